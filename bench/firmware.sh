#!/usr/bin/env bash
# The firmware's budgets (issues 37 and 38), beside the goals: flash and static RAM from avr-size
# (Marlin 1.1.9 for this board with EEPROM settings: 63.8 KB flash, 2.7 KB static RAM; at most
# 64 KB and 4 KB), the stack's high-water mark, the longest step interrupt and the highest
# step rate held (GRBL: 30 kHz on one axis; goal 20 kHz on three), measured on the emulated
# board; the highest step rate with X, Y and a 4-input mixing hotend stepping together (the
# mixing image); the flash and RAM of every image; then the inkjet build's nozzle pulses (issue
# 38). Not a test: `make firmware` first, then `bash bench/firmware.sh`.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
ELF="$ROOT/firmware/out/gweave-ramps.elf"
MIXING_ELF="$ROOT/firmware/out/gweave-ramps-mixing.elf"
for f in "$ELF" "$MIXING_ELF"; do [ -s "$f" ] || { echo "no $f: run make firmware first"; exit 1; }; done

kb() { python3 -c "print(f'{$1/1024:.1f}')"; }
# Flash and static RAM of one image against its goals: flash_goal_kb ram_goal_kb reference.
sizes() {
  local elf="$1" flash_goal="$2" ram_goal="$3" reference="$4" text data bss
  read -r text data bss < <(avr-size "$elf" | awk 'NR == 2 { print $1, $2, $3 }')
  echo "== firmware: $(basename "$elf")"
  printf "%-26s %7s KB   goal <= %s KB%s\n" "flash (text + data)" "$(kb $((text + data)))" "$flash_goal" "$reference"
  printf "%-26s %7s KB   goal <= %s KB\n" "static RAM (data + bss)" "$(kb $((data + bss)))" "$ram_goal"
  printf "%-26s %7s KB   of 8 KB\n" "RAM left for the stack" "$(kb $((8192 - data - bss)))"
}
# The base image (issue 37), and the machines' images (issue 38: a 4-input mixing hotend on E0,
# E1 and AUX-2; two hotends and extruders, EEB; M700 through an InkShield; a lathe's axis A
# on E1), each against the base.
sizes "$ELF" 64 4 " (Marlin 1.1.9: 63.8 KB, 2.7 KB RAM)"
read -r btext bdata bbss < <(avr-size "$ELF" | awk 'NR == 2 { print $1, $2, $3 }')
for image in mixing eeb inkjet rotary; do
  elf="$ROOT/firmware/out/gweave-ramps-$image.elf"
  if [ -s "$elf" ]; then
    read -r text data bss < <(avr-size "$elf" | awk 'NR == 2 { print $1, $2, $3 }')
    sizes "$elf" 128 6 " (base image: $(kb $((btext + bdata))) KB, $(kb $((bdata + bbss))) KB RAM)"
  else
    echo "== no $elf: run make firmware"
  fi
done

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
# Six motors at one rate: X, Y and the four inputs of the mixing hotend (M165, a quarter each).
echo "== the mixing image on the emulated board (X+Y and four mixing inputs)"
cargo run -q --release -p gweave-board --example budgets -- "$MIXING_ELF" --mixing 2>/dev/null | grep -v '^Loaded'

# Where the main loop's time goes while a host streams 0.5 mm lines at 60 mm/s, and its margin:
# the time to read and plan a line against the line's motion; then the cycles a line costs by
# function (the program counter's profile, on a shadow call stack; symbols from avr-nm).
echo "== streaming short segments: the main loop's margin and profile"
cargo run -q --release -p gweave-board --example profile -- "$ELF" 2>/dev/null | grep -v '^Loaded'

# The inkjet build (issue 38: M700 through an InkShield): its nozzle pulses on
# the emulated board against the InkShield's 5 us, and how fast a host can fire.
INK_ELF="$ROOT/firmware/out/gweave-ramps-inkjet.elf"
if [ -s "$INK_ELF" ]; then
  echo "== inkjet on the emulated board (nozzle pulses, fire rate)"
  cargo run -q --release -p gweave-board --example inkjet_budgets -- "$INK_ELF" 2>/dev/null | grep -v '^Loaded'
else
  echo "no $INK_ELF: run make firmware for the inkjet budgets"
fi
