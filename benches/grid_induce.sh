#!/usr/bin/env bash
# Issue 42's table over the real example buildings in /work/shared/data (or $MDG_DATA):
# for every SIGI example and GDMC structure, `mdgc induce` with the default options,
# then its summary: complete seeds of 10, distinct buildings of 10, seeds keeping every
# block kind of the example, shapes, matches, moves and the induction time.
# Usage: benches/grid_induce.sh [MDGC] [extra mdgc induce options…]   (prints a markdown table)
set -euo pipefail
data="${MDG_DATA:-/work/shared/data}"
mdgc="${1:-target/release/mdgc}"
shift || true
if [ ! -d "$data/sigi-examples" ] || [ ! -d "$data/gdmc2023" ]; then
  echo "grid_induce.sh: the example data is missing: no $data/sigi-examples or $data/gdmc2023 (set MDG_DATA)" >&2
  exit 2
fi
[ -x "$mdgc" ] || { echo "grid_induce.sh: no $mdgc (build it: cargo build --release -p mdg-cli)" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "| example | blocks | shapes | matches | moves | complete of 10 | distinct of 10 | all kinds of 10 | induce ms | induce + 10 seeds s | warnings |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for f in "$data"/sigi-examples/*.txt "$data"/gdmc2023/*.nbt; do
  start=$(date +%s.%N)
  err=$("$mdgc" induce "$f" "$@" -o "$tmp/s.mdg" 2>&1 >/dev/null) || { echo "| $(basename "$f") | failed: ${err//$'\n'/ } |"; continue; }
  secs=$(echo "$(date +%s.%N) - $start" | bc)
  line=$(grep -m1 ' blocks → ' <<<"$err")
  sum=$(grep -m1 '^summary: ' <<<"$err")
  blocks=$(sed -E 's/.*: ([0-9]+) blocks → .*/\1/' <<<"$line")
  ms=$(sed -E 's/.*, ([0-9.]+) ms$/\1/' <<<"$line")
  shapes=$(sed -E 's/^summary: [0-9]+ moves, ([0-9]+) shapes.*/\1/' <<<"$sum")
  moves=$(sed -E 's/^summary: ([0-9]+) moves.*/\1/' <<<"$sum")
  matches=$(sed -E 's/.* shapes, ([0-9]+) matches.*/\1/' <<<"$sum")
  distinct=$(sed -E 's/.* give ([0-9]+) distinct.*/\1/' <<<"$sum")
  complete=$(sed -E 's/.* buildings, ([0-9]+) complete.*/\1/' <<<"$sum")
  kinds=$(sed -E 's/.*, ([0-9]+) with all its block kinds.*/\1/' <<<"$sum")
  warns=$(grep -o 'warning\[W09[0-9]*\]' <<<"$err" | sed -E 's/warning\[(.*)\]/\1/' | sort -u | paste -sd ' ' || true)
  printf '| %s | %s | %s | %s | %s | %s | %s | %s | %s | %.1f | %s |\n' "$(basename "$f")" "$blocks" "$shapes" "$matches" \
    "$moves" "$complete" "$distinct" "$kinds" "$ms" "$secs" "${warns:-}"
done
