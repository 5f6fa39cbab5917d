#!/usr/bin/env bash
# gweave sim on a real Cura file: JSON report values, the temperature plot, a fault halting
# the machine with exit code 1 and Marlin's Error line, and an inkjet canvas written as PNG.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
F="$DATA/cura/cura_torus.gcode"

"$GWEAVE" sim "$F" --json --plot "$WORK/temps.png" -q > "$WORK/sim.json"
python3 - "$WORK/sim.json" "$WORK/temps.png" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
f = r["filament_mm"][0]
assert abs(f - 773.6185) < 1e-6, f
# The E motor ends at round(filament * 500 steps/mm); X Y Z at their final positions.
assert r["count"][3] == round(f * 500), (r["count"][3], f)
for i, spu in enumerate([80, 80, 4000]):
    assert r["count"][i] == round(r["position"][i] * spu), (i, r["count"], r["position"])
t = r["time"]
parts = t["motion_s"] + t["dwell_s"] + t["heating_s"] + t["homing_s"] + t["overhead_s"]
assert abs(parts - t["total_s"]) < 1e-6, t
assert len(r["layer_s"]) == 28 and not r["halted"]
assert open(sys.argv[2], "rb").read(8) == b"\x89PNG\r\n\x1a\n"
PY

# A cartridge that falls off mid-print: thermal runaway, exit 1.
if "$GWEAVE" sim "$F" --fault hotend-cartridge-off@400s -q > "$WORK/halt.txt" 2>&1; then
  echo "a halted run exited 0"; exit 1
fi
grep -q "Error:Thermal Runaway, system stopped! Heater_ID: 0" "$WORK/halt.txt"

# Inkjet: two fires on the C6602 machine, written as a 1-bit PNG canvas.
printf 'G28\nG1 X20.1323 Y20.1323 Z0.1 F3000\nM400\nM700 P0 S5\n' > "$WORK/ink.gcode"
"$GWEAVE" sim "$WORK/ink.gcode" --machine "$ROOT/examples/machines/inkjet-c6602.toml" \
  --raster-out "$WORK/ink" --json -q > "$WORK/ink.json"
python3 -c "import json,sys; r=json.load(open(sys.argv[1])); assert r['inkjet']['drops_per_head']==[2], r['inkjet']" "$WORK/ink.json"
[ -s "$WORK/ink/layer_00000_head0.png" ]
