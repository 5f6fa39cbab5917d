#!/usr/bin/env bash
# See it: a top view by tool, an isometric view by feature, a before/after of purge-shift, the
# predicted colours of a mixing file (before and after purge-shift), a rotary tube on its mandrel,
# binder-jet drops, the speed chart of the virtual printer, and the offline HTML viewer.
set -euo pipefail
echo "== gweave preview"
"$GWEAVE" preview "$DATA/cura/cura_dual.gcode" -o "$OUT/dual-layer60.png" --layer 60
"$GWEAVE" preview "$DATA/prusaslicer/pr_torus_pva.gcode" -o "$OUT/torus-iso.png" --view iso --colour-by feature
"$GWEAVE" preview "$DATA/slic3r/slic3r_cone_2tool.gcode" --compare "$OUT/slic3r_cone.shifted.gcode" \
  -o "$OUT/cone-purge-shift.png" --layer 20
BANDS="$ROOT/examples/mix/bands.toml"
"$GWEAVE" mix "$DATA/cura/cura_torus.gcode" -c "$BANDS" -o "$OUT/torus-bands.gcode" -q
"$GWEAVE" purge-shift "$OUT/torus-bands.gcode" -o "$OUT/torus-bands.shifted.gcode" --purge 8 \
  --cross-layers -q > /dev/null 2>&1
for f in torus-bands torus-bands.shifted; do
  "$GWEAVE" preview "$OUT/$f.gcode" -o "$OUT/$f-iso.png" --view iso --colour-by mix --mix-profile "$BANDS"
done
"$GWEAVE" preview "$OUT/tube.gcode" -o "$OUT/tube-preview.png" --view iso --colour-by layer
"$GWEAVE" preview "$OUT/sphere.inkjet.gcode" -o "$OUT/sphere-drops.png" --layer 100
"$GWEAVE" sim "$DATA/cura/cura_torus.gcode" --plot-speed "$OUT/torus-speed.png" -q > /dev/null
"$GWEAVE" preview "$DATA/cura/cura_dual.gcode" -o "$OUT/cura_dual.html"
