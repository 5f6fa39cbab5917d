#!/usr/bin/env bash
# gweave mix on a large multi-tool file (each slicer tool mapped to a mix, purge at every change):
# speed against `gweave cat` on the same file in the same run, and peak memory at 1x and 60x.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
BIG=$(multitool_file)
MAP=(--map T0=Cyan --map T1=Magenta --map T2=Yellow)
size=$(stat -c %s "$BIG")
cat "$BIG" > /dev/null
echo "file: $(basename "$BIG"), $(python3 -c "print(f'{$size/1e6:.0f}')") MB"
t_cat=$(best 3 "$GWEAVE" cat "$BIG" -o /dev/null -q)
t_mix=$(best 3 "$GWEAVE" mix "$BIG" "${MAP[@]}" -o /dev/null -q)
printf "%-26s %8s s\n" "gweave cat" "$t_cat"
printf "%-26s %8s s   %sx cat\n" "gweave mix (3-tool map)" "$t_mix" "$(ratio "$t_mix" "$t_cat")"
m1=$(peak_mb "$GWEAVE" mix "$SRC" "${MAP[@]}" -o /dev/null -q)
m60=$(peak_mb "$GWEAVE" mix "$BIG" "${MAP[@]}" -o /dev/null -q)
printf "%-26s %8s MB (1x file)  %s MB (60x file)\n" "mix peak memory" "$m1" "$m60"
goal "mix (3-tool map), $(python3 -c "print(f'{$size/1e6:.0f}')") MB" "$(ratio "$t_mix" "$t_cat")" "<=" 1.5 "x gweave cat"
goal "mix memory, 60x the file against 1x" "$(ratio "$m60" "$m1")" "<=" 1.3 "x (flat: 1)"
