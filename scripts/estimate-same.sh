#!/usr/bin/env bash
# Whether a change to the estimator left every figure the same to the bit: `gweave estimate
# --json` (Marlin by default, Klipper with bench/klipper-big-bed.toml, each also with --steps)
# and `gweave sim --json` (both machines) of two builds, compared byte for byte on every G-code
# file given (default: the bundled fixtures, tests/data/*/*.gcode).
#
#   scripts/estimate-same.sh OLD_GWEAVE NEW_GWEAVE [FILE...]
#
# Prints one line per differing output and the counts; exits 1 if any output differs.
set -uo pipefail
OLD=${1:?usage: scripts/estimate-same.sh OLD_GWEAVE NEW_GWEAVE [FILE...]}
NEW=${2:?usage: scripts/estimate-same.sh OLD_GWEAVE NEW_GWEAVE [FILE...]}
shift 2
ROOT=$(cd "$(dirname "$0")/.." && pwd)
if [ $# -eq 0 ]; then
  set -- "$ROOT"/tests/data/*/*.gcode
fi
KLIPPER="$ROOT/bench/klipper-big-bed.toml"
# name|arguments after the file
RUNS=(
  "estimate|estimate"
  "estimate-steps|estimate --steps"
  "estimate-klipper|estimate --machine $KLIPPER"
  "estimate-klipper-steps|estimate --machine $KLIPPER --steps"
  "sim|sim"
  "sim-klipper|sim --machine $KLIPPER"
)
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
same=0
differ=0
for f in "$@"; do
  for entry in "${RUNS[@]}"; do
    name=${entry%%|*}
    read -r cmd args <<<"${entry#*|}"
    # shellcheck disable=SC2086 # the arguments are split on purpose
    "$OLD" "$cmd" "$f" $args --json -q >"$TMP/old" 2>&1
    echo "exit $?" >>"$TMP/old"
    # shellcheck disable=SC2086
    "$NEW" "$cmd" "$f" $args --json -q >"$TMP/new" 2>&1
    echo "exit $?" >>"$TMP/new"
    if cmp -s "$TMP/old" "$TMP/new"; then
      same=$((same + 1))
    else
      differ=$((differ + 1))
      echo "DIFFERS: $name $f"
    fi
  done
done
echo "estimate-same: $same outputs identical, $differ differ ($# files x ${#RUNS[@]} runs)"
[ "$differ" -eq 0 ]
