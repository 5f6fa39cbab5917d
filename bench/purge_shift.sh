#!/usr/bin/env bash
# purge-shift on a large multi-tool file: speed against `gweave cat` on the same file in the same
# run, and peak memory at 1x and 60x the size: the window does not grow with the file, only the
# report does (one entry per change).
# The file is the PrusaSlicer 3-tool bunny (relative E, 793 changes) with its print proper
# repeated 60 times (about 225 MB, 47 000 changes).
set -euo pipefail
GWEAVE=$(realpath "${1:-target/release/gweave}")
ROOT=$(cd "$(dirname "$0")/.." && pwd)
DATA="$ROOT/bench/data"
SRC="$ROOT/tests/data/prusaslicer/pr_bunny_3tool_rel.gcode"
BIG="$DATA/bunny-3tool-x60.gcode"
mkdir -p "$DATA"
if [ ! -s "$BIG" ]; then
  first=$(grep -n -m1 '^;LAYER_CHANGE' "$SRC" | cut -d: -f1)
  last=$(grep -n '^;TYPE:Custom' "$SRC" | tail -1 | cut -d: -f1)
  {
    head -n $((first - 1)) "$SRC"
    for _ in $(seq 60); do sed -n "${first},$((last - 1))p" "$SRC"; done
    tail -n +"$last" "$SRC"
  } > "$BIG"
fi
best() { python3 "$ROOT/bench/besttime.py" "$@"; }
peak_mb() { /usr/bin/time -f %M "$@" 2>&1 >/dev/null | tail -1 | awk '{printf "%.1f", $1/1024}'; }
ratio() { python3 -c "import sys; print(f'{float(sys.argv[1])/float(sys.argv[2]):.2f}')" "$1" "$2"; }
size=$(stat -c %s "$BIG")
cat "$BIG" > /dev/null
echo "file: $(basename "$BIG"), $(python3 -c "print(f'{$size/1e6:.0f}')") MB, $(grep -c '^T' "$BIG") T lines"
t_cat=$(best 3 "$GWEAVE" cat "$BIG" -o /dev/null -q)
t_ps=$(best 3 "$GWEAVE" purge-shift "$BIG" -o /dev/null -q --purge 2.5)
printf "%-26s %8s s\n" "gweave cat" "$t_cat"
printf "%-26s %8s s   %sx cat\n" "gweave purge-shift" "$t_ps" "$(ratio "$t_ps" "$t_cat")"
printf "%-26s %8s MB (1x file)  %s MB (60x file)\n" "purge-shift peak memory" \
  "$(peak_mb "$GWEAVE" purge-shift "$SRC" -o /dev/null -q --purge 2.5)" \
  "$(peak_mb "$GWEAVE" purge-shift "$BIG" -o /dev/null -q --purge 2.5)"
