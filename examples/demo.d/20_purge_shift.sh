#!/usr/bin/env bash
# Multi-colour without a wipe tower: every tool change moved 2.5 mm of filament earlier.
set -euo pipefail
echo "== gweave purge-shift: Slic3r two-tool cone, 2.5 mm purge"
"$GWEAVE" purge-shift "$DATA/slic3r/slic3r_cone_2tool.gcode" -o "$OUT/slic3r_cone.shifted.gcode" \
  --purge 2.5 --report "$OUT/purge-shift-report.json" | tail -4
