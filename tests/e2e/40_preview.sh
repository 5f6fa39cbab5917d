#!/usr/bin/env bash
# gweave preview: PNG, SVG and HTML from the CLI and Python, checked by value.
set -euo pipefail
F="$DATA/cura/cura_dual.gcode"
"$GWEAVE" preview "$F" -o "$WORK/p.png" --layer 60 --size 400x300 -q > /dev/null
# PNG signature and IHDR size (bytes 16..24: width, height big-endian).
[ "$(head -c 8 "$WORK/p.png" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a ] || { echo "not a PNG"; exit 1; }
[ "$(od -An -tu1 -j16 -N8 "$WORK/p.png" | tr -s ' ' | sed 's/^ //')" = "0 0 1 144 0 0 1 44" ] || { echo "PNG size"; exit 1; }
"$GWEAVE" preview "$F" -o "$WORK/p.svg" --layer 60 --report "$WORK/pv.json" > "$WORK/pv.txt"
n=$(grep -o '<path ' "$WORK/p.svg" | wc -l)
[ "$n" -gt 10 ] || { echo "svg paths: $n"; exit 1; }
# The summary and the report say what was drawn: layer 60, its lines, the two tools' legend.
grep -q '^  layer           60$' "$WORK/pv.txt" || { echo "preview summary: $(cat "$WORK/pv.txt")"; exit 1; }
python3 - "$WORK/pv.json" "$WORK/p.svg" <<'PY'
import json, os, sys
r = json.load(open(sys.argv[1]))
assert (r["format"], r["layers_drawn"], r["bytes"]) == ("svg", [60, 60], os.path.getsize(sys.argv[2])), r
assert [e["label"] for e in r["legend"]] == ["T0", "T1"] and r["strokes"] > 500, r
PY
"$GWEAVE" preview "$F" -o "$WORK/p.html" -q > /dev/null
grep -q '"slicer":"cura"' "$WORK/p.html" || { echo "html stats"; exit 1; }
if grep -q 'https\?://' "$WORK/p.html"; then echo "html refers to the network"; exit 1; fi
# Python writes the same PNG bytes as the CLI.
"$(dirname "$PYGWEAVE")/python" - "$F" "$WORK/p.png" <<'PY'
import sys, gweave
png = gweave.preview(sys.argv[1], layer=60, size=(400, 300))
assert png == open(sys.argv[2], "rb").read(), "python and CLI PNGs differ"
PY
# Bad input: unknown extension and an empty layer range are errors with exit 1 / 2.
if "$GWEAVE" preview "$F" -o "$WORK/p.jpg" 2>/dev/null; then echo "accepted .jpg"; exit 1; fi
if "$GWEAVE" preview "$F" -o "$WORK/p.png" --layers 9-3 2>/dev/null; then echo "accepted 9-3"; exit 1; fi
