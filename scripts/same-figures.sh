#!/usr/bin/env bash
# Whether a change that must keep every figure to the bit did: two builds of gweave run the
# same commands on every G-code file given (default: the bundled fixtures, tests/data/*/*.gcode),
# and their outputs, messages and exit codes are compared byte for byte. The commands are the
# ones whose figures are computed rather than copied: `stats --json`, `estimate --json` (Marlin by default,
# Klipper with bench/klipper-big-bed.toml, each also with --steps), `sim --json` (both machines),
# and the transforms whose metadata the finishing step recomputes (`mix`, `purge-shift`).
# For every command's output on the fixtures, see scripts/outputs.sh.
#
#   scripts/same-figures.sh OLD_GWEAVE NEW_GWEAVE [FILE...]
#
# Prints one line per differing run and the counts; exits 1 if any run differs.
set -uo pipefail
OLD=$(realpath "${1:?usage: scripts/same-figures.sh OLD_GWEAVE NEW_GWEAVE [FILE...]}")
NEW=$(realpath "${2:?usage: scripts/same-figures.sh OLD_GWEAVE NEW_GWEAVE [FILE...]}")
shift 2
ROOT=$(cd "$(dirname "$0")/.." && pwd)
if [ $# -eq 0 ]; then
  set -- "$ROOT"/tests/data/*/*.gcode
fi
KLIPPER="$ROOT/bench/klipper-big-bed.toml"
# name|command and arguments (the file goes after the command's name)|what the run writes:
# json (standard output) or file (-o).
RUNS=(
  "stats|stats --json|json"
  "estimate|estimate --json -q|json"
  "estimate-steps|estimate --steps --json -q|json"
  "estimate-klipper|estimate --machine $KLIPPER --json -q|json"
  "estimate-klipper-steps|estimate --machine $KLIPPER --steps --json -q|json"
  "sim|sim --json -q|json"
  "sim-klipper|sim --machine $KLIPPER --json -q|json"
  "mix-map|mix --map T0=Cyan --map T1=Magenta --map T2=Yellow -q|file"
  "mix-layers|mix --at-layer 0=Orange --at-layer 3=Pink --at-layer 7=Cyan -q|file"
  "purge-shift-2.5|purge-shift --purge-mm 2.5 -q|file"
  "purge-shift-20|purge-shift --purge-mm 20 -q|file"
)
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
same=0
differ=0
for f in "$@"; do
  for entry in "${RUNS[@]}"; do
    IFS='|' read -r name cmdline writes <<<"$entry"
    read -r cmd args <<<"$cmdline"
    for side in old new; do
      bin=$OLD
      [ "$side" = new ] && bin=$NEW
      out=()
      [ "$writes" = file ] && out=(-o "$TMP/$side.gcode")
      # shellcheck disable=SC2086 # the arguments are split on purpose
      "$bin" "$cmd" "$f" $args "${out[@]}" >"$TMP/$side.msg" 2>&1
      echo "exit $?" >>"$TMP/$side.msg"
      sed -i "s|$bin|GWEAVE|g; s|$TMP/$side|OUT|g" "$TMP/$side.msg"
      [ -f "$TMP/$side.gcode" ] || : >"$TMP/$side.gcode"
    done
    if cmp -s "$TMP/old.msg" "$TMP/new.msg" && cmp -s "$TMP/old.gcode" "$TMP/new.gcode"; then
      same=$((same + 1))
    else
      differ=$((differ + 1))
      echo "differs: $name $f"
    fi
    rm -f "$TMP/old.gcode" "$TMP/new.gcode"
  done
done
echo "same-figures: $same runs identical, $differ differ ($# files x ${#RUNS[@]} runs)"
[ "$differ" -eq 0 ]
