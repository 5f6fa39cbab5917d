#!/usr/bin/env bash
# See it: a top view by tool, an isometric view by feature, a before/after of purge-shift, and
# the offline HTML viewer.
set -euo pipefail
echo "== gweave preview"
"$GWEAVE" preview "$DATA/cura/cura_dual.gcode" -o "$OUT/dual-layer60.png" --layer 60
"$GWEAVE" preview "$DATA/prusaslicer/pr_torus_pva.gcode" -o "$OUT/torus-iso.png" --view iso --colour-by feature
"$GWEAVE" preview "$DATA/slic3r/slic3r_cone_2tool.gcode" --compare "$OUT/slic3r_cone.shifted.gcode" \
  -o "$OUT/cone-purge-shift.png" --layer 20
"$GWEAVE" preview "$DATA/cura/cura_dual.gcode" -o "$OUT/cura_dual.html"
