#!/usr/bin/env bash
# The firmware's budgets (issue 37), beside the goals: flash and static RAM from avr-size
# (Marlin 1.1.9 for this board with EEPROM settings: 63.8 KB flash, 2.7 KB static RAM; at most
# 64 KB and 4 KB), the stack's high-water mark, the longest step interrupt and the highest
# step rate held (GRBL: 30 kHz on one axis; goal 20 kHz on three), measured on the emulated
# board. Not a test: `make firmware` first, then `bash bench/firmware.sh`.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
ELF="$ROOT/firmware/out/gweave-ramps.elf"
[ -s "$ELF" ] || { echo "no $ELF: run make firmware first"; exit 1; }

read -r text data bss < <(avr-size "$ELF" | awk 'NR == 2 { print $1, $2, $3 }')
kb() { python3 -c "print(f'{$1/1024:.1f}')"; }
echo "== firmware: $(basename "$ELF")"
printf "%-26s %7s KB   goal <= 64 KB (Marlin 1.1.9: 63.8 KB)\n" "flash (text + data)" "$(kb $((text + data)))"
printf "%-26s %7s KB   goal <= 4 KB (Marlin 1.1.9: 2.7 KB)\n" "static RAM (data + bss)" "$(kb $((data + bss)))"
printf "%-26s %7s KB   of 8 KB\n" "RAM left for the stack" "$(kb $((8192 - data - bss)))"

echo "== on the emulated board (stack, step interrupt, step rates)"
cargo run -q --release -p gweave-board --example budgets -- "$ELF" 2>/dev/null | grep -v '^Loaded'
