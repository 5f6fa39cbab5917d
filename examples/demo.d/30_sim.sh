#!/usr/bin/env bash
# The virtual printer runs a real file: time, steps, heaters, and a temperature plot.
set -euo pipefail
echo "== gweave sim: a Cura print on the virtual Marlin printer"
"$GWEAVE" sim "$DATA/cura/cura_torus.gcode" --plot "$OUT/temps.png" --report "$OUT/sim-report.json" -q
echo "== gweave sim: the mixing output, on a 4-input mixing machine"
"$GWEAVE" sim "$OUT/cura_torus.mix.gcode" --machine "$ROOT/examples/machines/mixing-4in.toml" -q | tail -6
