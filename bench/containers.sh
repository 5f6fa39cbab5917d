#!/usr/bin/env bash
# `gweave stats` of the same G-code stored three ways, each beside the plain text in the same run:
# binary G-code as gweave writes it (heatshrink 12/4, no MeatPack), as PrusaSlicer writes it
# (libbgcode: heatshrink 12/4 with MeatPack, when pybgcode is installed), and gzip. The target
# for binary G-code: within 2x the time of the text under load, where a command's wall time is
# its share of the busy cores, so what counts is its CPU time (user + system, every thread): the
# text runs on two threads, the `.bgcode` on three (decoding, lexing, stats), and on a quiet
# 2-core machine the wall time of three busy threads says how few cores there are. Both are
# printed; PrusaSlicer's `.bgcode` and the text are timed in turn. Peak memory too: blocks are
# streamed.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
BIG=$(multitool_file)
PY="$ROOT/.venv/bin/python"
[ -s "$BIG.bgcode" ] || "$GWEAVE" cat "$BIG" -o "$BIG.bgcode" -q >/dev/null
[ -s "$BIG.gz" ] || "$GWEAVE" cat "$BIG" -o "$BIG.gz" -q >/dev/null
if [ ! -s "$BIG.prusa.bgcode" ] && "$PY" -c "import pybgcode" 2>/dev/null; then
  "$PY" - "$BIG" "$BIG.prusa.bgcode" <<'PYEOF'
import sys, pybgcode
fin, fout = pybgcode.open(sys.argv[1], "r"), pybgcode.open(sys.argv[2], "wb")
assert pybgcode.from_ascii_to_binary(fin, fout, pybgcode.get_config()) == pybgcode.EResult.Success
pybgcode.close(fout); pybgcode.close(fin)
PYEOF
fi
size=$(stat -c %s "$BIG")
cat "$BIG" "$BIG".* > /dev/null
echo "file: $(basename "$BIG"), $(python3 -c "print(f'{$size/1e6:.0f}')") MB as text"
t_text=$(best 3 "$GWEAVE" stats "$BIG" -q)
printf "%-30s %8s s   %6s MB stored, peak %s MB\n" "gweave stats (text)" "$t_text" \
  "$(python3 -c "print(f'{$size/1e6:.0f}')")" "$(peak_mb "$GWEAVE" stats "$BIG" -q)"
for kind in bgcode prusa.bgcode gz; do
  f="$BIG.$kind"
  [ -s "$f" ] || continue
  t=$(best 3 "$GWEAVE" stats "$f" -q)
  printf "%-30s %8s s   %6s MB stored, peak %s MB, %sx the text's time\n" "gweave stats (.$kind)" "$t" \
    "$(python3 -c "print(f'{$(stat -c %s "$f")/1e6:.0f}')")" "$(peak_mb "$GWEAVE" stats "$f" -q)" "$(ratio "$t" "$t_text")"
  if [ "$kind" = prusa.bgcode ]; then
    read -r cpu_text cpu_prusa < <(python3 "$ROOT/bench/besttime.py" --cpu 5 -- "$GWEAVE" stats "$BIG" -q \
      -- "$GWEAVE" stats "$f" -q)
    printf "%-30s %8s s   CPU time, best of 5 in turn with the text's %s s: %sx\n" "gweave stats (.$kind)" \
      "$cpu_prusa" "$cpu_text" "$(ratio "$cpu_prusa" "$cpu_text")"
    goal "stats of PrusaSlicer's .bgcode (under load)" "$(ratio "$cpu_prusa" "$cpu_text")" "<=" 2 \
      "x the text's CPU time"
  fi
done
