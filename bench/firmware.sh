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

# The 32-bit build (`make firmware-cortex`), beside the AVR's figures above: the same core for
# a Cortex-M4F, against the smallest chip of the boards it is meant for (docs/firmware.md).
CORTEX_ELF="$ROOT/firmware/out/gweave-cortex.elf"
if [ -s "$CORTEX_ELF" ]; then
  read -r ctext cdata cbss < <(llvm-size-22 "$CORTEX_ELF" | awk 'NR == 2 { print $1, $2, $3 }')
  echo "== firmware: $(basename "$CORTEX_ELF") (STM32F405/F407; not run on a cycle-exact emulator)"
  printf "%-26s %7s KB   of 1024 KB (STM32F407), 256 KB (STM32F103RC)\n" "flash (text + data)" "$(kb $((ctext + cdata)))"
  printf "%-26s %7s KB   of 128 KB (STM32F407), 48 KB (STM32F103RC); + main's stack\n" "static RAM (data + bss)" "$(kb $((cdata + cbss)))"
  python3 "$ROOT/bench/cortex_stack.py" "$CORTEX_ELF"
else
  echo "== no $CORTEX_ELF: make firmware-cortex for the 32-bit build's sizes"
fi

echo "== on the emulated board (stack, step interrupt, step rates)"
cargo run -q --release -p gweave-board --example budgets -- "$ELF" 2>/dev/null | grep -v '^Loaded'
