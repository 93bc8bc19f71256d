"""The Python package's speed targets (issue 40), with the installed `mdg`:

    python benches/python_package.py [--mdg-run target/release/mdg-run] [--runs 5]

* `Program.run` of benches/workloads/tree.mdg (2^20 − 1 rule calls) into numpy
  against the CLI's evaluation time (`mdg-run --stats`' "time", which excludes
  writing): target ≤ 1.3×. Twice: with the squares as instances (`instances` and
  `base_mesh`), and flattened (`positions`, `triangles`, `normals`, `colors`: 6.3M
  vertices written out);
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
    limits = {"max_vertices": 10_000_000}
    inst, flat, cli = [], [], []
    for _ in range(args.runs):
        started = time.perf_counter()
        model = program.run(limits=limits)
        i = model.instances
        i.translation, i.rotation, i.scale, model.base_mesh.positions
        inst.append(time.perf_counter() - started)
        started = time.perf_counter()
        model = program.run(limits=limits)
        model.positions, model.triangles, model.normals, model.colors
        flat.append(time.perf_counter() - started)
        r = subprocess.run([args.mdg_run, tree, "--stats", "--max-vertices", "10000000", "-o", "/dev/null",
                            "--format", "json"], capture_output=True, text=True)
        m = re.search(r"time ([0-9.]+) ms", r.stderr)
        if m is None:
            raise SystemExit(f"no time in mdg-run --stats: {r.stderr}")
        cli.append(float(m.group(1)) / 1000)
    a, b, c = statistics.median(inst), statistics.median(flat), statistics.median(cli)
    print(f"tree (2^20-1 calls): mdg-run's evaluation {c * 1000:.0f} ms; Program.run into numpy as instances "
          f"({len(model.instances)} rows + base_mesh) {a * 1000:.0f} ms = {a / c:.2f}x (target <= 1.3x); "
          f"flattened ({len(model.positions)} vertices) {b * 1000:.0f} ms = {b / c:.2f}x")

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
