"""The Python package's speed targets (issue 40), with the installed `mdg`:

    python benches/python_package.py [--mdg-run target/release/mdg-run] [--runs 5]

* `Program.run` of benches/workloads/tree.mdg (2^20 − 1 rule calls) into numpy
  against the CLI's evaluation time (`mdg-run --stats --format none`'s "time", the
  evaluator's own, and its evaluate phase's CPU): target ≤ 1.3×, wall and CPU
  time, medians, with the load average. Twice: with the squares as instances
  (`instances` and `base_mesh`), and flattened (`positions`, `triangles`, `normals`, `colors`: 6.3M
  vertices written out);
* `mdg.generate` of 64 seeds of std/examples/pebbles.mdg with workers=2 against
  workers=1 (each seed's arrays read): target ≥ 1.8× on 2 cores, arrays identical.

Prints the medians; build the wheel with `maturin build --release` for real numbers.
"""

import argparse
import os
import pathlib
import re
import statistics
import subprocess
import time

import numpy as np

import mdg

ROOT = pathlib.Path(__file__).resolve().parents[1]


def cli_eval(mdg_run, tree):
    """mdg-run's evaluation of `tree`: (wall ms, CPU ms) from --stats (the evaluator's
    own time, and the evaluate phase's CPU in 10 ms ticks; nothing written)."""
    r = subprocess.run([mdg_run, tree, "--stats", "--max-vertices", "10000000", "--format", "none"],
                       capture_output=True, text=True)
    wall = re.search(r"time ([0-9.]+) ms", r.stderr)
    cpu = re.search(r"evaluate [0-9.]+ ms wall ([0-9.]+) ms CPU", r.stderr)
    if wall is None or cpu is None:
        raise SystemExit(f"no times in mdg-run --stats: {r.stderr}")
    return float(wall.group(1)), float(cpu.group(1))


def timed(f):
    """(wall ms, process CPU ms: every thread) of f()."""
    w, c = time.perf_counter(), time.process_time()
    f()
    return (time.perf_counter() - w) * 1000, (time.process_time() - c) * 1000


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--mdg-run", default=str(ROOT / "target" / "release" / "mdg-run"))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--only", choices=["tree", "generate"], help="run one of the two workloads")
    args = ap.parse_args()
    if args.only != "generate":
        tree_bench(args)
    if args.only != "tree":
        generate_bench()


def tree_bench(args):

    tree = ROOT / "benches" / "workloads" / "tree.mdg"
    program = mdg.compile(tree)
    limits = {"max_vertices": 10_000_000}
    load = [os.getloadavg()[0]]
    inst, flat, cli, evals, free = [], [], [], [], []
    for _ in range(args.runs):
        cli.append(cli_eval(args.mdg_run, tree))
        held = {}

        def instances():
            m = held["m"] = program.run(limits=limits)
            i = m.instances
            i.translation, i.rotation, i.scale, i.color, i.prototype, m.base_mesh.positions

        inst.append(timed(instances))
        evals.append(held["m"].stats["elapsed_ms"])
        # Freeing the model is not part of the run (mdg-run's time leaves out its exit).
        free.append(timed(held.clear))

        def flattened():
            m = held["m"] = program.run(limits=limits)
            m.positions, m.triangles, m.normals, m.colors

        flat.append(timed(flattened))
        n_vertices = len(held["m"].positions)
        free.append(timed(held.clear))
        load.append(os.getloadavg()[0])
    med = lambda xs, k: statistics.median(x[k] for x in xs)  # noqa: E731
    cw, cc = med(cli, 0), med(cli, 1)
    iw, ic, fw, fc = med(inst, 0), med(inst, 1), med(flat, 0), med(flat, 1)
    print(f"tree (2^20-1 calls), medians of {args.runs}, load average {min(load):.1f}-{max(load):.1f}:")
    print(f"  mdg-run's evaluation:        {cw:6.1f} ms wall {cc:6.0f} ms CPU")
    print(f"  Program.run's evaluation:    {statistics.median(evals):6.1f} ms wall (Model.stats['elapsed_ms'])")
    print(f"  Program.run into numpy, instances + base_mesh: {iw:6.1f} ms wall {ic:6.0f} ms CPU = "
          f"{iw / cw:.2f}x wall (target <= 1.3x)")
    print(f"  Program.run into numpy, flattened ({n_vertices} vertices): {fw:6.1f} ms wall {fc:6.0f} ms CPU = "
          f"{fw / cw:.2f}x wall")
    print(f"  freeing a model (not counted above): {statistics.median(x[0] for x in free):.1f} ms wall")


def generate_bench():
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
