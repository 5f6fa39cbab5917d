#!/usr/bin/env bash
# Print-time estimate against klipper_estimator (dalegaard/klipper_estimator, a Rust estimator
# of Klipper's motion planner) on the large benchmark file, both with the same Klipper limits
# (bench/klipper-big-bed.toml, bench/klipper_estimator.json5): wall time, peak memory and the
# estimated time. Runs only where a klipper_estimator binary is found.
#
# The totals compared are motion time: gweave's motion + dwell + Klipper's fixed overheads
# (start buffer, M84 stalls, exit flush), against klipper_estimator's total less its
# "Indeterminate time" (0.1 s it puts in for each G28, M109, M190). gweave sim's own total also
# holds the heating and homing it simulates, which klipper_estimator does not model; gweave
# estimate (the same planner without heaters; reading and parsing on one thread, planning on another) is
# the like-for-like comparison.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
KE=${KLIPPER_ESTIMATOR:-$(command -v klipper_estimator || true)}
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

# This machine's speed drifts by tens of percent within minutes, so the three tools run in turn,
# three rounds, and each keeps its fastest run (its wall, user and system time) and its highest
# peak memory; the first run's standard output is kept in $TMP/NAME.out.
# run_once NAME ROUND CMD...
run_once() {
  local name=$1 round=$2
  shift 2
  local out=/dev/null
  [ "$round" = 1 ] && out="$TMP/$name.out"
  /usr/bin/time -f "%e %U %S %M" -o "$TMP/$name.t$round" "$@" > "$out"
}
# fastest NAME: "wall-s user-s sys-s peak-MB" of NAME's runs.
fastest() {
  python3 - "$TMP/$1".t* <<'EOF'
import sys
runs = [open(p).read().split()[-4:] for p in sys.argv[1:]]
best = min(runs, key=lambda r: float(r[0]))
peak = max(int(r[3]) for r in runs) / 1024
print(f"{float(best[0]):.2f} {float(best[1]):.2f} {float(best[2]):.2f} {peak:.0f}")
EOF
}

for round in 1 2 3; do
  run_once ke "$round" "$KE" --config_file "$ROOT/bench/klipper_estimator.json5" estimate --format json "$BIG"
  run_once gw "$round" "$GWEAVE" sim "$BIG" --machine "$ROOT/bench/klipper-big-bed.toml" -q --json
  run_once ge "$round" "$GWEAVE" estimate "$BIG" --machine "$ROOT/bench/klipper-big-bed.toml" -q --json
done
read -r t_ke u_ke s_ke_sys m_ke < <(fastest ke)
read -r t_gw u_gw s_gw_sys m_gw < <(fastest gw)
read -r t_ge u_ge s_ge_sys m_ge < <(fastest ge)

totals=$(python3 - "$TMP/ke.out" "$TMP/gw.out" "$TMP/ge.out" <<'EOF'
import json, sys
ke = json.load(open(sys.argv[1]))["sequences"]
ke_total = sum(s["total_time"] for s in ke)
ke_motion = ke_total - sum(s["kind_times"].get("Indeterminate time", 0.0) for s in ke)
t = json.load(open(sys.argv[2]))["time"]
gw_motion = t["motion_s"] + t["dwell_s"] + t["overhead_s"]
ge_total = json.load(open(sys.argv[3]))["total_s"]
print(f"{ke_motion:.2f} {gw_motion:.2f} {t['total_s']:.1f} {gw_motion - ke_motion:+.3f} "
      f"{1e6 * (gw_motion - ke_motion) / ke_motion:+.2f} {ge_total:.2f} {ge_total - ke_motion:+.3f}")
EOF
)
read -r s_ke s_gw s_gw_all d_s d_ppm s_ge d_ge <<< "$totals"
echo "file: $(basename "$BIG"), Klipper limits: max_velocity 300, max_accel 3000, minimum_cruise_ratio 0.5, scv 5"
row() { printf "%-30s %7s s wall %6s s user %6s s sys %6s MB   %s\n" "$@"; }
row "klipper_estimator estimate" "$t_ke" "$u_ke" "$s_ke_sys" "$m_ke" "estimate $s_ke s"
row "gweave sim (+ steps, heaters)" "$t_gw" "$u_gw" "$s_gw_sys" "$m_gw" \
  "estimate $s_gw s ($s_gw_all s with heating and homing)"
row "gweave estimate (2 threads)" "$t_ge" "$u_ge" "$s_ge_sys" "$m_ge" "estimate $s_ge s"
# CPU time is user + system of all threads: klipper_estimator's system time (2.4-4.3 s, the
# 3.6 GB it allocates) is part of its cost, and varies more than its user time.
cpu() { python3 -c "import sys; print(float(sys.argv[1]) + float(sys.argv[2]))" "$1" "$2"; }
c_ke=$(cpu "$u_ke" "$s_ke_sys")
echo "klipper_estimator / gweave sim: $(ratio "$t_ke" "$t_gw")x wall time (goal >= 3x), $(ratio "$c_ke" "$(cpu "$u_gw" "$s_gw_sys")")x CPU time," \
  "$(ratio "$m_ke" "$m_gw")x peak memory; estimates differ by $d_s s ($d_ppm per million)"
echo "klipper_estimator / gweave estimate: $(ratio "$t_ke" "$t_ge")x wall time (goal >= 15x)," \
  "$(ratio "$c_ke" "$(cpu "$u_ge" "$s_ge_sys")")x CPU time, all threads (goal >= 10x), $(ratio "$m_ke" "$m_ge")x peak memory; estimates differ by $d_ge s"
goal "estimate, $(python3 -c "print(f'{$(stat -L -c %s "$BIG")/1e6:.0f}')") MB: klipper_estimator's wall time" "$(ratio "$t_ke" "$t_ge")" ">=" 15 "x faster"
goal "estimate: klipper_estimator's CPU time" "$(ratio "$c_ke" "$(cpu "$u_ge" "$s_ge_sys")")" ">=" 10 "x less"
goal "sim with steps and heaters: klipper_estimator" "$(ratio "$t_ke" "$t_gw")" ">=" 3 "x faster"
