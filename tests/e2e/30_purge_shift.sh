#!/usr/bin/env bash
# purge-shift end to end: the CLI as a PrusaSlicer post-processing script (in place, file name
# last), the JSON report, the config file, the block fallback through the virtual printer, and
# the refusal of unknown fallbacks and of a file for a nozzle per tool.
# Gets GWEAVE, PYGWEAVE, DATA, WORK from run.sh.
set -euo pipefail

# 1. Slic3r, absolute E: T1 moves from line 553 to a split inside line 509 (E21.80781 = 24.30781 - 2.5);
#    the output has the run's header on line 1, so the split is on lines 510 and 515, with T0's
#    10 mm tool-change retraction before T1 (in the file's E coordinates) and E and the feed
#    rate put back after it.
"$GWEAVE" purge-shift "$DATA/slic3r/slic3r_cone_2tool.gcode" -o "$WORK/cone.gcode" --purge 2.5 -q \
  --report "$WORK/cone.json" > /dev/null 2>&1
[ "$(sed -n 510,515p "$WORK/cone.gcode" | tr '\n' '|')" = "G1 X104.44317 Y87.09572 E21.80781|G1 E11.80781 F2400|T1|G92 E21.80781|G1 F1800|G1 X104.913 Y87.264 E21.85317|" ] \
  || { echo "slic3r split lines: $(sed -n 510,515p "$WORK/cone.gcode")"; exit 1; }
python3 - "$WORK/cone.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
assert len(r["changes"]) == 108, len(r["changes"])
c = r["changes"][0]
assert c["change_lines"] == [553] and c["output_line"] == 512 and c["achieved_mm"] == 2.5, c
assert abs(r["achieved_mm"] - 241.02) < 0.01, r["achieved_mm"]
PY
# Same number of lines plus one per split; same number of T lines.
[ "$(grep -c '^T' "$WORK/cone.gcode")" = "$(grep -c '^T' "$DATA/slic3r/slic3r_cone_2tool.gcode")" ] \
  || { echo "T count changed"; exit 1; }

# 2. As a PrusaSlicer post-processing script: options first, the file name last, in place.
cp "$DATA/prusaslicer/pr_bunny_3tool_rel.gcode" "$WORK/bunny.gcode"
"$GWEAVE" purge-shift --purge 2.5 --in-place --no-backup -q "$WORK/bunny.gcode" > /dev/null 2>&1
[ ! -e "$WORK/bunny.gcode.bak" ] || { echo "backup left"; exit 1; }
#    T2's retraction and T0's unretraction go with the change (relative E).
[ "$(sed -n 764,769p "$WORK/bunny.gcode" | tr '\n' '|')" = "G1 X70.82035 Y87.24949 E1.21026|G1 E-10 F2400|T0|G1 E10 F2400|G1 F3600|G1 X70.555 Y86.738 E0.04197|" ] \
  || { echo "bunny split lines: $(sed -n 764,769p "$WORK/bunny.gcode")"; exit 1; }

# 3. Config file with a per-pair table, crossing layers, JSON on stdout.
cat > "$WORK/purge.toml" <<'TOML'
purge_mm = 2.5
cross_layers = true
[[pair]]
from = 1
to = 0
purge_mm = 1.0
TOML
#    Cura's dual file as for one nozzle (its temperatures for named tools made comments, as
#    `gweave mix` does): purge-shift refuses a nozzle per tool (6.).
sed -E 's/^(M10[49] T)/;\1/' "$DATA/cura/cura_dual.gcode" > "$WORK/dual_one_nozzle.gcode"
"$GWEAVE" purge-shift "$WORK/dual_one_nozzle.gcode" -o "$WORK/dual.gcode" -c "$WORK/purge.toml" --json -q \
  2> /dev/null > "$WORK/dual.json"
python3 - "$WORK/dual.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
assert len(r["changes"]) == 77
for c in r["changes"]:
    want = 1.0 if (c["from_tool"], c["to_tool"]) == (1, 0) else 2.5
    assert c["requested_mm"] == want, c
    assert abs(c["achieved_mm"] + c["shortfall_mm"] - want) < 1e-9, c
PY

# 4. --fallback block: every change gets the whole purge, the block sits right after the change
#    and returns: the virtual printer feeds exactly the fallback purge more, ends where the
#    original does, and no move leaves the default machine's bed.
"$GWEAVE" purge-shift "$DATA/slic3r/slic3r_cone_2tool.gcode" -o "$WORK/cone_block.gcode" --purge 2.5 \
  --fallback block -q --report "$WORK/cone_block.json" > /dev/null 2>&1
"$GWEAVE" sim "$DATA/slic3r/slic3r_cone_2tool.gcode" --json -q > "$WORK/sim_in.json"
"$GWEAVE" sim "$WORK/cone_block.gcode" --json -q > "$WORK/sim_block.json"
python3 - "$WORK/cone_block.json" "$WORK/sim_in.json" "$WORK/sim_block.json" "$WORK/cone_block.gcode" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
a, b = json.load(open(sys.argv[2])), json.load(open(sys.argv[3]))
changes = r["changes"]
assert len(changes) == 108 and all(c["shortfall_mm"] == 0 and c["achieved_mm"] == 2.5 for c in changes)
assert abs(r["moved_mm"] - 241.02) < 0.01 and abs(r["fallback_mm"] - 28.98) < 0.01, r
blocks = [c for c in changes if c["fallback_mm"] > 0]
assert len(blocks) == 29, len(blocks)
lines = open(sys.argv[4]).read().split("\n")
for c in blocks:
    # 0-based index of the block's first line: after the change lines and the new tool's
    # unretraction moved with them.
    after = c["retraction"]["lines_after"] if c["retraction"] else 0
    first = c["output_line"] + len(c["change_lines"]) - 1 + after
    assert lines[first].startswith("; gweave purge-shift: purge T"), (c, lines[first])
    assert lines[first + c["fallback_lines"] - 1] == "; gweave purge-shift: end purge", c
fed = sum(b["filament_mm"]) - sum(a["filament_mm"])
assert abs(fed - r["fallback_mm"]) < 1e-6, (fed, r["fallback_mm"])
assert b["position"][:3] == a["position"][:3] and b["count"][:3] == a["count"][:3], (a["position"], b["position"])
for kind in ("out_of_bounds", "below_bed"):
    assert b["warning_counts"].get(kind, 0) == a["warning_counts"].get(kind, 0), kind
PY

# 5. An unknown fallback is refused with a clear error and no output.
if "$GWEAVE" purge-shift "$DATA/cura/cura_dual.gcode" -o "$WORK/x.gcode" --purge 2 --fallback wipe 2> "$WORK/err"; then
  echo "unknown fallback accepted"; exit 1
fi
grep -q 'unknown fallback "wipe" (known: partial, block, tower)' "$WORK/err" || { echo "error text: $(cat "$WORK/err")"; exit 1; }
[ ! -e "$WORK/x.gcode" ] || { echo "output written"; exit 1; }

# 6. A file sliced for a nozzle per tool (Cura's dual extrusion) is refused, naming the line
#    that shows it and the way out, with no output.
if "$GWEAVE" purge-shift "$DATA/cura/cura_dual.gcode" -o "$WORK/y.gcode" --purge 2 2> "$WORK/err"; then
  echo "a file for a nozzle per tool accepted"; exit 1
fi
if ! grep -q "cura_dual.gcode:4249: here, at the first command after the temperatures, T0's nozzle is at 200 °C (set on line 4247) and T1's at 215 °C (line 3974): the file heats a nozzle per tool" "$WORK/err" \
  || ! grep -q 'or run `gweave mix` on it first' "$WORK/err"; then
  echo "error text: $(cat "$WORK/err")"; exit 1
fi
[ ! -e "$WORK/y.gcode" ] || { echo "output written"; exit 1; }
