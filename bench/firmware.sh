#!/usr/bin/env bash
# The firmware's budgets (issue 37), beside the goals: flash and static RAM from avr-size
# (Marlin 1.1.9 for this board with EEPROM settings: 63.8 KB flash, 2.7 KB static RAM; at most
# 64 KB and 4 KB), the stack's high-water mark, the longest step interrupt and the highest
# step rate held (GRBL: 30 kHz on one axis; goal 20 kHz on three), measured on the emulated
# board; then the inkjet build's size and nozzle pulses (issue 38). Not a test: `make firmware`
# first, then `bash bench/firmware.sh`.
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

# The inkjet build (issue 38: M700 through an InkShield): its size, then its nozzle pulses on
# the emulated board against the InkShield's 5 us, and how fast a host can fire.
INK_ELF="$ROOT/firmware/out/gweave-ramps-inkjet.elf"
if [ -s "$INK_ELF" ]; then
  read -r itext idata ibss < <(avr-size "$INK_ELF" | awk 'NR == 2 { print $1, $2, $3 }')
  echo "== firmware: $(basename "$INK_ELF")"
  printf "%-26s %7s KB   base image: %s KB (256 KB on the chip; issue 38: <= 128 KB)\n" "flash (text + data)" \
    "$(kb $((itext + idata)))" "$(kb $((text + data)))"
  printf "%-26s %7s KB   base image: %s KB (goal <= 6 KB)\n" "static RAM (data + bss)" \
    "$(kb $((idata + ibss)))" "$(kb $((data + bss)))"
  echo "== inkjet on the emulated board (nozzle pulses, fire rate)"
  cargo run -q --release -p gweave-board --example inkjet_budgets -- "$INK_ELF" 2>/dev/null | grep -v '^Loaded'
else
  echo "no $INK_ELF: run make firmware for the inkjet budgets"
fi
