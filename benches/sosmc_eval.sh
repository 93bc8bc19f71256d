#!/usr/bin/env bash
# Guided search evaluation (docs/guided.md): the guiding-curves paper's Fig. 4 on the
# std tree grammar — final COST with and without the heuristic at alignment offsets
# 0.6 and 0.5, generation-size ramping, and the forward-sampling baseline (best of N
# complete samples), all at the same budget of particle-steps — as a table.
#
# Usage: benches/sosmc_eval.sh [RUNS]   (default 500 runs per row; seeds 1..RUNS, the same in every row)
#
# Guide sets: the grammar's own guides, std/examples/guides/arch.json and windswept.json
# (searched with the grammar's `search` section), then — when ../shared/data is there —
# Calder's benchmark curves (../shared/data/guides/calder_benchmark.json, never
# committed) twice: with Calder's playground search parameters (`@calder`: heuristic
# scale 0.013 over the first 40% of 100 generations, particles 100 → 15, EXPECTED from
# 4 samples) and with the grammar's. Without ../shared the Calder sets are skipped
# with a note.
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${1:-500}
GUIDES=program,std/examples/guides/arch.json,std/examples/guides/windswept.json
CALDER=../shared/data/guides/calder_benchmark.json
if [ -f "$CALDER" ]; then
  GUIDES="$GUIDES,$CALDER@calder,$CALDER"
else
  echo "note: $CALDER not found (../shared/data is absent): Calder's curves are skipped" >&2
fi
cargo build --release -q -p mdg-cli --bin mdgc
mkdir -p target/sosmc
target/release/mdgc build std/examples/guided_tree.mdg -o target/sosmc/guided_tree.mdgb > /dev/null
MDG_SOSMC_BUNDLE=target/sosmc/guided_tree.mdgb \
  cargo run --release -q -p mdg-guided --example sosmc_eval -- fig4 --runs "$RUNS" --guides "$GUIDES"
