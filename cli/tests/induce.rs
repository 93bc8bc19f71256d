//! `mdgc induce`'s summary and warnings: moves, shapes, matches and what ten seeds
//! generate; W0901 (no match), W0902 (no move) and W0903 (identical seeds), each
//! with its code. The buildings are written by the test.

use std::process::Command;

/// A 5 × 5 house of stone with glass windows, a doorway and a slab roof.
fn house() -> String {
    let mut s = String::new();
    for x in 0..5 {
        for z in 0..5 {
            s.push_str(&format!("{x} 0 {z} minecraft:oak_planks\n{x} 4 {z} minecraft:oak_slab[type=bottom]\n"));
            let edge = x == 0 || x == 4 || z == 0 || z == 4;
            for y in 1..4 {
                if edge && !(z == 0 && x == 2 && y < 3) {
                    let b = if y == 2 && (x == 2 || z == 2) { "minecraft:glass_pane" } else { "minecraft:stone" };
                    s.push_str(&format!("{x} {y} {z} {b}\n"));
                }
            }
        }
    }
    s
}

fn induce(dir: &std::path::Path, args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_mdgc"))
        .current_dir(dir)
        .arg("induce")
        .arg("house.txt")
        .args(args)
        .args(["-o", "style.mdg"])
        .output()
        .expect("run mdgc");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{err}");
    err
}

#[test]
fn the_summary_says_what_the_grammar_generates_and_warns_with_codes() {
    let dir = std::env::temp_dir().join(format!("mdg-induce-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::write(dir.join("house.txt"), house()).expect("write");
    // rect: shapes that match, seeds that differ.
    let rect = induce(&dir, &["--spec", "rect", "--alpha", "1", "--cost", "sum", "--ops", "both"]);
    let summary = rect.lines().find(|l| l.starts_with("summary: ")).unwrap_or_else(|| panic!("no summary: {rect}"));
    for part in [" moves, ", " shapes, ", " matches, ", "seeds 1–10", " distinct buildings", " complete "] {
        assert!(summary.contains(part), "{part:?} missing: {summary}");
    }
    assert!(!rect.contains("W0901") && !rect.contains("W0903"), "{rect}");
    // At α = 1 with the sum cost the maximal rectangles are a local optimum: said.
    assert!(rect.contains("warning[W0902]: house.txt: no move made") && rect.contains("--cost kinds"), "{rect}");
    // 3d: one solid shape, nothing matches: refused, saying why and what to use.
    let out = Command::new(env!("CARGO_BIN_EXE_mdgc"))
        .current_dir(&dir)
        .args(["induce", "house.txt", "--spec", "3d", "-o", "solid.mdg"])
        .output()
        .expect("run mdgc");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("none matches another") && err.contains("use --spec rect"), "{err}");
    assert!(!dir.join("solid.mdg").exists(), "nothing written");
    // 2d at α = 0: shapes too mixed to match, every seed the example.
    let planar = induce(&dir, &["--spec", "2d"]);
    assert!(planar.contains("warning[W0901]: no match") && planar.contains("rebuilds the example"), "{planar}");
    assert!(planar.contains("warning[W0903]: seeds give identical outputs"), "{planar}");
    assert!(planar.contains("1 distinct buildings"), "{planar}");
    // Each warning rendered with its code.
    let all = format!("{rect}{planar}");
    for code in ["W0901", "W0902", "W0903"] {
        assert!(all.contains(&format!("warning[{code}]: ")), "{code} not shown: {all}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The Python with nbtlib (`$MDG_NBTLIB_PYTHON`, default
/// `~/.cache/mdg/nbtlib-venv/bin/python`, which `.ci/run` makes).
fn nbtlib_python() -> std::path::PathBuf {
    if let Some(p) = std::env::var_os("MDG_NBTLIB_PYTHON") {
        return p.into();
    }
    let cache = std::env::var_os("XDG_CACHE_HOME")
        .map(std::path::PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| std::path::PathBuf::from(h).join(".cache")))
        .unwrap_or_else(|| ".cache".into());
    cache.join("mdg/nbtlib-venv/bin/python")
}

/// Prints `x y z block[state]` for every non-air block of a structure-block `.nbt` or
/// a Sponge v2 `.schem`, read by nbtlib (a reader that is not ours).
const READ_BACK: &str = r#"
import sys, nbtlib
path = sys.argv[1]
f = nbtlib.load(path)
root = f.get("Schematic", f) if hasattr(f, "get") else f
def state(name, props):
    if props:
        return name + "[" + ",".join(f"{k}={props[k]}" for k in sorted(props)) + "]"
    return name
out = []
if path.endswith(".nbt"):
    pal = [state(str(p["Name"]), {str(k): str(v) for k, v in p.get("Properties", {}).items()}) for p in root["palette"]]
    for b in root["blocks"]:
        x, y, z = (int(c) for c in b["pos"])
        out.append((x, y, z, pal[int(b["state"])]))
else:
    w, h, l = int(root["Width"]), int(root["Height"]), int(root["Length"])
    pal = {int(v): str(k) for k, v in root["Palette"].items()}
    data = [int(b) & 0xFF for b in root["BlockData"]]
    i = n = 0
    while i < len(data):
        v = shift = 0
        while True:
            v |= (data[i] & 0x7F) << shift
            shift += 7
            i += 1
            if data[i - 1] < 0x80:
                break
        x, z, y = n % w, (n // w) % l, n // (w * l)
        n += 1
        out.append((x, y, z, pal[v]))
for x, y, z, s in sorted(out):
    if s not in ("minecraft:air", "minecraft:cave_air", "minecraft:void_air", "minecraft:structure_void"):
        print(x, y, z, s)
"#;

#[test]
fn generated_schem_and_nbt_read_back_by_nbtlib_with_the_same_blocks() {
    if std::env::var("MDG_SKIP_CLIENT_TESTS").is_ok_and(|v| v == "1") {
        eprintln!("SKIPPED: nbtlib read-back (MDG_SKIP_CLIENT_TESTS=1)");
        return;
    }
    let python = nbtlib_python();
    let ok = Command::new(&python).args(["-c", "import nbtlib"]).output().is_ok_and(|o| o.status.success());
    assert!(
        ok,
        "no nbtlib with {}: python3 -m venv ~/.cache/mdg/nbtlib-venv && ~/.cache/mdg/nbtlib-venv/bin/pip install \
         'nbtlib==2.0.4' (as .ci/run does), or set MDG_NBTLIB_PYTHON; MDG_SKIP_CLIENT_TESTS=1 skips",
        python.display()
    );
    let dir = std::env::temp_dir().join(format!("mdg-induce-nbtlib-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    // The house with a porch step of stairs (an oriented block state).
    let mut text = house();
    for x in 0..5 {
        text.push_str(&format!("{x} 0 -1 minecraft:oak_stairs[facing=north,half=bottom,shape=straight]\n"));
    }
    std::fs::write(dir.join("house.txt"), text).expect("write");
    induce(&dir, &[]);
    let run = |out: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_mdg-run"))
            .current_dir(&dir)
            .args(["style.mdg", "--seed", "5", "-o", out])
            .output()
            .expect("run mdg-run");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run("a.txt");
    let model = mdg_grid::format::read(&dir.join("a.txt")).expect("reads").normalized();
    let mut want: Vec<String> = model
        .blocks
        .iter()
        .map(|b| {
            let id = mdg_grid::blocks::to_modern(&model.kinds[b.kind as usize].id).expect("a minecraft name");
            format!("{} {} {} {id}", b.pos[0], b.pos[1], b.pos[2])
        })
        .collect();
    want.sort();
    assert!(want.len() > 50 && want.iter().any(|l| l.contains("oak_stairs[")), "a house with its stairs: {want:?}");
    for f in ["a.nbt", "a.schem"] {
        run(f);
        let o = Command::new(&python).arg("-c").arg(READ_BACK).arg(dir.join(f)).output().expect("run python");
        assert!(o.status.success(), "{f}: {}", String::from_utf8_lossy(&o.stderr));
        let mut got: Vec<String> = String::from_utf8_lossy(&o.stdout).lines().map(str::to_string).collect();
        got.sort();
        assert_eq!(got, want, "{f}: nbtlib reads other blocks than mdg-run generated");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn summary_seeds_sets_the_seeds_measured_and_zero_skips_them() {
    let dir = std::env::temp_dir().join(format!("mdg-induce-summary-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::write(dir.join("house.txt"), house()).expect("write");
    let three = induce(&dir, &["--summary-seeds", "3"]);
    assert!(three.contains("seeds 1–3 "), "{three}");
    let none = induce(&dir, &["--summary-seeds", "0"]);
    let summary = none.lines().find(|l| l.starts_with("summary: ")).unwrap_or_else(|| panic!("no summary: {none}"));
    assert!(summary.contains("no seeds generated (--summary-seeds 0)") && !summary.contains("distinct"), "{summary}");
    assert!(dir.join("style.mdg").exists());
    let out = Command::new(env!("CARGO_BIN_EXE_mdgc"))
        .current_dir(&dir)
        .args(["induce", "house.txt", "--summary-seeds", "1001", "-o", "x.mdg"])
        .output()
        .expect("run mdgc");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--summary-seeds 1001: at most 1000"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// An example that cannot be read (missing, an unknown extension) is a usage or IO
/// error (exit 2); one that is read and refused, an error in the input (exit 1).
#[test]
fn unreadable_examples_exit_2_and_refused_ones_exit_1() {
    let dir = std::env::temp_dir().join(format!("mdg-induce-status-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    std::fs::write(dir.join("bad.txt"), "0 0 x stone\n").expect("write");
    std::fs::write(dir.join("house.schematic"), "0 0 0 stone\n").expect("write");
    for (example, status, says) in [
        ("missing.txt", 2, "cannot read missing.txt"),
        ("house.schematic", 2, "house.schematic: unknown voxel format"),
        ("bad.txt", 1, "bad.txt: line 1: `x` is not an integer z coordinate"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_mdgc"))
            .current_dir(&dir)
            .args(["induce", example, "-o", "out.mdg"])
            .output()
            .expect("run mdgc");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(status), "{example}: {err}");
        assert!(err.contains(says), "{example}: {err}");
        assert!(!dir.join("out.mdg").exists(), "{example}: nothing written");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
