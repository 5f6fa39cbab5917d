#!/usr/bin/env bash
# Rotary printing end to end: a real PrusaSlicer flat plate wrapped onto a 30 mm mandrel, and
# generated tubes. Every figure is recomputed here from the written G-code, independently of
# gweave's own summary, and compared.
set -euo pipefail
: "${GWEAVE:?}" "${DATA:?}" "${WORK:?}"
R="$WORK/rotary"
mkdir -p "$R"

# 1. Wrap the plate (40 x 30*pi x 2 mm, 10 layers) with a seam rotation; read back per layer.
"$GWEAVE" rotary wrap "$DATA/rotary/plate.gcode" -o "$R/sleeve.gcode" --mandrel-diameter 30 \
  --seam-rotation 7.5 --preview "$R/sleeve.png" --report "$R/sleeve.json" > "$R/sleeve.txt"
grep -q "layers          10" "$R/sleeve.txt"
python3 - "$DATA/rotary/plate.gcode" "$R/sleeve.gcode" "$R/sleeve.json" "$R/sleeve.png" <<'PY'
import json, math, struct, sys

def moves(path, letters):
    """(layer, from, to, e) of every move; absolute XYZ/A words, absolute E, G92 honoured."""
    pos = dict.fromkeys(letters + "E", 0.0)
    layer, out = -1, []
    for line in open(path):
        if line.startswith(";LAYER_CHANGE"):
            layer += 1
        code = line.split(";")[0].split()
        if not code:
            continue
        words = {w[0]: float(w[1:]) for w in code[1:] if w[0] in letters + "E" and len(w) > 1}
        if code[0] == "G92":
            pos.update(words)
        elif code[0] in ("G0", "G1"):
            new = dict(pos, **words)
            out.append((layer, dict(pos), new, new["E"] - pos["E"]))
            pos = new
    return out

D, w = 30.0, 0.45
R0, C = D / 2, math.pi * D
flat = moves(sys.argv[1], "XYZ")
wrapped = moves(sys.argv[2], "XAZ")
report = json.load(open(sys.argv[3]))

# Closure: every layer sweeps the full turn less one bead width, so the bead edges at the
# weld line meet: span + 360 * w / C = 360; and layer k is turned 7.5 k degrees.
spans = {}
for layer, a, b, e in wrapped:
    if e > 0 and (a["X"], a["A"]) != (b["X"], b["A"]):
        lo, hi = spans.get(layer, (math.inf, -math.inf))
        spans[layer] = (min(lo, a["A"], b["A"]), max(hi, a["A"], b["A"]))
assert sorted(spans) == list(range(10)), sorted(spans)
for k, (lo, hi) in spans.items():
    closure = hi - lo + 360 * w / C
    assert abs(closure - 360) < 0.005, (k, lo, hi, closure)
    assert abs(lo - (spans[0][0] + 7.5 * k)) < 0.002, (k, lo)
    js = report["layers"][k]
    assert abs(js["theta_range_deg"][0] - lo) < 1e-9 and abs(js["span_deg"] - (hi - lo)) < 1e-9, js
    assert abs(js["seam_deg"] - 7.5 * k) < 1e-9 and abs(js["radius_mm"] - (R0 + 0.2 * (k + 1))) < 1e-9, js

# E scaling: each flat bead grows by hypot(dx, dy*r/R0)/hypot(dx, dy) at r = R0 + z.
expected = 0.0
for _, a, b, e in flat:
    if e > 0:
        dx, dy = b["X"] - a["X"], b["Y"] - a["Y"]
        r = R0 + (a["Z"] + b["Z"]) / 2
        expected += e * (math.hypot(dx, dy * r / R0) / math.hypot(dx, dy) if (dx, dy) != (0, 0) else 1)
got = sum(e for _, a, b, e in wrapped if e > 0)
assert abs(got - expected) < 1e-3 * expected, (got, expected)
# gweave's summary counts beads (moves that extrude), not the unretractions.
beads = sum(e for _, a, b, e in wrapped if e > 0 and (a["X"], a["A"]) != (b["X"], b["A"]))
assert abs(report["filament_mm"] - beads) < 1e-6 * beads, (report["filament_mm"], beads)

# The preview is an 800 x 600 RGB PNG.
png = open(sys.argv[4], "rb").read()
assert png[:8] == b"\x89PNG\r\n\x1a\n" and struct.unpack(">II", png[16:24]) == (800, 600)
PY

# 2. Inverse time: G93 before the first move, G94 at the end, F on every G1.
"$GWEAVE" rotary wrap "$DATA/rotary/plate.gcode" -o "$R/g93.gcode" --mandrel-diameter 30 --feed inverse-time -q > /dev/null
[ "$(grep -m1 -oE '^G9[34]' "$R/g93.gcode")" = "G93" ]
[ "$(grep -oE '^G9[34]' "$R/g93.gcode" | tail -1)" = "G94" ]
[ "$(grep -E '^G1 ' "$R/g93.gcode" | grep -cv ' F')" = 0 ]

# 3. A closed tube: volume = wall volume within 1 %, alternating helices, constant surface speed.
"$GWEAVE" rotary tube -o "$R/tube.gcode" --mandrel-diameter 20 --length 30 --layers 3 --json \
  --preview "$R/tube.png" > "$R/tube.json"
python3 - "$R/tube.gcode" "$R/tube.json" <<'PY'
import json, math, sys
t = json.load(open(sys.argv[2]))
R0, h, L, N, v = 10.0, 0.2, 30.0, 3, 20.0
wall = math.pi * ((R0 + N * h) ** 2 - R0 ** 2) * L
assert abs(t["wall_volume_mm3"] - wall) < 1e-9 * wall, t["wall_volume_mm3"]
assert abs(t["extruded_mm3"] / wall - 1) < 0.01, (t["extruded_mm3"], wall)
assert [l["handedness"] for l in t["layers"]] == ["right", "left", "right"], t["layers"]
assert [round(l["radius_mm"], 9) for l in t["layers"]] == [10.1, 10.3, 10.5]
assert t["executed_beads"] > 10000

# Read the G-code back: every extruding move's surface speed, under NIST feed (F is the axial
# speed; a rotary-only move has F in deg/min), is 20 mm/s within 1 %.
pos = {"X": math.nan, "A": math.nan, "Z": math.nan}
e = f = 0.0
n = 0
area = math.pi * 1.75 ** 2 / 4
volume = 0.0
for line in open(sys.argv[1]):
    code = line.split(";")[0].split()
    if not code:
        continue
    words = {c[0]: float(c[1:]) for c in code[1:] if c[0] in "XAZEF" and len(c) > 1}
    if code[0] == "G92":
        pos.update({k: v for k, v in words.items() if k in pos})
        e = words.get("E", e)
    elif code[0] == "G1" and pos["Z"] == pos["Z"]:
        new = dict(pos, **{k: v for k, v in words.items() if k in pos})
        f = words.get("F", f)
        de = words.get("E", e) - e
        e = words.get("E", e)
        if de > 0:
            r = R0 + (pos["Z"] + new["Z"]) / 2 - h / 2
            dx = new["X"] - pos["X"]
            arc = r * math.radians(new["A"] - pos["A"])
            length = math.hypot(dx, arc)
            t_s = 60 * (abs(dx) if dx else abs(new["A"] - pos["A"])) / f
            assert abs(length / t_s / v - 1) < 0.01, (line, length / t_s)
            volume += de * area
            n += 1
        pos = new
    elif code[0] == "G1":
        pos.update({k: v for k, v in words.items() if k in pos})
assert n > 10000 and abs(volume / t["extruded_mm3"] - 1) < 1e-4, (n, volume)
PY

# 4. The human summary of an open lattice names the lattice and the per-layer spindle speeds.
"$GWEAVE" rotary tube -o "$R/lattice.gcode" --mandrel-diameter 20 --length 30 --layers 2 --pitch 6 > "$R/lattice.txt"
grep -qE "layer 0 +r +10.100 mm +right" "$R/lattice.txt"
grep -qE "layer 1 +r +10.300 mm +left" "$R/lattice.txt"
grep -q "lattice:" "$R/lattice.txt"

# 5. Bad input is refused with the key named; no output left behind.
if "$GWEAVE" rotary tube -o "$R/bad.gcode" --mandrel-diameter 20 --pitch 0.1 2> "$R/err"; then exit 1; fi
grep -q "pitch_mm" "$R/err"
[ ! -e "$R/bad.gcode" ]

# 6. Python: the same tube through the bindings gives the same G-code and summary.
PY_BIN="$(dirname "$PYGWEAVE")/python"
if [ -x "$PY_BIN" ]; then
  "$PY_BIN" - "$R" <<'PY'
import json, sys
import gweave
out = sys.argv[1]
s = gweave.rotary_tube(out + "/py_tube.gcode", mandrel_diameter=20, length=30, layer_count=3)
assert open(out + "/py_tube.gcode").read() == open(out + "/tube.gcode").read()
t = json.load(open(out + "/tube.json"))
assert abs(s["extruded_mm3"] - t["extruded_mm3"]) < 1e-9
PY
fi
echo "40_rotary: ok"
