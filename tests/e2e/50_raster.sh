#!/usr/bin/env bash
# Binder-jet raster: images and .sl1 archives to M700 G-code, test pattern, slice-raster.
# Gets GWEAVE, PYGWEAVE, DATA, WORK from run.sh (or run it alone: it sets defaults).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
GWEAVE=${GWEAVE:-$ROOT/target/release/gweave}
PYGWEAVE=${PYGWEAVE:-$ROOT/.venv/bin/gweave}
WORK=${WORK:-$(mktemp -d)}
EX="$ROOT/examples/raster"
RDATA="$ROOT/crates/gweave/tests/data/raster"
failed=0
fail() { echo "FAIL 50_raster: $*"; failed=1; }

# Checks a raster G-code file against its JSON report: M700/M578 lines = fire commands,
# every fire has P, every fire follows M400 (or a repeated fire of the same column), layers.
check_gcode() { # gcode json fire_code
  python3 - "$@" <<'PY'
import json, sys
g, rep, code = open(sys.argv[1]).read().splitlines(), json.load(open(sys.argv[2])), sys.argv[3]
fires = [i for i, l in enumerate(g) if l.startswith(code + " ")]
assert len(fires) == rep["fire_commands"], (len(fires), rep["fire_commands"])
assert all(" P" in g[i] for i in fires), "fire without P"
for i in fires:
    j = i - 1
    while g[j].startswith(code + " "):
        j -= 1
    assert g[j] == "M400", (i + 1, g[j])
    assert g[j - 1].startswith("G1 X"), (i + 1, g[j - 1])
# one stop per fired column, no move for an empty band: G1 X lines = columns fired
moves = sum(1 for l in g if l.startswith("G1 X"))
assert moves == rep["columns_fired"] == rep["xy_moves"], (moves, rep["columns_fired"])
assert sum(1 for l in g if l.startswith(";LAYER:")) == rep["layers"]
other = {"M700", "M578"} - {code}
assert not any(l.split(" ")[0] in other for l in g), "wrong dialect"
PY
}

# 1. The example BMP stack: values, structure, serpentine vs one-way.
"$GWEAVE" raster "$EX/layers" --flip-y --head "$EX/c6602.toml" -o "$WORK/badge.gcode" --json > "$WORK/badge.json"
check_gcode "$WORK/badge.gcode" "$WORK/badge.json" M700 || fail "badge structure"
python3 - "$WORK/badge.json" <<'PY' || fail "badge figures"
import json, sys
r = json.load(open(sys.argv[1]))
assert (r["layers"], r["images_read"], r["bands_printed"], r["bands_skipped"]) == (8, 8, 29, 3), r
assert (r["columns_fired"], r["drops_per_head"]) == (844, [6508]), r
assert abs(r["binder_volume_ul"] - 6508 * 160e-6) < 1e-9, r["binder_volume_ul"]
assert r["time"]["method"] == "planner" and r["time"]["total_s"] > r["time"]["fire_s"] > 0, r["time"]
PY
"$GWEAVE" raster "$EX/layers" --flip-y --one-way --density 3 -o "$WORK/badge1.gcode" --json > "$WORK/badge1.json"
check_gcode "$WORK/badge1.gcode" "$WORK/badge1.json" M700 || fail "one-way density structure"
python3 - "$WORK/badge.json" "$WORK/badge1.json" <<'PY' || fail "density"
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:])
assert b["fire_commands"] == 3 * a["columns_fired"] and b["drops_per_head"] == [3 * 6508], b
PY

# 2. PrusaSlicer .sl1 with RepRapFirmware's M578; same drops as the Rust round-trip test.
"$GWEAVE" raster "$RDATA/sphere.sl1" --dialect reprap --fast-estimate -o "$WORK/sphere.gcode" --json > "$WORK/sphere.json"
check_gcode "$WORK/sphere.gcode" "$WORK/sphere.json" M578 || fail "sl1 structure"
python3 -c "
import json, sys; r = json.load(open(sys.argv[1]))
assert (r['layers'], r['drops_per_head'], r['time']['method']) == (308, [2199541], 'feed'), r" "$WORK/sphere.json" || fail "sl1 figures"

# 3. Two heads, one folder each, from the 2-head profile: head 1 prints 30 mm further left.
"$GWEAVE" raster "$EX/layers" "$EX/layers" --heads 2 --head "$EX/c6602_2head.toml" -o "$WORK/two.gcode" --json > "$WORK/two.json"
check_gcode "$WORK/two.gcode" "$WORK/two.json" M700 || fail "two-head structure"
python3 - "$WORK/two.gcode" "$WORK/two.json" <<'PY' || fail "two heads"
import json, sys
g, r = open(sys.argv[1]).read().splitlines(), json.load(open(sys.argv[2]))
assert r["drops_per_head"] == [6508, 6508], r["drops_per_head"]
xs = {0: [], 1: []}
for i, l in enumerate(g):
    if l.startswith("M700 P"):
        xs[int(l.split()[1][1:])].append(float(g[i - 2].split()[1][1:]))
assert abs(min(xs[0]) - min(xs[1]) - 30.0) < 1e-3, (min(xs[0]), min(xs[1]))
PY

# 4. Nozzle test pattern: 12 groups of 4 columns, address a alone, S = 2^a in order.
"$GWEAVE" raster --test-pattern -o "$WORK/pattern.gcode" -q > /dev/null
python3 - "$WORK/pattern.gcode" <<'PY' || fail "test pattern"
import sys
s = [int(l.split("S")[1]) for l in open(sys.argv[1]) if l.startswith("M700 P0 S")]
assert s == [1 << a for a in range(12) for _ in range(4)], s
PY

# 5. slice-raster a PrusaSlicer sample mesh, then raster the images: one stack, 57 layers.
"$GWEAVE" slice-raster "$RDATA/torus.stl" --layer-height 0.1 --dpi 96 -o "$WORK/torus" --json > "$WORK/slice.json"
[ "$(ls "$WORK/torus" | grep -c '^layer_.*\.png$')" = 57 ] || fail "slice-raster file count"
"$GWEAVE" raster "$WORK/torus" --fast-estimate -o "$WORK/torus.gcode" --json > "$WORK/torus.json"
python3 - "$WORK/slice.json" "$WORK/torus.json" <<'PY' || fail "slice-raster -> raster"
import json, sys
s, r = (json.load(open(p)) for p in sys.argv[1:])
assert s["grid"]["layers"] == 57 and (s["grid"]["width_px"], s["grid"]["height_px"]) == (108, 108), s["grid"]
assert r["layers"] == 57 and r["drops_per_head"] == [sum(s["pixels_per_layer"])], (r["drops_per_head"], sum(s["pixels_per_layer"]))
PY

# 6. Bad input: a non-image file fails with the file named, and leaves no output.
echo "not an image" > "$WORK/bad.png"
if "$GWEAVE" raster "$WORK/bad.png" -o "$WORK/bad.gcode" 2> "$WORK/err"; then fail "bad image accepted"; fi
grep -q "bad.png" "$WORK/err" || fail "error text: $(cat "$WORK/err")"
[ ! -e "$WORK/bad.gcode" ] || fail "partial output left"

# 7. The Python console script gives the same report.
if [ -x "$PYGWEAVE" ]; then
  "$PYGWEAVE" raster "$EX/layers" --flip-y --head "$EX/c6602.toml" -o "$WORK/py.gcode" --json > "$WORK/py.json"
  cmp -s "$WORK/badge.gcode" "$WORK/py.gcode" || fail "python raster output differs"
fi

exit $failed
