#!/usr/bin/env bash
# gweave preview of every kind of file gweave makes: mix colours (and a purge-shifted
# transition), rotary output on its cylinder, raster drops; and the sim speed chart. Pixels are
# read back with Python's zlib (PNG from gweave: 8-bit RGB, filter bytes per row).
set -euo pipefail
P="$WORK/kinds"
mkdir -p "$P"
ROOT_DIR=$(cd "$DATA/../.." && pwd)
cp "$ROOT_DIR/examples/mix/bands.toml" "$P/bands.toml"
cat > "$P/png.py" <<'PY'
import struct, sys, zlib
def read(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", path
    pos, idat, w, h = 8, b"", 0, 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, colour = struct.unpack(">IIBB", body[:10])
            assert (depth, colour) == (8, 2), (depth, colour)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw, rows, prev, i = zlib.decompress(idat), [], bytearray(w * 3), 0
    for _ in range(h):
        f, line = raw[i], bytearray(raw[i + 1:i + 1 + w * 3]); i += 1 + w * 3
        for x in range(w * 3):
            a = line[x - 3] if x >= 3 else 0
            b, c = prev[x], prev[x - 3] if x >= 3 else 0
            p = a + b - c
            pr = a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else b if abs(p - b) <= abs(p - c) else c
            line[x] = (line[x] + [0, a, b, (a + b) // 2, pr][f]) & 255
        rows.append(line); prev = line
    return w, h, rows
def histogram(path, background=(0xf7, 0xf7, 0xf5)):
    w, h, rows = read(path)
    hist = {}
    for r in rows:
        for x in range(w):
            c = tuple(r[3 * x:3 * x + 3])
            if c != background:
                hist[c] = hist.get(c, 0) + 1
    return hist
PY
# 1. Mix colours: layer 5 is Blue, layer 15 Yellow (the dominant colour of each picture).
"$GWEAVE" mix "$DATA/cura/cura_torus.gcode" -c "$P/bands.toml" -o "$P/bands.gcode" > /dev/null
for l in 5 15; do
  "$GWEAVE" preview "$P/bands.gcode" -o "$P/mix$l.png" --layer $l --colour-by mix --mix-profile "$P/bands.toml" --size 300x300 -q > /dev/null
done
python3 - "$P" <<'PY'
import sys; sys.path.insert(0, sys.argv[1]); from png import histogram
blue = max(histogram(sys.argv[1] + "/mix5.png").items(), key=lambda kv: kv[1])[0]
yellow = max(histogram(sys.argv[1] + "/mix15.png").items(), key=lambda kv: kv[1])[0]
assert blue[2] > blue[0] and blue[2] > blue[1], blue
assert yellow[0] > 200 and yellow[1] > 180 and yellow[2] < 80, yellow
PY
# 2. Purge-shift moves the change to Magenta back into layer 18: that layer now shows the blend.
"$GWEAVE" purge-shift "$P/bands.gcode" -o "$P/shifted.gcode" --purge 60 --cross-layers > /dev/null 2>&1
"$GWEAVE" preview "$P/bands.gcode" -o "$P/l9.png" --layer 18 --colour-by mix --mix-profile "$P/bands.toml" --size 300x300 -q > /dev/null
"$GWEAVE" preview "$P/shifted.gcode" -o "$P/l9s.png" --layer 18 --colour-by mix --mix-profile "$P/bands.toml" --size 300x300 -q > /dev/null
python3 - "$P" <<'PY'
import sys; sys.path.insert(0, sys.argv[1]); from png import histogram
def orange(hist):  # blends of yellow (G 224) into magenta (G 16): red, green in between
    return sum(n for c, n in hist.items() if c[0] > 200 and 40 < c[1] < 200)
before, after = orange(histogram(sys.argv[1] + "/l9.png")), orange(histogram(sys.argv[1] + "/l9s.png"))
assert before < 50 and after > 500, (before, after)
PY
# 3. Rotary: a tube drawn from the top is as wide as its diameter, not its circumference.
"$GWEAVE" rotary tube -o "$P/tube.gcode" --mandrel-diameter 20 --length 30 --layers 2 > /dev/null
"$GWEAVE" preview "$P/tube.gcode" -o "$P/tube.png" --size 400x400 -q > /dev/null
python3 - "$P" <<'PY'
import sys; sys.path.insert(0, sys.argv[1]); from png import read
w, h, rows = read(sys.argv[1] + "/tube.png")
lit = [y for y in range(h) if tuple(rows[y][3 * (w // 2):3 * (w // 2) + 3]) != (0xf7, 0xf7, 0xf5)]
width_px, length_px = lit[-1] - lit[0] + 1, None
cols = [x for x in range(w) if tuple(rows[h // 2][3 * x:3 * x + 3]) != (0xf7, 0xf7, 0xf5)]
length_px = cols[-1] - cols[0] + 1
# 30 mm long, 2 x 10.4 = 20.8 mm across (nozzle radius of the outer layer): ratio 0.69.
assert abs(width_px / length_px - 20.8 / 30.0) < 0.05, (width_px, length_px)
PY
# 4. Raster: the drops of a layer of the badge cover the image's black pixels.
"$GWEAVE" raster "$ROOT_DIR/examples/raster/layers" -o "$P/badge.gcode" --invert > /dev/null
"$GWEAVE" preview "$P/badge.gcode" -o "$P/badge.png" --layer 0 --size 300x300 -q > /dev/null
python3 - "$P" <<'PY'
import sys; sys.path.insert(0, sys.argv[1]); from png import histogram
lit = sum(histogram(sys.argv[1] + "/badge.png").values())
assert 20000 < lit < 80000, lit
PY
# 5. The speed chart: a PNG 1000 x 640 (speed above, time per layer below) with the mean-speed
# colour on it.
"$GWEAVE" sim "$DATA/cura/cura_torus.gcode" --plot-speed "$P/speed.png" -q > /dev/null
python3 - "$P" <<'PY'
import sys; sys.path.insert(0, sys.argv[1]); from png import read
w, h, rows = read(sys.argv[1] + "/speed.png")
assert (w, h) == (1000, 640), (w, h)
mean = sum(1 for r in rows for x in range(w) if tuple(r[3 * x:3 * x + 3]) == (30, 90, 200))
assert mean > 1000, mean
PY
echo "45_preview_kinds: ok"
