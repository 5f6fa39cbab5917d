#!/usr/bin/env bash
# Raster benchmark (issue 7): 500 layers of 2000 x 2000 px to inkjet G-code in under 10 s.
# Usage: bash bench/raster.sh path/to/gweave
# The layer images are made once into bench/data/raster/ (git-ignored): a solid sphere 100 mm
# across, sliced by `gweave slice-raster` at 0.05 mm pixels and 0.2 mm layers, i.e. 500 layers of
# 2000 x 2000 px (1-bit PNG). References measured in the same run: `cat` of the PNG files (the
# I/O floor) and Python's zlib decompressing every PNG's image data (the decode floor of any
# PNG reader).
set -euo pipefail
GWEAVE=$(realpath "${1:?usage: bench/raster.sh path/to/gweave}")
ROOT=$(cd "$(dirname "$0")/.." && pwd)
DATA="$ROOT/bench/data/raster"
LAYERS="$DATA/layers"
mkdir -p "$DATA"

if [ "$(ls "$LAYERS" 2>/dev/null | grep -c '\.png$')" != 500 ]; then
  echo "raster bench: making 500 layers of 2000 x 2000 px (once) ..."
  python3 - "$DATA/sphere.stl" <<'PY'
import math, struct, sys
# UV sphere, radius 50 mm, centre (50, 50, 50): 180 latitude bands x 360 segments.
r, lat, lon = 50.0, 180, 360
def p(i, j):
    th, ph = math.pi * i / lat, 2 * math.pi * j / lon
    return (50 + r * math.sin(th) * math.cos(ph), 50 + r * math.sin(th) * math.sin(ph), 50 + r * math.cos(th))
tris = []
for i in range(lat):
    for j in range(lon):
        a, b, c, d = p(i, j), p(i, j + 1), p(i + 1, j + 1), p(i + 1, j)
        if i > 0: tris.append((a, b, c))
        if i + 1 < lat: tris.append((a, c, d))
with open(sys.argv[1], "wb") as f:
    f.write(b"\0" * 80 + struct.pack("<I", len(tris)))
    for t in tris:
        f.write(struct.pack("<12fH", 0, 0, 0, *t[0], *t[1], *t[2], 0))
PY
  rm -rf "$LAYERS"
  "$GWEAVE" slice-raster "$DATA/sphere.stl" --layer-height 0.2 --pixel-mm 0.05 -o "$LAYERS" --json > "$DATA/slice.json"
fi
python3 -c "
import json, sys; g = json.load(open(sys.argv[1]))['grid']
assert (g['layers'], g['width_px'], g['height_px']) == (500, 2000, 2000), g" "$DATA/slice.json"

now() { date +%s.%N; }
t0=$(now); cat "$LAYERS"/*.png > /dev/null; t1=$(now)
python3 - "$LAYERS" <<'PY' > /dev/null
import os, struct, sys, zlib
d = sys.argv[1]
for n in sorted(os.listdir(d)):
    b = open(os.path.join(d, n), "rb").read()
    pos, idat = 8, []
    while pos < len(b):
        (ln,) = struct.unpack(">I", b[pos:pos + 4])
        if b[pos + 4:pos + 8] == b"IDAT":
            idat.append(b[pos + 8:pos + 8 + ln])
        pos += 12 + ln
    zlib.decompress(b"".join(idat))
PY
t2=$(now)
# G-code to a pipe into /dev/null: the generator's own speed (the 10 s target) ...
t3=$(now)
"$GWEAVE" raster "$LAYERS" --fast-estimate -o - > /dev/null
t4=$(now)
# ... and to a file on disk, with its size.
"$GWEAVE" raster "$LAYERS" --fast-estimate -o "$DATA/out.gcode" --json > "$DATA/raster.json"
t5=$(now)
size=$(stat -c %s "$DATA/out.gcode")
rm -f "$DATA/out.gcode"
python3 - "$t0" "$t1" "$t2" "$t3" "$t4" "$t5" "$size" "$DATA/raster.json" <<'PY'
import json, sys
t = [float(v) for v in sys.argv[1:7]]
size, r = int(sys.argv[7]), json.load(open(sys.argv[8]))
cat_s, zlib_s, pipe_s, file_s = t[1] - t[0], t[2] - t[1], t[4] - t[3], t[5] - t[4]
print("raster bench: 500 layers of 2000 x 2000 px (solid sphere, 1-bit PNG)")
print(f"  cat of the PNGs (I/O floor)        {cat_s:7.2f} s")
print(f"  python zlib of the PNGs            {zlib_s:7.2f} s")
print(f"  gweave raster -> /dev/null         {pipe_s:7.2f} s   {pipe_s / zlib_s:5.2f} x zlib   target < 10 s: {'PASS' if pipe_s < 10 else 'FAIL'}")
print(f"  gweave raster -> file              {file_s:7.2f} s   ({size / 1e9:.2f} GB G-code, {size / 1e6 / file_s:.0f} MB/s)")
print(f"  {r['columns_fired']} columns fired, {r['bands_printed']} bands, {sum(r['drops_per_head'])} drops")
PY
