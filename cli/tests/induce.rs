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
    // 3d: one solid shape, nothing matches, every seed the example.
    let solid = induce(&dir, &["--spec", "3d"]);
    assert!(solid.contains("warning[W0901]: no match") && solid.contains("rebuilds the example"), "{solid}");
    assert!(solid.contains("warning[W0903]: seeds give identical outputs"), "{solid}");
    assert!(solid.contains("1 distinct buildings"), "{solid}");
    let _ = std::fs::remove_dir_all(&dir);
}
