#!/usr/bin/env bash
# Mixing hotend: the seed's layer schedule on a Cura file, and the palette as a swatch image.
set -euo pipefail
echo "== gweave mix: colour changes by layer on a Cura file (the seed's example)"
"$GWEAVE" mix "$DATA/cura/cura_torus.gcode" -c "$ROOT/examples/mix/seed_layers.toml" \
  -o "$OUT/cura_torus.mix.gcode" --report "$OUT/mix-report.json" --palette-png "$OUT/palette.png" -q
echo "== gweave mix: PrusaSlicer soluble support as 100 % material 2"
"$GWEAVE" mix "$DATA/prusaslicer/pr_torus_pva.gcode" -c "$ROOT/examples/mix/pva_support.toml" \
  -o "$OUT/pr_torus_pva.mix.gcode" -q
