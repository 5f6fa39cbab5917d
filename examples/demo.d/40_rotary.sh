#!/usr/bin/env bash
# Lathe-type printer: an interwoven helical tube, and a flat PrusaSlicer plate wrapped on a mandrel.
set -euo pipefail
echo "== gweave rotary tube"
"$GWEAVE" rotary tube -o "$OUT/tube.gcode" --mandrel-diameter 20 --length 20 --layers 4 --preview "$OUT/tube.png"
echo "== gweave rotary wrap"
"$GWEAVE" rotary wrap "$DATA/rotary/plate.gcode" -o "$OUT/sleeve.gcode" --mandrel-diameter 30 \
  --seam-rotation 7.5 --preview "$OUT/sleeve.png" | tail -4
