#!/usr/bin/env bash
# Binder jetting: a PrusaSlicer SLA export to inkjet G-code, then the virtual printer's dots.
set -euo pipefail
echo "== gweave raster: sphere.sl1 to M700 G-code"
"$GWEAVE" raster "$DATA/sla/sphere.sl1" -o "$OUT/sphere.inkjet.gcode" --report "$OUT/raster-report.json" -q
echo "== gweave sim: the inkjet printer deposits the dots (PNG per layer)"
mkdir -p "$OUT/dots"
"$GWEAVE" sim "$OUT/sphere.inkjet.gcode" --machine "$ROOT/examples/machines/inkjet-c6602.toml" \
  --raster-out "$OUT/dots" -q | tail -3
