#!/usr/bin/env bash
# Print-time estimate against klipper_estimator (dalegaard/klipper_estimator, a Rust estimator
# of Klipper's motion planner) on the large benchmark file, both with the same Klipper limits
# (bench/klipper-big-bed.toml, bench/klipper_estimator.json5): wall time, peak memory and the
# estimated time. Runs only where a klipper_estimator binary is found.
#
# The totals compared are motion time: gweave's motion + dwell + Klipper's fixed overheads
# (start buffer, M84 stalls, exit flush), against klipper_estimator's total less its
# "Indeterminate time" (0.1 s it puts in for each G28, M109, M190). gweave sim's own total also
# holds the heating and homing it simulates, which klipper_estimator does not model.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
KE=${KLIPPER_ESTIMATOR:-$(command -v klipper_estimator || true)}
if [ -z "$KE" ] && [ -x /work/kest-src/target/release/klipper_estimator ]; then
  KE=/work/kest-src/target/release/klipper_estimator
fi
if [ -z "$KE" ] || [ ! -x "$KE" ]; then
  echo "skipped: build dalegaard/klipper_estimator and set KLIPPER_ESTIMATOR"
  exit 0
fi
BIG="$ROOT/bench/data/bunny-gyroid.gcode"
if [ ! -s "$BIG" ]; then
  echo "skipped: $BIG is missing (bench/run.sh slices it)"
  exit 0
fi
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
cat "$BIG" > /dev/null

# measure NAME CMD...: run CMD twice, keep its standard output of the first run in $TMP/NAME.out,
# print "best-wall-seconds peak-MB".
measure() {
  local name=$1
  shift
  /usr/bin/time -f "%e %M" -o "$TMP/$name.t1" "$@" > "$TMP/$name.out"
  /usr/bin/time -f "%e %M" -o "$TMP/$name.t2" "$@" > /dev/null
  python3 - "$TMP/$name.t1" "$TMP/$name.t2" <<'EOF'
import sys
runs = [open(p).read().split()[-2:] for p in sys.argv[1:]]
print(f"{min(float(r[0]) for r in runs):.2f} {max(int(r[1]) for r in runs) / 1024:.0f}")
EOF
}

read -r t_ke m_ke < <(measure ke "$KE" --config_file "$ROOT/bench/klipper_estimator.json5" \
  estimate --format json "$BIG")
read -r t_gw m_gw < <(measure gw "$GWEAVE" sim "$BIG" --machine "$ROOT/bench/klipper-big-bed.toml" -q --json)

totals=$(python3 - "$TMP/ke.out" "$TMP/gw.out" <<'EOF'
import json, sys
ke = json.load(open(sys.argv[1]))["sequences"]
ke_total = sum(s["total_time"] for s in ke)
ke_motion = ke_total - sum(s["kind_times"].get("Indeterminate time", 0.0) for s in ke)
t = json.load(open(sys.argv[2]))["time"]
gw_motion = t["motion_s"] + t["dwell_s"] + t["overhead_s"]
print(f"{ke_motion:.1f} {gw_motion:.1f} {t['total_s']:.1f} {gw_motion - ke_motion:+.1f} "
      f"{100 * (gw_motion - ke_motion) / ke_motion:+.3f}")
EOF
)
read -r s_ke s_gw s_gw_all d_s d_pct <<< "$totals"
echo "file: $(basename "$BIG"), Klipper limits: max_velocity 300, max_accel 3000, minimum_cruise_ratio 0.5, scv 5"
printf "%-30s %7s s %7s MB   estimate %s s\n" "klipper_estimator estimate" "$t_ke" "$m_ke" "$s_ke"
printf "%-30s %7s s %7s MB   estimate %s s (%s s with heating and homing)\n" "gweave sim (+ steps, heaters)" \
  "$t_gw" "$m_gw" "$s_gw" "$s_gw_all"
printf "%-30s %7s x time  %6s x memory   estimates differ by %s s (%s %%)\n" "klipper_estimator / gweave" \
  "$(ratio "$t_ke" "$t_gw")" "$(ratio "$m_ke" "$m_gw")" "$d_s" "$d_pct"
