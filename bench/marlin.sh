#!/usr/bin/env bash
# Print-time estimate against Marlin's own planner: `marlin-calc`, the host build of Marlin
# bugfix-2.0.x that the PrintTimeGenius OctoPrint plugin runs (tests/data/README.md says how to
# build it; it is GPL, so it is never part of the project). Runs only where MARLIN_CALC names the
# binary. Every fixture is prepared as the README says and run with PrusaSlicer's normal limits
# in both corner modes: each tool's estimate and wall time (best of 3), the difference, and how
# many times faster gweave is.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
MC=${MARLIN_CALC:-}
if [ -z "$MC" ] || [ ! -x "$MC" ]; then
  echo "skipped: build Marlin's marlin-calc (tests/data/README.md) and set MARLIN_CALC"
  exit 0
fi
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
LIMITS="$ROOT/bench/marlin_limits.py"
printf "%-26s %-5s %11s %11s %9s %9s %9s %7s\n" file mode "Marlin s" "gweave s" diff "Marlin t" "gweave t" speed
for fixture in prusaslicer/pr_torus_pva prusaslicer/pr_bunny_3tool_rel prusaslicer/pr_sphere_rrf_fwretract \
  cura/cura_torus cura/cura_dual slic3r/slic3r_cone_2tool; do
  name=$(basename "$fixture")
  file="$TMP/$name.gcode"
  python3 "$LIMITS" prepare "$ROOT/tests/data/$fixture.gcode" "$file"
  for mode in jd jerk; do
    mcodes=$(python3 "$LIMITS" mcodes prusa "$mode")
    python3 "$LIMITS" toml prusa "$mode" > "$TMP/$mode.toml"
    s_m=$("$MC" "$file" "$mcodes" 2>/dev/null | python3 "$LIMITS" total)
    s_g=$("$GWEAVE" estimate "$file" --machine "$TMP/$mode.toml" -q --json | python3 -c "import json,sys; print(json.load(sys.stdin)['total_s'])")
    read -r t_m t_g < <(best 3 -- "$MC" "$file" "$mcodes" -- "$GWEAVE" estimate "$file" --machine "$TMP/$mode.toml" -q --json)
    diff=$(python3 -c "import sys; m, g = map(float, sys.argv[1:]); print(f'{100 * (g - m) / m:+.4f}%')" "$s_m" "$s_g")
    printf "%-26s %-5s %11.3f %11.3f %9s %8ss %8ss %6sx\n" "$name" "$mode" "$s_m" "$s_g" "$diff" "$t_m" "$t_g" "$(ratio "$t_m" "$t_g")"
  done
done
echo "limits: $(python3 "$LIMITS" mcodes prusa jerk | tr '\n' ' ')(or M205 S0 T0 J0.013)"
