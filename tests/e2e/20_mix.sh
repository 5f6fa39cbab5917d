#!/usr/bin/env bash
# gweave mix end to end: the seed's layer schedule on Cura's torus, a tool map as a PrusaSlicer
# post-processing script (--in-place, path last), the wizard fed by a pipe, and the swatch PNG.
# Variables from run.sh: GWEAVE, PYGWEAVE, DATA, WORK.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
EX="$ROOT/examples/mix"

# 1. The seed's schedule: two changes (layers 10 and 25), two 25 mm purges, Z capped.
"$GWEAVE" mix "$DATA/cura/cura_torus.gcode" -c "$EX/seed_layers.toml" -o "$WORK/torus.mix.gcode" -q \
  --report "$WORK/torus.json"
python3 - "$WORK/torus.json" "$WORK/torus.mix.gcode" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
assert r["changes"] == 2 and r["purge"]["count"] == 2, (r["changes"], r["purge"])
assert abs(r["purge"]["filament_mm"] - 50.0) < 1e-9
names = [m["name"] for m in r["mixes"]]
assert names == ["Orange", "Pink", "Blue"], names
assert r["mixes"][1]["layers"] == [[10, 24]], r["mixes"][1]["layers"]
text = open(sys.argv[2]).read().splitlines()
# Orange defined with the seed's ratios (normalised, 4 decimals) before the first T0.
i = text.index("M164 S0")
assert text[i - 4:i] == ["M163 S0 P0", "M163 S1 P0.1717", "M163 S2 P0.8283", "M163 S3 P0"], text[i - 4:i]
assert text.index("T0") > i
# Pink selected right after layer 10 starts, before its first extrusion.
l10 = text.index(";LAYER:10")
t1 = text.index("T1")
assert l10 < t1 < text.index(";LAYER:11")
PY

# 2. Flags alone (default profile: the seed's CMYW inputs, purge and Z cap).
"$GWEAVE" mix "$DATA/cura/cura_torus.gcode" --at-layer 0=Orange --at-layer 10=Magenta -o "$WORK/flags.gcode" \
  --json -q > "$WORK/flags.json"
python3 -c "import json,sys; r=json.load(open(sys.argv[1])); assert (r['changes'], r['purge']['count']) == (1, 1), r" \
  "$WORK/flags.json"
#    To standard output: the G-code alone (the summary goes to stderr), the same bytes as -o FILE.
"$GWEAVE" mix "$DATA/cura/cura_torus.gcode" --at-layer 0=Orange --at-layer 10=Magenta -o - \
  2> "$WORK/flags.err" | cmp - "$WORK/flags.gcode"
grep -q '^changes *1$' "$WORK/flags.err"

# 3. As PrusaSlicer calls a post-processing script: options first, the file path last, in place.
cp "$DATA/prusaslicer/pr_torus_pva.gcode" "$WORK/pva.gcode"
"$GWEAVE" mix -c "$EX/pva_support.toml" --in-place --no-backup -q "$WORK/pva.gcode"
[ ! -e "$WORK/pva.gcode.bak" ]
grep -q "^M163 S3 P1$" "$WORK/pva.gcode"
[ "$(grep -c '^; gweave mix: purge' "$WORK/pva.gcode")" = 2 ]

#    PrusaSlicer's RepRapFirmware flavour (said only at the end of the file), no dialect in the
#    profile: RepRapFirmware tools (M563/M567/M568), which the virtual printer with a 4-input
#    mixing hotend runs without an unknown command, splitting E as the report says.
"$GWEAVE" mix "$DATA/prusaslicer/pr_sphere_rrf_fwretract.gcode" --at-layer 0=Orange --at-layer 50=Blue \
  -o "$WORK/rrf.gcode" --json -q > "$WORK/rrf.json"
grep -q "^M567 P1 E0.5:0.5:0:0$" "$WORK/rrf.gcode"
! grep -q "^M16[34] " "$WORK/rrf.gcode"
"$GWEAVE" sim "$WORK/rrf.gcode" --machine "$ROOT/examples/machines/mixing-4in.toml" --json -q > "$WORK/rrf.sim.json"
python3 - "$WORK/rrf.json" "$WORK/rrf.sim.json" <<'PY'
import json, sys
mix, sim = (json.load(open(p)) for p in sys.argv[1:])
assert (mix["dialect"], mix["flavour"]) == ("reprapfirmware", "reprapfirmware"), (mix["dialect"], mix["flavour"])
assert sim["unknown_commands"] == {} and sim["warning_counts"] == {}, sim["warning_counts"]
# The sim counts net filament: the file's last firmware retraction (1 mm of Blue, 0.5:0.5:0:0)
# is never undone. Beyond that, whole steps of each input (500 per mm) and the report's 3 decimals.
for want, got, retracted in zip(mix["filament_per_input_mm"], sim["mixing_input_mm"], [0.5, 0.5, 0, 0]):
    assert abs(want - retracted - got) <= 0.01, (mix["filament_per_input_mm"], sim["mixing_input_mm"])
PY

#    --dialect overrides the file's flavour, and Python's dialect= does the same.
"$GWEAVE" mix "$DATA/prusaslicer/pr_sphere_rrf_fwretract.gcode" --at-layer 0=Orange --dialect marlin \
  -o "$WORK/rrf-marlin.gcode" -q > /dev/null
grep -q "^M164 S0$" "$WORK/rrf-marlin.gcode"
! grep -q "^M567 " "$WORK/rrf-marlin.gcode"
if [ -x "$PYGWEAVE" ]; then
  "$(dirname "$PYGWEAVE")/python" -c 'import sys, gweave; r = gweave.mix(sys.argv[1], sys.argv[2], at_layer=["0=Orange"], dialect="reprap"); assert r["dialect"] == "reprapfirmware", r["dialect"]' \
    "$DATA/cura/cura_torus.gcode" "$WORK/torus-rrf.gcode"
  grep -q "^M567 P0 E0:0.1717:0.8283:0$" "$WORK/torus-rrf.gcode"
fi
#    Through a pipe the same: the input is spooled once, so its flavour (named at the end) is
#    read first, and the output equals the file's own run but for the header's input name.
"$GWEAVE" mix <(cat "$DATA/prusaslicer/pr_sphere_rrf_fwretract.gcode") --at-layer 0=Orange -o "$WORK/piped.gcode" \
  2> "$WORK/piped.err" > /dev/null
"$GWEAVE" mix "$DATA/prusaslicer/pr_sphere_rrf_fwretract.gcode" --at-layer 0=Orange -o "$WORK/filed.gcode" -q
grep -q "^M567 " "$WORK/piped.gcode"
cmp -s "$WORK/piped.gcode" "$WORK/filed.gcode"

# 4. The wizard, answers piped: the seed's session.
printf '1\nn\nOrange\n0\nPink\ny\n0 0.6 0.1 0.3\n10\nBlue\n20\n\n\n\ny\n' \
  | "$GWEAVE" mix --wizard -c "$WORK/wiz.toml" > /dev/null
grep -q 'mix = "Pink"' "$WORK/wiz.toml"
"$GWEAVE" mix "$DATA/cura/cura_torus.gcode" -c "$WORK/wiz.toml" -o "$WORK/wiz.gcode" --json -q > "$WORK/wiz.json"
python3 -c "import json,sys; r=json.load(open(sys.argv[1])); assert r['changes'] == 2, r['changes']" "$WORK/wiz.json"

# 5. The job's mixes as a PNG swatch chart: a real PNG file.
"$GWEAVE" mix -c "$EX/seed_layers.toml" --palette-png "$WORK/palette.png"
head -c 8 "$WORK/palette.png" | od -An -tx1 | grep -q "89 50 4e 47 0d 0a 1a 0a"

# 6. The Python front end gives the same bytes.
if [ -x "$PYGWEAVE" ]; then
  "$PYGWEAVE" mix "$DATA/cura/cura_torus.gcode" -c "$EX/seed_layers.toml" -o "$WORK/py.gcode" -q > /dev/null
  cmp -s "$WORK/py.gcode" "$WORK/torus.mix.gcode"
fi
echo "20_mix: ok"
