#!/usr/bin/env bash
# `make demo`: the main jobs on bundled real slicer output, results written to OUT (default out/).
# Each capability adds its own step script examples/demo.d/NN_<name>.sh, run in order.
set -euo pipefail
GWEAVE=$(realpath "${1:-target/release/gweave}")
ROOT=$(cd "$(dirname "$0")/.." && pwd)
OUT=$(mkdir -p "${2:-out}" && realpath "${2:-out}")
DATA="$ROOT/tests/data"
export GWEAVE ROOT OUT DATA

echo "== gweave stats: what each real slicer file will print"
for f in prusaslicer/pr_bunny_3tool_rel.gcode cura/cura_dual.gcode slic3r/slic3r_cone_2tool.gcode; do
  "$GWEAVE" stats "$DATA/$f" --report "$OUT/stats-$(basename "$f" .gcode).json"
done
echo "== gweave check"
"$GWEAVE" check "$DATA/prusaslicer/pr_torus_pva.gcode" --bed 200,200,200 --report "$OUT/check-pr_torus_pva.json"
echo "== gweave cat: byte-exact round trip of every fixture"
for f in "$DATA"/*/*.gcode; do
  "$GWEAVE" cat "$f" -o "$OUT/roundtrip.gcode" -q
  cmp "$f" "$OUT/roundtrip.gcode" && echo "  identical: ${f#"$DATA"/}"
done
rm -f "$OUT/roundtrip.gcode"
for step in "$ROOT"/examples/demo.d/[0-9]*.sh; do
  [ -e "$step" ] || continue
  bash "$step"
done
echo "== results in $OUT"
ls -1 "$OUT"
echo "== the gweave command: $GWEAVE (export PATH=\"$(dirname "$GWEAVE"):\$PATH\" to type gweave)"
