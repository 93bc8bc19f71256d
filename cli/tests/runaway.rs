//! Runaway grammars and the caps a grammar cannot raise (issue 35): `stacksize` and
//! `maxiter` in the grammar are capped by `--max-stack` and `--max-iter`; the
//! evaluation limits reach the grid and creature modes; line profiles count against
//! the vertex budget as they are made; and inputs that used to be superlinear are
//! not. Each binary runs in its own process under `ulimit -v` and a time limit, with
//! its peak resident memory sampled (`bounded`).

mod bounded;

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::Duration;

/// Virtual memory each child may map (KiB): 3 GiB.
const VMEM_KIB: u64 = 3 * 1024 * 1024;

/// A test's scratch directory, removed when the test ends (passed or failed).
struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn scratch(name: &str) -> Scratch {
    let d = std::env::temp_dir().join(format!("mdg-runaway-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    Scratch(d)
}

/// Runs `bin ARGS` in `dir`; asserts it ended by itself within `limit` and that its
/// peak resident memory stayed under `peak_mib`.
fn run(dir: &Path, bin: &str, args: &[&str], peak_mib: u64, limit: u64) -> Output {
    let r = bounded::run(dir, bin, args, &[], VMEM_KIB, Duration::from_secs(limit));
    let name = bin.rsplit('/').next().unwrap_or(bin);
    eprintln!("{name} {}: peak RSS {:.1} MiB, {:?}", args.join(" "), r.peak_kib as f64 / 1024.0, r.took);
    assert!(!r.timed_out, "{name} {args:?} ran past {limit} s");
    assert!(r.peak_kib < peak_mib * 1024, "{args:?}: peak RSS {} KiB, more than {peak_mib} MiB", r.peak_kib);
    let e = stderr(&r.output);
    assert!(!e.contains("panicked"), "panicked: {e}");
    r.output
}

fn mdg_run(dir: &Path, args: &[&str], peak_mib: u64) -> Output {
    run(dir, env!("CARGO_BIN_EXE_mdg-run"), args, peak_mib, 120)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn ok(o: &Output) -> String {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(0), "{e}");
    e
}

// ------------------------------------------------------------ caps on the grammar

#[test]
fn a_grammar_cannot_raise_its_stack_past_max_stack() {
    let dir = scratch("stack");
    // Binary recursion without a limit: depth-first, the stack holds one pending
    // sibling per level, so it grows until the stack limit ends the branch.
    std::fs::write(dir.join("a.mdg"), "stacksize 1e12\nstartshape A\nrule A { A {x 1} A {y 1} }\n").expect("write");
    // 1,000,000 activations (the default cap) are ~110 MB; the grammar's 1e12 used
    // to be taken as it is (1 GB and more).
    let e = ok(&mdg_run(&dir, &["a.mdg", "-o", "a.obj", "--max-iter", "3000000"], 256));
    assert!(e.contains("the grammar's `stacksize 4294967295 or more`") && e.contains("capped at 1000000"), "{e}");
    assert!(e.contains("stack size 1000000 reached"), "{e}");
    // The flag lowers it further, and the limit warning names the flag to raise.
    let e = ok(&mdg_run(&dir, &["a.mdg", "-o", "a.obj", "--max-stack", "1000"], 256));
    assert!(e.contains("stack size 1000 reached"), "{e}");
    assert!(e.contains("--max-stack"), "{e}");
}

#[test]
fn a_grammar_cannot_raise_maxiter_past_max_iter() {
    let dir = scratch("iter");
    // An iterator that draws nothing and a grammar that switches maxiter off: this
    // ran for ever.
    std::fs::write(
        dir.join("a.mdg"),
        "maxiter 1e15\nstartshape A\nrule A { 1000000000000000 * {rz 1} B {} }\nrule B { }\n",
    )
    .expect("write");
    let e = ok(&mdg_run(&dir, &["a.mdg", "-o", "a.obj", "--max-iter", "200000"], 256));
    assert!(e.contains("maxiter 1000000000000000") && e.contains("capped"), "{e}");
    assert!(e.contains("maxiter 200000 reached"), "{e}");
    assert!(e.contains("--max-iter"), "{e}");
    // The default cap ends it too (100,000,000 calls: seconds, not for ever).
    let e = ok(&mdg_run(&dir, &["a.mdg", "-o", "a.obj"], 256));
    assert!(e.contains("maxiter 100000000 reached"), "{e}");
}

#[test]
fn the_caps_are_in_help() {
    for bin in [env!("CARGO_BIN_EXE_mdg-run"), env!("CARGO_BIN_EXE_mdg-view")] {
        let o = std::process::Command::new(bin).arg("--help").output().expect("run");
        let h = String::from_utf8_lossy(&o.stdout);
        assert!(h.contains("--max-iter") && h.contains("--max-stack"), "{bin}: {h}");
    }
}

// ------------------------------------------------------------ every mode

const GRID: &str = "startshape site
rule site { 20000 * {x 1} tri {} }
rule tri { VERTEX {} VERTEX {x 0.5} VERTEX {y 0.5} }
grid g {
  palette { stone \"minecraft:stone\" 127 127 127; }
  shape a { size 1 1 1; plane y; at 0 0 0; blocks stone; }
  start a;
}
";

#[test]
fn the_vertex_budget_reaches_the_grid_mode() {
    let dir = scratch("grid");
    std::fs::write(dir.join("g.mdg"), GRID).expect("write");
    let e = ok(&mdg_run(&dir, &["g.mdg", "-o", "g.glb", "--max-vertices", "3000"], 256));
    assert!(e.contains("vertex budget 3000 reached"), "{e}");
}

#[test]
fn the_time_budget_reaches_the_grid_mode() {
    let dir = scratch("grid-time");
    let g = GRID.replace("20000 * {x 1} tri {} }", "100000000 * {x 1} B {} tri {} }\nrule B { }");
    std::fs::write(dir.join("g.mdg"), g).expect("write");
    let e = ok(&mdg_run(&dir, &["g.mdg", "-o", "g.glb", "--time-budget", "50ms", "--max-iter", "100000000"], 256));
    assert!(e.contains("time budget reached"), "{e}");
}

/// The std folder of the repository (the creature grammar imports `creatures`).
fn std_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../std")
}

#[test]
fn the_vertex_budget_reaches_the_creature_mode() {
    let dir = scratch("creature");
    let monsters = std_dir().join("examples/monsters.mdg");
    let m = monsters.to_str().expect("utf-8");
    let o = mdg_run(
        &dir,
        &[m, "-o", "out", "--generations", "1", "--population", "2", "--seed", "1", "--max-vertices", "12"],
        1024,
    );
    let e = stderr(&o);
    assert!(e.contains("vertex budget 12 reached"), "{e}");
}

#[test]
fn the_creature_mode_compiles_with_the_command_lines_std() {
    // A copy of std where the torso of the humanoid is a different part: the run
    // must use it (it used to re-read the built-in std when it embedded the meshes).
    let dir = scratch("creature-std");
    let my_std = dir.join("mystd");
    std::fs::create_dir_all(&my_std).expect("mkdir");
    for f in std::fs::read_dir(std_dir()).expect("std") {
        let f = f.expect("entry").path();
        if f.is_file() {
            std::fs::copy(&f, my_std.join(f.file_name().expect("name"))).expect("copy");
        }
    }
    // Meshes the creature library reads from OBJ files next to it.
    let src = std_dir();
    for sub in std::fs::read_dir(&src).expect("std") {
        let sub = sub.expect("entry").path();
        if sub.is_dir() && sub.file_name().is_some_and(|n| n != "examples") {
            copy_dir(&sub, &my_std.join(sub.file_name().expect("name")));
        }
    }
    let creatures = std::fs::read_to_string(my_std.join("creatures.mdg")).expect("read");
    std::fs::write(my_std.join("creatures.mdg"), format!("{creatures}\n// mine\n")).expect("write");
    std::fs::copy(std_dir().join("examples/monsters.mdg"), dir.join("monsters.mdg")).expect("copy");
    let std_arg = my_std.to_str().expect("utf-8");
    let o = mdg_run(
        &dir,
        &["monsters.mdg", "--std", std_arg, "-o", "out", "--generations", "1", "--population", "2", "--seed", "1"],
        1024,
    );
    ok(&o);
    // Break the copy: the run must now fail, which it can only if it reads it.
    std::fs::write(my_std.join("creatures.mdg"), format!("{creatures}\nrule broken {{ nosuchrule {{}} }}\n"))
        .expect("write");
    let o = mdg_run(
        &dir,
        &["monsters.mdg", "--std", std_arg, "-o", "out2", "--generations", "1", "--population", "2", "--seed", "1"],
        1024,
    );
    assert_ne!(o.status.code(), Some(0), "the broken --std was not used: {}", stderr(&o));
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("mkdir");
    for f in std::fs::read_dir(from).expect("dir") {
        let f = f.expect("entry").path();
        let dest = to.join(f.file_name().expect("name"));
        if f.is_dir() {
            copy_dir(&f, &dest);
        } else {
            std::fs::copy(&f, dest).expect("copy");
        }
    }
}

// ------------------------------------------------------------ line profiles

#[test]
fn line_profile_vertices_count_against_the_vertex_budget() {
    let dir = scratch("profile");
    // A profile of 10^12 points (ended by maxiter at 10^7) swept along two segments:
    // 2.2 GB and half a minute, whatever --max-vertices said.
    std::fs::write(
        dir.join("p.mdg"),
        "startshape A\nlinerule prof\nrule prof { 1000000000000 * {rz 30} VERTEX {x 0.05} }\n\
         rule A { MOVETO {} LINETO {x 1} LINETO {x 2} }\n",
    )
    .expect("write");
    let e = ok(&mdg_run(&dir, &["p.mdg", "-o", "p.glb", "--max-vertices", "1000"], 256));
    // The profile is cut at half the budget, and the second segment's sweep would
    // pass it, so the run stops before making it.
    assert!(e.contains("profile rule `prof` makes more than 500 points"), "{e}");
    assert!(e.contains("vertex budget 1000 reached"), "{e}");
    let len = std::fs::metadata(dir.join("p.glb")).expect("written").len();
    assert!(len < 200_000, "{len} bytes for a 1000-vertex budget");
}

#[test]
fn a_profile_past_its_point_limit_is_cut_with_a_warning() {
    let dir = scratch("profile-cap");
    std::fs::write(
        dir.join("p.mdg"),
        "startshape A\nlinerule prof\nrule prof { 1000000000000 * {rz 30} VERTEX {x 0.05} }\n\
         rule A { MOVETO {} LINETO {x 1} }\n",
    )
    .expect("write");
    let e = ok(&mdg_run(&dir, &["p.mdg", "-o", "p.obj"], 512));
    assert!(e.contains("profile rule `prof`") && e.contains("points"), "{e}");
}
