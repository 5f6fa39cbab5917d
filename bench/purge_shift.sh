#!/usr/bin/env bash
# purge-shift on a large multi-tool file: speed against `gweave cat` on the same file in the same
# run, and peak memory at 1x and 60x the size: the window does not grow with the file, and the
# report keeps 1000 entries in memory and spills the rest to a temporary file, streamed into the
# JSON report at the end (so with --report the memory stays flat too).
# The file is the PrusaSlicer 3-tool bunny (relative E, 793 changes) with its print proper
# repeated 60 times (about 225 MB, 47 000 changes).
set -euo pipefail
source "$(dirname "$0")/lib.sh"
BIG=$(multitool_file)
size=$(stat -c %s "$BIG")
cat "$BIG" > /dev/null
echo "file: $(basename "$BIG"), $(python3 -c "print(f'{$size/1e6:.0f}')") MB, $(grep -c '^T' "$BIG") T lines"
t_cat=$(best 3 "$GWEAVE" cat "$BIG" -o /dev/null -q)
t_ps=$(best 3 "$GWEAVE" purge-shift "$BIG" -o /dev/null -q --purge-mm 2.5)
printf "%-26s %8s s\n" "gweave cat" "$t_cat"
printf "%-26s %8s s   %sx cat\n" "gweave purge-shift" "$t_ps" "$(ratio "$t_ps" "$t_cat")"
m1=$(peak_mb "$GWEAVE" purge-shift "$SRC" -o /dev/null -q --purge-mm 2.5)
m60=$(peak_mb "$GWEAVE" purge-shift "$BIG" -o /dev/null -q --purge-mm 2.5)
printf "%-26s %8s MB (1x file)  %s MB (60x file)\n" "purge-shift peak memory" "$m1" "$m60"
goal "purge-shift, $(python3 -c "print(f'{$size/1e6:.0f}')") MB" "$(ratio "$t_ps" "$t_cat")" "<=" 1.5 "x gweave cat"
goal "purge-shift memory, 60x the file against 1x" "$(ratio "$m60" "$m1")" "<=" 1.3 "x (flat: 1)"
printf "%-26s %8s MB (1x file)  %s MB (60x file)\n" "  with --report" \
  "$(peak_mb "$GWEAVE" purge-shift "$SRC" -o /dev/null -q --purge-mm 2.5 --report "$BIG.report.json")" \
  "$(peak_mb "$GWEAVE" purge-shift "$BIG" -o /dev/null -q --purge-mm 2.5 --report "$BIG.report.json")"
rm -f "$BIG.report.json"
