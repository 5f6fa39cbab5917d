#!/usr/bin/env bash
# gweave estimate on real files: the same motion time and E steps as the virtual printer with
# the same profile, the human summary, a line out of range skipped as sim refuses it, and a bad
# file stopping with its line and exit 1.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
KLIPPER="$ROOT/examples/machines/klipper.toml"

for F in "$DATA/cura/cura_torus.gcode" "$DATA/prusaslicer/pr_bunny_3tool_rel.gcode"; do
  "$GWEAVE" estimate "$F" --machine "$KLIPPER" --steps --json -q > "$WORK/est.json"
  "$GWEAVE" sim "$F" --machine "$KLIPPER" --json -q > "$WORK/sim.json"
  python3 - "$WORK/est.json" "$WORK/sim.json" <<'PY'
import json, sys
e, s = (json.load(open(p)) for p in sys.argv[1:])
assert (e["planner"], e["steps_counted"]) == ("klipper", True), e["planner"]
assert e["motion_s"] == s["time"]["motion_s"], (e["motion_s"], s["time"]["motion_s"])
assert e["dwell_s"] == s["time"]["dwell_s"]
assert e["steps"]["axes"][3] == s["steps"]["axes"][3] > 0
assert len(e["layer_s"]) == len(s["layer_s"])
parts = e["motion_s"] + e["dwell_s"] + e["overhead_s"]
assert abs(parts - e["total_s"]) < 1e-6, e
PY
done

"$GWEAVE" estimate "$DATA/cura/cura_torus.gcode" > "$WORK/est.txt"
grep -q "on RAMPS 1.4 Marlin (default) (marlin planner)" "$WORK/est.txt"
grep -Eq "^  time +0h 12m 03s" "$WORK/est.txt"  # 722.7 s, Marlin's planner in whole steps

# A value outside its command's range (M204 S-5) is refused and skipped, as the virtual printer
# refuses it, and said in the summary; a limit the planner cannot take (Klipper's
# SET_VELOCITY_LIMIT has no declared range) stops the estimate with its line and exit 1.
printf 'G1 X1 F600\nG1 X2\nM204 S-5\n' > "$WORK/refused.gcode"
"$GWEAVE" estimate "$WORK/refused.gcode" > "$WORK/est.txt"
grep -q "refused         1 lines, skipped as the printer refuses them (first: line 3, M204 S = -5 is out of range: 0.001 to 1000000 mm/s²; see gweave check)" "$WORK/est.txt" || { cat "$WORK/est.txt"; exit 1; }
printf 'G1 X1 F600\nG1 X2\nSET_VELOCITY_LIMIT ACCEL=-5\n' > "$WORK/bad.gcode"
if "$GWEAVE" estimate "$WORK/bad.gcode" --machine "$KLIPPER" 2> "$WORK/err" > /dev/null; then
  echo "an invalid SET_VELOCITY_LIMIT was accepted"; exit 1
fi
grep -qx "gweave: error: $WORK/bad.gcode:3: \[motion.corners\] max_accel_mm_s2 = -5 is out of range: 0.001 to 1000000 mm/s²" "$WORK/err" || { cat "$WORK/err"; exit 1; }
