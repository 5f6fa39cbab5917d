#!/usr/bin/env bash
# The pictures of README.md and docs/ that gweave draws itself, made again from the bundled
# files with the current code: previews (PNG), charts (`sim --plot`), rotary previews and the
# calibration card. (The viewer's and OctoPrint's screenshots are taken in a browser
# by their tests, not here.)
# Usage: scripts/docs_images.sh [GWEAVE]   (default: target/release/gweave); `make docs-images`.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
G=$(realpath "${1:-$ROOT/target/release/gweave}")
IMG="$ROOT/docs/images"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
cd "$ROOT"
preview() { "$G" preview -q "$@"; }

# Plain files: a layer from the top, whole prints in 3D, one layer by speed.
preview tests/data/cura/cura_dual.gcode -o "$IMG/preview_top.png" --layer 60 --size 900x675
preview tests/data/prusaslicer/pr_bunny_3tool_rel.gcode -o "$IMG/preview_iso.png" --view iso \
  --colour-by feature --size 900x675
preview tests/data/cura/cura_dual.gcode -o "$IMG/preview_iso_tools.png" --view iso --size 900x675
preview tests/data/slic3r/slic3r_cone_2tool.gcode -o "$IMG/preview_speed.png" --layer 10 \
  --colour-by speed --size 900x675

# Before and after: the sphere's moves (T1) of layer 60 shifted by 2 mm in a copy.
python3 - tests/data/cura/cura_dual.gcode "$T/shifted.gcode" <<'PY'
import re, sys
layer, tool, out = None, 0, []
for line in open(sys.argv[1]):
    if line.startswith(";LAYER:"):
        layer = int(line[7:])
    elif re.match(r"T\d", line):
        tool = int(line[1])
    elif layer == 60 and tool == 1 and line.startswith(("G0 ", "G1 ")):
        line = re.sub(r"X([-\d.]+)", lambda m: f"X{float(m.group(1)) + 2:.3f}", line)
    out.append(line)
open(sys.argv[2], "w").writelines(out)
PY
preview tests/data/cura/cura_dual.gcode --compare "$T/shifted.gcode" -o "$IMG/preview_compare.png" \
  --layer 60 --size 1200x500

# Mixing and purge-shift (examples/mix/bands.toml: Blue, Yellow from layer 10, Magenta from 19).
BANDS=examples/mix/bands.toml
"$G" mix tests/data/cura/cura_torus.gcode -c "$BANDS" -o "$T/torus.mix.gcode" -q
"$G" purge-shift "$T/torus.mix.gcode" --purge-mm 60 --cross-layers -o "$T/torus.shift.gcode" -q
mix_preview() { preview "$@" --colour-by mix --mix-profile "$BANDS" --size 600x450; }
mix_preview "$T/torus.mix.gcode" -o "$IMG/preview_mix.png" --view iso
mix_preview "$T/torus.mix.gcode" -o "$IMG/preview_mix_switch.png" --layer 18
mix_preview "$T/torus.shift.gcode" -o "$IMG/preview_purge_shift.png" --layer 18
# The calibration card, in the colours predicted for the default filaments.
"$G" mix --calibration-card -c "$BANDS" -o "$T/card.gcode" --card-png "$IMG/mix_calibration_card.png" -q

# Rotary output on its cylinder, and the rotary commands' own previews.
"$G" rotary tube -c examples/rotary/tube.toml -o "$T/tube.gcode" -q --preview "$IMG/rotary_tube.png"
"$G" rotary wrap tests/data/rotary/plate.gcode -o "$T/sleeve.gcode" --mandrel-diameter 30 \
  --seam-rotation 7.5 -q --preview "$IMG/rotary_sleeve.png"
"$G" rotary tube -c examples/rotary/lattice.toml -o "$T/lattice.gcode" -q --preview "$IMG/rotary_lattice.png"
preview "$T/tube.gcode" -o "$IMG/preview_rotary_tube.png" --view iso --colour-by layer --size 600x450
preview "$T/sleeve.gcode" -o "$IMG/preview_rotary_sleeve.png" --view iso --colour-by feature --size 600x450

# Binder-jet raster output: the drops of every layer.
"$G" raster examples/raster/layers --invert -o "$T/raster.gcode" -q
preview "$T/raster.gcode" -o "$IMG/preview_raster.png" --view iso --colour-by layer --size 600x450

# Charts of the virtual printer.
"$G" sim tests/data/cura/cura_torus.gcode -q --plot "$IMG/sim_temperature.png" \
  --plot-speed "$IMG/sim_speed.png"
echo "pictures written to $IMG"
