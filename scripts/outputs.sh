#!/usr/bin/env bash
# Every command's outputs on every bundled fixture, written to one folder, so that a refactor can
# be checked byte for byte: `scripts/outputs.sh before/` on the old commit, `scripts/outputs.sh
# after/` on the new one, then `diff -r before after`. Standard output and error are kept too
# (timing lines and the output folder's name removed: the only things that differ between two
# runs).
set -uo pipefail
OUT=${1:?usage: scripts/outputs.sh OUTDIR [GWEAVE]}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
G=${2:-$ROOT/target/release/gweave}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
cd "$ROOT"
FILES=(tests/data/*/*.gcode)
run() { # name, then the command; keeps exit code, stdout and stderr
  local name=$1; shift
  "$@" >"$OUT/$name.stdout" 2>"$OUT/$name.stderr"
  echo $? >"$OUT/$name.rc"
  sed -i -E '/(elapsed|took|[0-9.]+ ?(ms|MB\/s|s wall)|in [0-9.]+ ?s\b)/d' "$OUT/$name.stderr" "$OUT/$name.stdout"
  sed -i "s#$OUT#OUT#g" "$OUT/$name.stderr" "$OUT/$name.stdout"
}
for f in "${FILES[@]}"; do
  b=$(basename "$f" .gcode)
  run "$b.stats" "$G" stats "$f" --json
  run "$b.stats-human" "$G" stats "$f"
  run "$b.check" "$G" check "$f" --json
  run "$b.cat" "$G" cat "$f" -o "$OUT/$b.cat.gcode"
  run "$b.sim" "$G" sim "$f" --json -q
  run "$b.sim-mix" "$G" sim "$f" --machine examples/machines/mixing-4in.toml --json -q
  run "$b.estimate" "$G" estimate "$f" --json -q
  run "$b.estimate-klipper" "$G" estimate "$f" --machine examples/machines/klipper.toml --json -q
  run "$b.purge-shift" "$G" purge-shift "$f" --purge-mm 25 -o "$OUT/$b.ps.gcode" -q
  run "$b.purge-shift-gz" "$G" purge-shift "$f" --purge-mm 25 -o "$OUT/$b.ps.gcode.gz" -q
  for m in examples/mix/*.toml; do
    mb=$(basename "$m" .toml)
    run "$b.mix-$mb" "$G" mix "$f" --config "$m" -o "$OUT/$b.mix-$mb.gcode" --report "$OUT/$b.mix-$mb.json"
  done
  run "$b.mix-bgcode" "$G" mix "$f" --config examples/mix/bands.toml -o "$OUT/$b.mix.bgcode" -q
  run "$b.wrap" "$G" rotary wrap "$f" --mandrel-diameter 60 --allow-overlap -o "$OUT/$b.wrap.gcode" -q
  run "$b.preview-png" "$G" preview "$f" -o "$OUT/$b.png" -q
  run "$b.preview-iso" "$G" preview "$f" --view iso -o "$OUT/$b.iso.png" -q
  run "$b.preview-svg" "$G" preview "$f" -o "$OUT/$b.svg" -q
  run "$b.preview-html" "$G" preview "$f" -o "$OUT/$b.html" -q
done
run plate.wrap "$G" rotary wrap tests/data/rotary/plate.gcode --mandrel-diameter 30 --seam-rotation 7.5 \
  -o "$OUT/plate.wrap.gcode" --preview "$OUT/plate.wrap.png" --report "$OUT/plate.wrap.json"
run plate.helical "$G" rotary wrap tests/data/rotary/plate.gcode --mandrel-diameter 30 --helical \
  -o "$OUT/plate.helical.gcode" -q
for t in tube lattice; do
  run "rotary-$t" "$G" rotary tube --config "examples/rotary/$t.toml" -o "$OUT/rotary-$t.gcode" -q
done
for t in wrap wrap_rrf_y; do
  run "rotary-$t" "$G" rotary wrap tests/data/rotary/plate.gcode --config "examples/rotary/$t.toml" -o "$OUT/rotary-$t.gcode" -q
done
run raster-pattern "$G" raster --test-pattern -o "$OUT/pattern.gcode" -q
run tube "$G" rotary tube -o "$OUT/tube.gcode" --mandrel-diameter 20 --length 20 --layers 4 --preview "$OUT/tube.png" -q
run raster "$G" raster tests/data/sla/sphere.sl1 -o "$OUT/sphere.inkjet.gcode" --report "$OUT/raster.json" -q
run raster-2head "$G" raster examples/raster/layers --head examples/raster/c6602_2head.toml --dialect reprap -o "$OUT/layers.inkjet.gcode" -q
run raster-sim "$G" sim "$OUT/sphere.inkjet.gcode" --machine examples/machines/inkjet-c6602.toml --json -q
run raster-preview "$G" preview "$OUT/sphere.inkjet.gcode" -o "$OUT/sphere.inkjet.png" -q
run tube-preview "$G" preview "$OUT/tube.gcode" -o "$OUT/tube.preview.png" -q
run tube-html "$G" preview "$OUT/tube.gcode" -o "$OUT/tube.html" -q
run torus-plot "$G" sim tests/data/cura/cura_torus.gcode --plot "$OUT/torus.temps.png" -q
run torus-plot-svg "$G" sim tests/data/cura/cura_torus.gcode --plot "$OUT/torus.temps.svg" -q
run compare "$G" preview tests/data/cura/cura_torus.gcode --compare "$OUT/cura_torus.ps.gcode" -o "$OUT/compare.png" -q
run mix-predict "$G" mix --predict 1:1:0:0 --json
run mix-card "$G" mix --calibration-card -o "$OUT/card.gcode" -q
run seed-sim "$G" sim tests/data/cura/cura_torus.gcode --machine examples/machines/seed-controller.toml --json -q
run help "$G" --help
for c in stats check cat sim estimate machine raster slice-raster purge-shift serve mix preview; do
  run "help-$c" "$G" "$c" --help
done
run help-wrap "$G" rotary wrap --help
run help-tube "$G" rotary tube --help
sed -i "s#$OUT#OUT#g" "$OUT"/*.json
echo "$(ls "$OUT" | wc -l) files in $OUT"
