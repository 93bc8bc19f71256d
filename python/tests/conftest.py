"""Shared set-up of the mdg package's tests (run by .ci/run against the wheel it
built and installed into a venv, never the source tree: see test_installed_package).

`MDG_RUN` names the `mdg-run` binary the arrays are compared with (default: the
checkout's target/debug/mdg-run, which `cargo test --workspace` builds)."""

import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = sorted((ROOT / "std" / "examples").glob("*.mdg"))
# Grammars with an extension section run a mode of mdg-run (search, creatures, grid).
MODE_EXAMPLES = {"grid_cottage", "guided_tree", "guided_tree_paper", "monsters"}


def mdg_run_path():
    p = pathlib.Path(os.environ.get("MDG_RUN", ROOT / "target" / "debug" / "mdg-run"))
    if not p.is_file():
        pytest.fail(f"no mdg-run at {p}: build it (cargo build -p mdg-cli) or set MDG_RUN")
    return p


def mdgc_path():
    """mdgc, beside mdg-run."""
    p = mdg_run_path().with_name("mdgc")
    if not p.is_file():
        pytest.fail(f"no mdgc at {p}: build it (cargo build -p mdg-cli)")
    return p


def mdg_run(*args, cwd=None):
    """Runs mdg-run with ARGS; fails the test with its stderr if it fails."""
    r = subprocess.run([str(mdg_run_path()), *map(str, args)], capture_output=True, text=True, cwd=cwd)
    if r.returncode != 0:
        pytest.fail(f"mdg-run {' '.join(map(str, args))} failed ({r.returncode}):\n{r.stderr}")
    return r


def json_dump(path, tmp_path, *args):
    out = tmp_path / (pathlib.Path(path).stem + ".json")
    mdg_run(path, "--format", "json", "-o", out, *args)
    return json.loads(out.read_text())


@pytest.fixture(scope="session")
def root():
    return ROOT
