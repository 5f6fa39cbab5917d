#!/usr/bin/env bash
# Two gweave binaries on every fixture (tests/data/**, and the .gcode files under any further
# directories given): `stats --json`, `mix` and `purge-shift` (bench/mix.sh's and
# bench/purge_shift.sh's arguments), each output, exit status and message compared byte for
# byte. For a change that must not change a byte.
#
#   bash bench/same_outputs.sh OLD_GWEAVE NEW_GWEAVE [DIR...]
set -uo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
OLD=$(realpath "$1")
NEW=$(realpath "$2")
shift 2
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
COMMANDS=(
  "stats --json"
  "mix --map T0=Cyan --map T1=Magenta --map T2=Yellow -q"
  "purge-shift --purge-mm 2.5 -q"
)
same=0
differ=0
while IFS= read -r file; do
  for cmd in "${COMMANDS[@]}"; do
    for which in old new; do
      bin=$OLD
      [ "$which" = new ] && bin=$NEW
      mkdir -p "$WORK/$which"
      # shellcheck disable=SC2086 # the arguments are split on purpose
      case $cmd in
        stats*) (cd "$WORK" && "$bin" $cmd "$file" > "$WORK/$which/out" 2> "$WORK/$which/err"; echo $? > "$WORK/$which/rc") ;;
        *)
          (cd "$WORK" && "$bin" ${cmd%% *} "$file" ${cmd#* } -o "$WORK/out.gcode" > /dev/null 2> "$WORK/$which/err"
           echo $? > "$WORK/$which/rc")
          mv "$WORK/out.gcode" "$WORK/$which/out" 2>/dev/null || : > "$WORK/$which/out"
          ;;
      esac
    done
    if cmp -s "$WORK/old/out" "$WORK/new/out" && cmp -s "$WORK/old/rc" "$WORK/new/rc" \
      && cmp -s "$WORK/old/err" "$WORK/new/err"; then
      same=$((same + 1))
    else
      differ=$((differ + 1))
      echo "differs: ${cmd%% *} $file"
    fi
    rm -rf "$WORK/old" "$WORK/new"
  done
done < <(find "$ROOT/tests/data" "$@" -type f -name '*.gcode' | sort)
echo "same: $same, differ: $differ"
[ "$differ" -eq 0 ]
