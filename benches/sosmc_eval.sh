#!/usr/bin/env bash
# Guided search evaluation (docs/guided.md): the guiding-curves paper's Fig. 4 on the
# std tree grammar — final COST with and without the heuristic at alignment offsets
# 0.6 and 0.5, generation-size ramping, and the forward-sampling baseline (best of N
# complete samples), all at the same budget of particle-steps — as a table.
#
# Usage: benches/sosmc_eval.sh [RUNS]   (default 500 runs per row; seeds 1..RUNS, the same in every row; three guide sets)
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${1:-500}
cargo build --release -q -p mdg-cli --bin mdgc
mkdir -p target/sosmc
target/release/mdgc build std/examples/guided_tree.mdg -o target/sosmc/guided_tree.mdgb > /dev/null
MDG_SOSMC_BUNDLE=target/sosmc/guided_tree.mdgb \
  cargo run --release -q -p mdg-vm --example sosmc_eval -- fig4 --runs "$RUNS"
