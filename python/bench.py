"""The Python package's speed targets (issue 40), with the installed `mdg`:

    python python/bench.py [--mdg-run target/release/mdg-run] [--runs 5]

* `Program.run` of benches/workloads/tree.mdg (2^20 − 1 rule calls) into numpy
  (the run plus `model.positions`/`triangles`) against the CLI's evaluation time
  (`mdg-run --stats`' "time", which excludes writing): target ≤ 1.3×;
* `mdg.generate` of 64 seeds of std/examples/pebbles.mdg with workers=2 against
  workers=1 (each seed's arrays read): target ≥ 1.8× on 2 cores, arrays identical.

Prints the medians; build the wheel with `maturin build --release` for real numbers.
"""

import argparse
import pathlib
import re
import statistics
import subprocess
import time

import numpy as np

import mdg

ROOT = pathlib.Path(__file__).resolve().parents[1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--mdg-run", default=str(ROOT / "target" / "release" / "mdg-run"))
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args()

    tree = ROOT / "benches" / "workloads" / "tree.mdg"
    program = mdg.compile(tree)
    py, cli = [], []
    for _ in range(args.runs):
        started = time.perf_counter()
        model = program.run()
        model.positions, model.triangles
        py.append(time.perf_counter() - started)
        r = subprocess.run([args.mdg_run, tree, "--stats", "-o", "/dev/null", "--format", "json"],
                           capture_output=True, text=True)
        m = re.search(r"time ([0-9.]+) ms", r.stderr)
        if m is None:
            raise SystemExit(f"no time in mdg-run --stats: {r.stderr}")
        cli.append(float(m.group(1)) / 1000)
    p, c = statistics.median(py), statistics.median(cli)
    print(f"tree (2^20-1 calls, {len(model.positions)} vertices): Program.run into numpy {p * 1000:.0f} ms, "
          f"mdg-run's evaluation {c * 1000:.0f} ms: {p / c:.2f}x (target <= 1.3x)")

    pebbles = mdg.compile(ROOT / "std" / "examples" / "pebbles.mdg")
    seeds = range(64)

    def run(workers):
        started = time.perf_counter()
        got = [(s, m.positions) for s, m in mdg.generate(pebbles, seeds, workers=workers)]
        return time.perf_counter() - started, got

    one, a = run(1)
    two, b = run(2)
    same = all(sa == sb and np.array_equal(pa, pb) for (sa, pa), (sb, pb) in zip(a, b))
    print(f"generate 64 seeds of pebbles: workers=1 {one:.2f} s, workers=2 {two:.2f} s: {one / two:.2f}x "
          f"(target >= 1.8x on 2 cores), arrays identical: {same}")


if __name__ == "__main__":
    main()
