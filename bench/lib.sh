# Shared by the benchmark scripts (sourced, not run, with the script's own arguments): where the
# project is, the gweave binary to measure (first argument, default the release build), timing
# helpers and the large files.
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
GWEAVE=$(realpath "${1:-$ROOT/target/release/gweave}")
# The multi-tool fixture the large file is made from (also measured on its own for memory).
SRC="$ROOT/tests/data/prusaslicer/pr_bunny_3tool_rel.gcode"
best() { python3 "$ROOT/bench/besttime.py" "$@"; }
peak_mb() { /usr/bin/time -f %M "$@" 2>&1 >/dev/null | tail -1 | awk '{printf "%.1f", $1/1024}'; }
ratio() { python3 -c "import sys; print(f'{float(sys.argv[1])/float(sys.argv[2]):.2f}')" "$1" "$2"; }

# The PrusaSlicer 3-tool bunny (relative E, 793 changes) with its print proper repeated 60 times
# (about 225 MB, 47 000 changes). Prints the path.
multitool_file() {
  local src="$SRC"
  local big="$ROOT/bench/data/bunny-3tool-x60.gcode"
  mkdir -p "$ROOT/bench/data"
  if [ ! -s "$big" ]; then
    local first last
    first=$(grep -n -m1 '^;LAYER_CHANGE' "$src" | cut -d: -f1)
    last=$(grep -n '^;TYPE:Custom' "$src" | tail -1 | cut -d: -f1)
    {
      head -n $((first - 1)) "$src"
      for _ in $(seq 60); do sed -n "${first},$((last - 1))p" "$src"; done
      tail -n +"$last" "$src"
    } > "$big"
  fi
  echo "$big"
}

# Issue 35's table: `goal LABEL VALUE OP GOAL UNIT` records a figure beside its goal (OP: `<=`,
# `>=`) in $BENCH_GOALS, which bench/run.sh prints at the end, marking the ones short of their
# goal. Without $BENCH_GOALS (a script run on its own) nothing is recorded.
goal() {
  [ -n "${BENCH_GOALS:-}" ] || return 0
  printf '%s\t%s\t%s\t%s\t%s\n' "$1" "$2" "$3" "$4" "$5" >> "$BENCH_GOALS"
}
