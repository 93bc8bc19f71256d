#!/usr/bin/env bash
# Redraws docs/grid.md's pictures of every real example beside three generated buildings:
# for each SIGI example (docs/img/grid_example_buildingNN.png) and GDMC structure
# (docs/img/grid_gdmc_NAME.png) of /work/shared/data (or $MDG_DATA), `mdgc induce` with
# the default options, then `mdg-run` seeds 3, 4 and 5 (the same seeds for every example)
# drawn beside the example, 900 × 300.
# Usage: benches/grid_pictures.sh [BIN_DIR] [OUT_DIR]   (defaults: target/release, docs/img)
set -euo pipefail
data="${MDG_DATA:-/work/shared/data}"
bin="${1:-target/release}"
out="${2:-docs/img}"
if [ ! -d "$data/sigi-examples" ] || [ ! -d "$data/gdmc2023" ]; then
  echo "grid_pictures.sh: the example data is missing: no $data/sigi-examples or $data/gdmc2023 (set MDG_DATA)" >&2
  exit 2
fi
for b in mdgc mdg-run; do
  [ -x "$bin/$b" ] || { echo "grid_pictures.sh: no $bin/$b (build it: cargo build --release -p mdg-cli)" >&2; exit 2; }
done
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
draw() { # example file, picture name
  "$bin/mdgc" induce "$1" -o "$tmp/s.mdg" 2>"$tmp/induce.log" >/dev/null ||
    { echo "grid_pictures.sh: $1: $(tail -1 "$tmp/induce.log")" >&2; return 1; }
  "$bin/mdg-run" "$tmp/s.mdg" --seed 3 --more 2 --size 900x300 --png "$out/$2.png" -o "$tmp/b.vox" 2>"$tmp/run.log" >/dev/null ||
    { echo "grid_pictures.sh: $1: $(tail -1 "$tmp/run.log")" >&2; return 1; }
  echo "$out/$2.png: $(grep -m1 '^summary: ' "$tmp/induce.log" | sed -E 's/.*give //')"
}
for f in "$data"/sigi-examples/building*.txt; do
  draw "$f" "grid_example_$(basename "$f" .txt)"
done
for f in "$data"/gdmc2023/*.nbt; do
  draw "$f" "grid_gdmc_$(basename "$f" .nbt)"
done
