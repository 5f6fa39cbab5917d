#!/usr/bin/env bash
# Whether two builds of gweave write the same bytes for the transforms whose metadata the
# finishing step recomputes (mix, purge-shift) on every G-code fixture: for a change that must
# keep every figure written to the bit (e.g. a cheaper way to plan the same windows).
#
#   bash bench/same_output.sh GWEAVE_BEFORE GWEAVE_AFTER [FIXTURE_DIR...]
#
# Prints one line per differing run and the count of runs compared; exits 1 on a difference.
# The exit status and error message of a refused run are compared too.
set -uo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
A=$(realpath "$1")
B=$(realpath "$2")
shift 2
DIRS=("$@")
[ ${#DIRS[@]} -gt 0 ] || DIRS=("$ROOT/tests/data")
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

# name and arguments; the input comes first.
RUNS=(
  "mix-map|mix --map T0=Cyan --map T1=Magenta --map T2=Yellow"
  "mix-layers|mix --at-layer 0=Orange --at-layer 3=Pink --at-layer 7=Cyan"
  "purge-shift-2.5|purge-shift --purge-mm 2.5"
  "purge-shift-20|purge-shift --purge-mm 20"
)
compared=0
differ=0
while IFS= read -r -d '' f; do
  for run in "${RUNS[@]}"; do
    name=${run%%|*}
    for g in A B; do
      bin=$A; [ $g = B ] && bin=$B
      # shellcheck disable=SC2086 # the arguments are split on purpose
      "$bin" ${run#*|} "$f" -o "$WORK/$g.out" -q >"$WORK/$g.msg" 2>&1
      echo "exit $?" >>"$WORK/$g.msg"
      [ -f "$WORK/$g.out" ] || : >"$WORK/$g.out"
      sed -i "s|$bin|GWEAVE|g" "$WORK/$g.msg"
    done
    compared=$((compared + 1))
    if ! cmp -s "$WORK/A.out" "$WORK/B.out" || ! cmp -s "$WORK/A.msg" "$WORK/B.msg"; then
      differ=$((differ + 1))
      echo "differs: $name $f"
    fi
    rm -f "$WORK/A.out" "$WORK/B.out"
  done
done < <(find "${DIRS[@]}" -type f \( -name '*.gcode' -o -name '*.gco' -o -name '*.g' \) -print0 | sort -z)
echo "same_output: $compared runs compared, $differ differ"
[ "$differ" -eq 0 ]
