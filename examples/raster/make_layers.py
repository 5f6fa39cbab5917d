"""Writes the example BMP stack in layers/: a 40 x 40 px smiley badge (10.6 mm at 96 dpi),
8 layers, as 1-bit BMPs with white = binder. Rows are written bottom-up as BMP stores them, so
the picture shows the +Y-up view; print it with `gweave raster layers/ --flip-y`.
Run: python3 examples/raster/make_layers.py (no dependencies)."""

import math
import os
import struct

W = H = 40
LAYERS = 8


def inked(layer: int, x: int, y: int) -> bool:
    """Pixel (x, y) of the picture, y = 0 at the top."""
    cx, cy = x + 0.5 - W / 2, y + 0.5 - H / 2
    r = math.hypot(cx, cy)
    radius = 19.0 - 0.5 * layer  # a slightly domed badge
    if r > radius:
        return False
    if layer < 2:  # solid base
        return True
    eye = any(math.hypot(cx - ex, cy + 6) < 3 for ex in (-7, 7))
    smile = 9 < r < 12.5 and cy > 3
    return not (eye or smile)


def bmp_1bit(rows):
    stride = (W + 31) // 32 * 4
    pixels = b""
    for row in reversed(rows):  # BMP stores the bottom row first
        bits = 0
        for x, on in enumerate(row):
            bits |= on << (stride * 8 - 1 - x)
        pixels += bits.to_bytes(stride, "big")
    palette = b"\x00\x00\x00\x00" + b"\xff\xff\xff\x00"  # index 0 black, 1 white
    offset = 14 + 40 + len(palette)
    header = b"BM" + struct.pack("<IHHI", offset + len(pixels), 0, 0, offset)
    info = struct.pack("<IiiHHIIiiII", 40, W, H, 1, 1, 0, len(pixels), 3780, 3780, 2, 0)
    return header + info + palette + pixels


here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "layers")
os.makedirs(here, exist_ok=True)
for k in range(LAYERS):
    rows = [[inked(k, x, y) for x in range(W)] for y in range(H)]
    with open(os.path.join(here, f"badge_{k}.bmp"), "wb") as f:
        f.write(bmp_1bit(rows))
