#!/usr/bin/env bash
# gweave preview on the large file of bench/run.sh: a whole-print isometric picture and one layer
# from the top, beside `gweave stats` on the same file in the same run (the cost of reading and
# parsing it, which every picture pays) and peak memory (the rasteriser keeps one canvas, not
# the toolpath).
set -euo pipefail
source "$(dirname "$0")/lib.sh"
BIG="$ROOT/bench/data/bunny-gyroid.gcode"
[ -s "$BIG" ] || { echo "run bench/run.sh first (it slices $BIG)"; exit 1; }
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
cat "$BIG" > /dev/null
# Three rounds of the three in turn, the best of each: single runs of the iso view spread by
# 5 % or more on this machine (see besttime.py).
read -r t_stats t_iso t_layer < <(best 3 -- "$GWEAVE" stats "$BIG" -q \
  -- "$GWEAVE" preview "$BIG" -o "$OUT/iso.png" --view iso -q \
  -- "$GWEAVE" preview "$BIG" -o "$OUT/layer.png" --layer 300 -q)
printf "%-30s %8s s\n" "gweave stats (parse floor)" "$t_stats"
printf "%-30s %8s s   %sx stats, peak %s MB\n" "preview --view iso (all)" "$t_iso" "$(ratio "$t_iso" "$t_stats")" \
  "$(peak_mb "$GWEAVE" preview "$BIG" -o "$OUT/iso.png" --view iso -q)"
printf "%-30s %8s s   %sx stats\n" "preview --layer 300 (top)" "$t_layer" "$(ratio "$t_layer" "$t_stats")"
