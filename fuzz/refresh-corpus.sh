#!/usr/bin/env bash
# Replaces fuzz/corpus/<target>/ with a small set of inputs that covers every edge the last fuzz
# run reached (fuzz/out/<target>/, left by `make fuzz`) together with the corpus kept so far.
#
#   fuzz/refresh-corpus.sh gcode [MAX_FILES]
#
# afl-showmap gives each input's edges (hit counts ignored); a greedy cover then keeps, one at a
# time, the input that adds the most edges not yet covered (the shorter on a tie), until every edge
# is covered or MAX_FILES (default 100) are kept. Files are named by a hash of their bytes, so a
# refresh keeps the names of inputs it keeps again. Needs the target built (`make fuzz` does it).
set -euo pipefail
target=$1
max_files=${2:-100}
cd "$(dirname "$0")"
[[ -x target/release/$target ]] || { echo "build first: cd fuzz && cargo afl build --release" >&2; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir "$work/inputs"
cp corpus/"$target"/* "$work/inputs/" 2>/dev/null || true
cp out/"$target"/default/queue/id:* "$work/inputs/" 2>/dev/null || true
nice -n 19 cargo afl showmap -q -e -t 2000 -i "$work/inputs" -o "$work/maps" -- "target/release/$target" \
    >/dev/null 2>&1 || true

python3 - "$work" "$max_files" "corpus/$target" <<'EOF'
import hashlib, os, shutil, sys

work, max_files, dest = sys.argv[1], int(sys.argv[2]), sys.argv[3]
edges, data = {}, {}
for name in os.listdir(f"{work}/inputs"):
    with open(f"{work}/inputs/{name}", "rb") as f:
        data[name] = f.read()
    try:
        with open(f"{work}/maps/{name}") as f:
            edges[name] = {line.split(":")[0] for line in f if line.strip()}
    except FileNotFoundError:  # afl-showmap writes no map for an input that timed out
        edges[name] = set()
total = set().union(*edges.values())
covered, kept = set(), []
while len(kept) < max_files:
    best = max(edges, key=lambda n: (len(edges[n] - covered), -len(data[n])))
    if not edges[best] - covered:
        break
    covered |= edges.pop(best)
    kept.append(best)
shutil.rmtree(dest, ignore_errors=True)
os.makedirs(dest)
for name in kept:
    with open(f"{dest}/{hashlib.sha1(data[name]).hexdigest()[:16]}", "wb") as f:
        f.write(data[name])
size = sum(len(data[n]) for n in kept)
print(f"{dest}: {len(kept)} files, {size} bytes, {len(covered)} of {len(total)} edges")
EOF
