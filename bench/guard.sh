#!/usr/bin/env bash
# The performance guard of `make test`: instructions per line of the hot commands on a fixed
# input, counted by callgrind, against the baseline in bench/guard-baseline.txt. Instructions do
# not depend on the machine's load (six builds on two cores leave wall times meaningless), and a
# hot path that gets slower runs more of them. A figure more than 15 % over its baseline fails.
#
#   bash bench/guard.sh GWEAVE            measure and compare (make test runs this)
#   bash bench/guard.sh GWEAVE --update   measure and write the baseline
#
# GWEAVE is the binary of the `guard` cargo profile (Cargo.toml: release without fat LTO, which
# builds in a fraction of the time and counts within a few percent of it). The baseline is
# updated on purpose, in the commit that changes the cost, with the reason in its message
# (docs/performance.md, "The guard").
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
GWEAVE=$(realpath "$1")
UPDATE=${2:-}
BASELINE="$ROOT/bench/guard-baseline.txt"
LIMIT_PCT=15
command -v valgrind >/dev/null || { echo "guard: valgrind is needed (apt-get install valgrind)"; exit 1; }

# The fixed input: the PrusaSlicer 3-tool bunny (tests/data), its first 30 000 lines (about
# 0.8 MB, 200 tool changes) and its last 350 (the settings block: flavour, machine limits in both
# modes), so every command reads what it reads on the whole file in a tenth of the time.
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
SRC="$ROOT/tests/data/prusaslicer/pr_bunny_3tool_rel.gcode"
IN="$WORK/guard.gcode"
{ head -n 30000 "$SRC"; tail -n 350 "$SRC"; } > "$IN"
LINES=$(wc -l < "$IN")

# name and arguments, one per line (the input is $IN).
COMMANDS=(
  "stats|stats $IN -q"
  "check|check $IN -q"
  "cat|cat $IN -o /dev/null -q"
  "mix|mix $IN --map T0=Cyan --map T1=Magenta --map T2=Yellow -o /dev/null -q"
  "purge-shift|purge-shift $IN --purge-mm 2.5 -o /dev/null -q"
  "estimate-marlin|estimate $IN -q"
  "estimate-klipper|estimate $IN --machine $ROOT/bench/klipper-big-bed.toml -q"
  "sim|sim $IN --machine $ROOT/bench/big-bed.toml -q"
)

# Instructions of one run, all threads together.
instructions() {
  # shellcheck disable=SC2086 # the arguments are split on purpose
  valgrind --tool=callgrind --callgrind-out-file=/dev/null "$GWEAVE" $1 2>&1 >/dev/null \
    | awk '/Collected :/ {print $NF}'
}

baseline_of() { [ -f "$BASELINE" ] && awk -v n="$1" '$1 == n {print $2}' "$BASELINE" || true; }

failed=0
new=""
printf "guard: %s, %s lines; instructions per line (callgrind) against %s\n" \
  "$(basename "$IN")" "$LINES" "bench/guard-baseline.txt"
for entry in "${COMMANDS[@]}"; do
  name=${entry%%|*}
  ir=$(instructions "${entry#*|}")
  [ -n "$ir" ] || { echo "guard: $name did not run under callgrind"; exit 1; }
  per_line=$((ir / LINES))
  new+="$name $per_line"$'\n'
  base=$(baseline_of "$name")
  if [ -z "$base" ]; then
    printf "  %-18s %7s   (no baseline)\n" "$name" "$per_line"
    [ -n "$UPDATE" ] || failed=1
    continue
  fi
  pct=$(( (per_line - base) * 100 / base ))
  mark="ok"
  if [ "$per_line" -gt $((base + base * LIMIT_PCT / 100)) ]; then
    mark="SLOWER by more than $LIMIT_PCT %"
    failed=1
  fi
  printf "  %-18s %7s   baseline %7s   %+4d %%   %s\n" "$name" "$per_line" "$base" "$pct" "$mark"
done

if [ -n "$UPDATE" ]; then
  {
    echo "# Instructions per line of bench/guard.sh's commands (callgrind, the guard profile)."
    echo "# Written by 'bash bench/guard.sh GWEAVE --update'; commit it with the reason."
    printf "%s" "$new"
  } > "$BASELINE"
  echo "guard: baseline written to bench/guard-baseline.txt"
  exit 0
fi
if [ "$failed" = 1 ]; then
  echo "guard: a hot path got slower (or has no baseline): find why (callgrind_annotate), or if the"
  echo "       cost is deliberate, run 'bash bench/guard.sh GWEAVE --update' and say why in the commit"
  exit 1
fi
echo "guard: every figure within $LIMIT_PCT % of its baseline"
