#!/usr/bin/env bash
# End-to-end: the installed `gweave` binary and the one the Python package installs (the same executable) on real slicer files.
# Every check compares values; the script stops at the first failure and prints what differed.
set -euo pipefail
GWEAVE=$(realpath "${1:-target/release/gweave}")
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
DATA="$ROOT/tests/data"
PYGWEAVE="$ROOT/.venv/bin/gweave"
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
passed=0
failed=0
ok() { passed=$((passed + 1)); }
fail() { echo "FAIL: $*"; failed=$((failed + 1)); }

# 1. Every fixture round-trips byte for byte through `cat`, with both front ends.
for f in "$DATA"/*/*.gcode; do
  "$GWEAVE" cat "$f" -o "$WORK/copy.gcode" -q
  cmp -s "$f" "$WORK/copy.gcode" && ok || fail "cat changed $f"
  "$PYGWEAVE" cat "$f" -o - -q | cmp -s "$f" - && ok || fail "python cat to stdout changed $f"
done

#    The summary counts what was copied (here with --lenient past a malformed line).
printf 'G1 X1\r\nG1 Y2..3\nG1 X2' > "$WORK/lenient.gcode"
"$GWEAVE" cat "$WORK/lenient.gcode" -o "$WORK/lenient.out" --lenient --json > "$WORK/cat.json"
cmp -s "$WORK/lenient.gcode" "$WORK/lenient.out" && ok || fail "cat --lenient changed the file"
python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); assert r == {"lines": 3, "bytes": 21, "malformed_lines": 1, "first_malformed_line": 2}, r' \
  "$WORK/cat.json" && ok || fail "cat --json: $(cat "$WORK/cat.json")"

# 2. stats --json equals PrusaSlicer's own filament figures.
"$GWEAVE" stats "$DATA/prusaslicer/pr_torus_pva.gcode" --json > "$WORK/s.json"
python3 - "$WORK/s.json" <<'PY' && ok || fail "stats figures"
import json, sys
s = json.load(open(sys.argv[1]))
ours = [round(t["extruded_mm"], 2) for t in s["filament"]]
assert ours == [525.88, 123.16], ours
assert s["layers"] == 28 and s["tool_changes"] == 2, (s["layers"], s["tool_changes"])
PY

# 3. A malformed file: error names file, line and column; exit 1; no output left behind.
printf 'G1 X1\nG1 Y2..3\n' > "$WORK/bad.gcode"
if "$GWEAVE" cat "$WORK/bad.gcode" -o "$WORK/out.gcode" 2> "$WORK/err"; then fail "bad input accepted"; else ok; fi
grep -q "bad.gcode:2:5: malformed number after 'Y'" "$WORK/err" && ok || fail "error text: $(cat "$WORK/err")"
[ ! -e "$WORK/out.gcode" ] && ok || fail "partial output left"
[ "$(ls "$WORK" | grep -c '^\.gweave-')" = 0 ] && ok || fail "temporary file left"
#    A line a transform cannot handle: one error line naming file and line, exit 1, no output.
printf 'G1 X1 E1\n' > "$WORK/nofeed.gcode"
if "$GWEAVE" rotary wrap "$WORK/nofeed.gcode" --mandrel-diameter 30 -o "$WORK/out.gcode" 2> "$WORK/err"; then
  fail "rotary wrap accepted a move without a feed rate"
else
  [ "$(cat "$WORK/err")" = "gweave: error: $WORK/nofeed.gcode:1: invalid rotary setting \`F\`: a move before any feed rate was set" ] \
    && [ ! -e "$WORK/out.gcode" ] && ok || fail "rotary error text: $(cat "$WORK/err")"
fi
printf 'M83\n;LAYER_CHANGE\nG1 Z0.2 F100\nG1 X10 E1 F1800\nT1\nG1 X5 E3\n' > "$WORK/t1.gcode"
if "$GWEAVE" mix "$WORK/t1.gcode" --map T0=Red -o "$WORK/out.gcode" 2> "$WORK/err" > /dev/null; then
  fail "mix accepted an unmapped tool"
else
  grep -q "^gweave: error: $WORK/t1.gcode:5: the file selects T1, which has no mix" "$WORK/err" && [ ! -e "$WORK/out.gcode" ] \
    && ok || fail "mix error text: $(cat "$WORK/err")"
fi

#    Transforms that write E moves refuse a file whose extruder is A (PrusaSlicer's mach3 flavour);
#    the rotary wrap also because it writes A as the mandrel's turn.
for cmd in "mix --at-layer 0=Orange" "purge-shift --purge 20" "rotary wrap --mandrel-diameter 30"; do
  # shellcheck disable=SC2086
  if "$GWEAVE" $cmd "$DATA/prusaslicer/pr_box_mach3.gcode" -o "$WORK/out.gcode" 2> "$WORK/err" > /dev/null; then
    fail "$cmd accepted a mach3 file"
  else
    grep -q "the file is for mach3, whose extruder is the A axis" "$WORK/err" && [ ! -e "$WORK/out.gcode" ] \
      && ok || fail "$cmd on mach3: $(cat "$WORK/err")"
  fi
done

# 4. check: exit code 1 on errors, 0 on a clean real file.
"$GWEAVE" check "$DATA/prusaslicer/pr_torus_pva.gcode" -q > /dev/null && ok || fail "check on a clean file"
printf 'N1 G28*18\nN2 G1 X5*99\n' > "$WORK/sum.gcode"
if "$GWEAVE" check "$WORK/sum.gcode" > "$WORK/check.txt"; then fail "checksum error passed"; else ok; fi
grep -q "sum.gcode:2:9: error: checksum mismatch" "$WORK/check.txt" && ok || fail "check text: $(cat "$WORK/check.txt")"

# 5. --in-place keeps a .bak, and refusing to overwrite the input without it.
cp "$DATA/cura/cura_torus.gcode" "$WORK/t.gcode"
"$GWEAVE" cat "$WORK/t.gcode" --in-place -q
cmp -s "$WORK/t.gcode" "$WORK/t.gcode.bak" && ok || fail "in-place backup"
if "$GWEAVE" cat "$WORK/t.gcode" -o "$WORK/t.gcode" 2>/dev/null; then fail "overwrote input"; else ok; fi
#    A --report naming the input is refused too, and the input stays as it was.
cp "$WORK/t.gcode" "$WORK/t.orig"
if "$GWEAVE" stats "$WORK/t.gcode" --report "$WORK/t.gcode" 2> "$WORK/rep.err" > /dev/null; then
  fail "stats --report replaced its input"
else
  cmp -s "$WORK/t.gcode" "$WORK/t.orig" && grep -q "would overwrite the input file $WORK/t.gcode; name another file" "$WORK/rep.err" && ok \
    || fail "stats --report onto its input: $(cat "$WORK/rep.err")"
fi

# 6. A closed pipe ends gweave quietly, as it does `cat`: by SIGPIPE (status 141) or status 0,
#    nothing on stderr; for the output file and for a summary, with both front ends.
for g in "$GWEAVE" "$PYGWEAVE"; do
  for cmd in "cat -o -" "stats"; do
    set +o pipefail
    # shellcheck disable=SC2086
    { rc=0; "$g" $cmd "$DATA/cura/cura_dual.gcode" 2> "$WORK/pipe.err" || rc=$?; echo $rc > "$WORK/pipe.status"; } | true
    set -o pipefail
    status=$(cat "$WORK/pipe.status")
    { [ "$status" = 0 ] || [ "$status" = 141 ]; } && [ ! -s "$WORK/pipe.err" ] && ok \
      || fail "$g $cmd | true: status $status, $(head -3 "$WORK/pipe.err")"
  done
done

for extra in "$ROOT"/tests/e2e/[0-9]*.sh; do
  [ -e "$extra" ] || continue
  if GWEAVE="$GWEAVE" PYGWEAVE="$PYGWEAVE" DATA="$DATA" WORK="$WORK" bash "$extra"; then ok; else fail "$(basename "$extra")"; fi
done

echo "e2e: $passed passed, $failed failed"
[ "$failed" = 0 ]
