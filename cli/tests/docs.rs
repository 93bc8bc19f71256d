//! The documents a newcomer reads first cannot rot (issue 36):
//!
//! - `docs/tutorial.md`: every grammar compiles without errors, is laid out as
//!   `mdgc fmt` lays it out and evaluates to geometry; every command runs (in a
//!   temporary folder, with the built commands on `PATH`) and succeeds; every
//!   picture the page shows is made by those commands and matches the committed one
//!   (within a tolerance; skipped with a note where only the software renderer is
//!   available).
//! - `README.md`: every command line of its `sh` blocks is accounted for below:
//!   most run for real the same way; the ones that open a window, take minutes or
//!   install things are checked instead (every path exists, every flag is in the
//!   command's `--help`).
//! - `docs/gallery.md`: lists every std example with its purpose (the first sentence
//!   of its leading comment) and the hash of the source its picture was drawn from;
//!   a changed example makes this test fail until the gallery is regenerated.
//!
//! Regenerate the tutorial's and the gallery's pictures and the gallery page with
//! `UPDATE_DOCS=1 cargo test -p mdg-cli --test docs` (the gallery redraws only the
//! examples whose source changed; `UPDATE_DOCS=all` redraws every one).

use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mdg-docs-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn update() -> Option<String> {
    std::env::var("UPDATE_DOCS").ok().filter(|v| !v.is_empty() && v != "0")
}

/// The fenced blocks of a Markdown text: (language, text), in order.
fn blocks(md: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut cur: Option<(String, String)> = None;
    for line in md.lines() {
        match (&mut cur, line.strip_prefix("```")) {
            (None, Some(lang)) => cur = Some((lang.trim().to_string(), String::new())),
            (Some(_), Some(_)) => out.extend(cur.take()),
            (Some((_, text)), None) => {
                text.push_str(line);
                text.push('\n');
            }
            (None, None) => {}
        }
    }
    assert!(cur.is_none(), "an unclosed code block");
    out
}

/// A folder holding the built commands under their installed names.
fn bin_dir() -> PathBuf {
    let dir = temp_dir("bin");
    for (name, path) in [
        ("mdg-run", env!("CARGO_BIN_EXE_mdg-run")),
        ("mdgc", env!("CARGO_BIN_EXE_mdgc")),
        ("mdg-view", env!("CARGO_BIN_EXE_mdg-view")),
    ] {
        std::os::unix::fs::symlink(path, dir.join(name)).expect("link the command");
    }
    dir
}

/// Runs `script` with bash (`-e`: the first failing command fails it) in `dir`,
/// with the built commands first on `PATH`.
fn bash(bin: &Path, dir: &Path, script: &str) -> Output {
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap_or_default());
    Command::new("bash")
        .args(["-e", "-c", script])
        .current_dir(dir)
        .env("PATH", path)
        .env_remove("MDG_STD")
        .output()
        .expect("run bash")
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// Whether the pictures of this run came from the software renderer (no Vulkan
/// here): they differ from the committed Vulkan ones.
fn software_pictures(out: &str) -> bool {
    out.contains("software renderer")
}

/// RGBA pixels and size of a PNG.
fn decode(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
    let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
    dec.set_transformations(png::Transformations::EXPAND | png::Transformations::ALPHA);
    let mut reader = dec.read_info().expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("decode");
    buf.truncate(info.buffer_size());
    let rgba = match info.color_type {
        png::ColorType::Rgba => buf,
        png::ColorType::Rgb => buf.chunks(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect(),
        other => panic!("unexpected PNG colour type {other:?}"),
    };
    (info.width, info.height, rgba)
}

/// Mean absolute difference of two pictures' RGB values (0–255), or why they
/// cannot be compared.
fn picture_difference(a: &[u8], b: &[u8]) -> Result<f64, String> {
    let (wa, ha, pa) = decode(a);
    let (wb, hb, pb) = decode(b);
    if (wa, ha) != (wb, hb) {
        return Err(format!("sizes differ: {wa}x{ha} and {wb}x{hb}"));
    }
    let sum: u64 =
        pa.chunks(4).zip(pb.chunks(4)).map(|(p, q)| (0..3).map(|k| u64::from(p[k].abs_diff(q[k]))).sum::<u64>()).sum();
    Ok(sum as f64 / (f64::from(wa) * f64::from(ha) * 3.0))
}

/// The committed pictures are small.
const MAX_PICTURE_BYTES: u64 = 100 * 1024;

/// How far a re-drawn picture may be from the committed one (mean absolute
/// difference of the RGB values, 0–255): another Mesa version moves edges by a pixel.
const PICTURE_TOLERANCE: f64 = 3.0;

// ---------------------------------------------------------------- the tutorial

/// The file a tutorial grammar is saved as: its first line is `// NAME.mdg: …`.
fn grammar_file(block: &str) -> String {
    let first = block.lines().next().unwrap_or_default();
    let name = first.strip_prefix("// ").and_then(|l| l.split(':').next()).unwrap_or_default();
    assert!(name.ends_with(".mdg"), "a tutorial grammar starts with `// NAME.mdg: …`, not {first:?}");
    name.to_string()
}

/// The pictures a page shows from `prefix` (`img/tutorial/`): their file names.
fn pictures(md: &str, prefix: &str) -> Vec<String> {
    let mut out = Vec::new();
    for part in md.split(&format!("]({prefix}")).skip(1) {
        let name = part.split(')').next().unwrap_or_default();
        out.push(name.to_string());
    }
    out
}

#[test]
fn the_tutorial_runs_and_its_pictures_are_current() {
    let md = std::fs::read_to_string(root().join("docs/tutorial.md")).expect("docs/tutorial.md");
    let bin = bin_dir();
    let work = temp_dir("tutorial");
    let (mut grammars, mut commands, mut software) = (0, 0, false);
    for (lang, block) in blocks(&md) {
        match lang.as_str() {
            "mdg" => {
                let name = grammar_file(&block);
                let path = work.join(&name);
                std::fs::write(&path, &block).expect("write the step");
                // Laid out as the formatter lays it out.
                let formatted = mdg_compiler::fmt::format_source(&block).expect("formats");
                assert_eq!(formatted, block, "{name} is not laid out as `mdgc fmt` would");
                // No errors or warnings, and geometry.
                let opts = mdg_compiler::expand::Options {
                    std_dir: mdg_compiler::driver::default_std_dir(),
                    ..Default::default()
                };
                let (bundle, a) = match mdg_compiler::driver::build(&mdg_compiler::source::FsLoader, &path, &opts) {
                    Ok(b) => b,
                    Err(a) => panic!("{name}:\n{}", mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources)),
                };
                assert!(
                    a.diagnostics.is_empty(),
                    "{name}:\n{}",
                    mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources)
                );
                let out = mdg_vm::eval::evaluate(&bundle, &mdg_vm::eval::EvalOptions::default());
                let (vertices, triangles) = out.flat_counts(mdg_vm::output::Groups::ALL);
                assert!(vertices > 0 && triangles > 0, "{name} draws nothing");
                grammars += 1;
            }
            "sh" => {
                let o = bash(&bin, &work, &block);
                let said = text(&o);
                assert!(o.status.success(), "the tutorial's commands failed:\n{block}\n{said}");
                software |= software_pictures(&said);
                commands += block.lines().filter(|l| !l.trim().is_empty()).count();
            }
            other => panic!("a `{other}` block in the tutorial: only mdg and sh blocks are checked"),
        }
    }
    assert!(grammars >= 9 && commands >= 15, "{grammars} grammars, {commands} commands");
    let shown = pictures(&md, "img/tutorial/");
    assert!(shown.len() >= 10, "{shown:?}");
    let dir = root().join("docs/img/tutorial");
    let mut far = Vec::new();
    for name in &shown {
        let made = std::fs::read(work.join(name)).unwrap_or_else(|_| panic!("no command of the tutorial makes {name}"));
        let committed = dir.join(name);
        if update().is_some() {
            assert!(!software, "UPDATE_DOCS needs Vulkan (lavapipe): these pictures came from the software renderer");
            std::fs::write(&committed, &made).expect("write the picture");
            continue;
        }
        let bytes = std::fs::read(&committed).unwrap_or_else(|_| panic!("{} is missing", committed.display()));
        assert!(bytes.len() as u64 <= MAX_PICTURE_BYTES, "{name}: {} bytes", bytes.len());
        if software {
            continue;
        }
        match picture_difference(&made, &bytes) {
            Ok(d) if d <= PICTURE_TOLERANCE => {}
            Ok(d) => far.push(format!("{name}: mean difference {d:.2}")),
            Err(e) => far.push(format!("{name}: {e}")),
        }
    }
    if software {
        eprintln!(
            "note: no Vulkan here, so the tutorial's pictures were drawn by the software renderer and not compared"
        );
    }
    assert!(
        far.is_empty(),
        "pictures out of date (regenerate: UPDATE_DOCS=1 cargo test -p mdg-cli --test docs):\n{}",
        far.join("\n")
    );
    // Nothing unused in the picture folder.
    for e in std::fs::read_dir(&dir).expect("picture folder").flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        assert!(shown.contains(&n), "docs/img/tutorial/{n} is not shown by the tutorial");
    }
    let _ = std::fs::remove_dir_all(&work);
}

// ---------------------------------------------------------------- the README

/// How the test treats one README command line.
#[derive(Clone, Copy, Debug, PartialEq)]
enum How {
    /// Run for real in a temporary folder (`std/` linked there); must succeed.
    Run,
    /// Not run (a window, minutes of work, an installation, a usage summary):
    /// every path exists and every flag is in the command's `--help`.
    Check,
}

/// Every command line of the README's `sh` blocks (comments and blank lines
/// dropped, continuation lines joined) and how it is tested. A line not listed
/// fails the test: decide how to test it when you add it.
const README_LINES: &[(&str, How)] = &[
    ("cargo run --release --bin mdg-run -- std/examples/tree.mdg -o tree.glb --png tree.png", How::Run),
    ("bash .ci/run", How::Check),
    ("cargo install --locked --path cli && cargo install --locked --path lsp", How::Check),
    ("cd ~ && mdg-run --help", How::Run),
    ("cargo run --release --bin mdg-view -- std/examples/torus_knot.mdg", How::Check),
    ("cargo run --release --bin mdg-view -- std/examples/tree.mdg --png tree.png", How::Run),
    (
        "mdg-run std/examples/guided_tree.mdg --guides std/examples/guides/arch.json --stats --png tree.png",
        How::Run,
    ),
    ("mdg-view std/examples/guided_tree.mdg", How::Check),
    ("mdg-run std/examples/monsters.mdg --generations 5 --population 18 --seed 3 -o out/", How::Check),
    ("mdg-run std/examples/grid_cottage.mdg --seed 1 -o house1.vox", How::Run),
    ("mdg-run std/examples/grid_cottage.mdg --seed 2 -o house2.schem", How::Run),
    ("mdgc induce house1.vox house2.schem --spec rect --alpha 1 --ops both -o style.mdg", How::Run),
    ("mdg-run style.mdg --steps 50 --enclosure --seed 7 -o house.vox --png house.png", How::Run),
    ("mdg-run FILE.mdg|FILE.mdgb [-o OUT] [--format glb|obj|stl|ply|json|none] [--instances] [--seed N] [--param NAME=V]… [--preset P]… [--png PIC.png --size WxH] [--samples auto|N] [--renderer auto|cpu|vulkan] [--camera AZ,EL[,ZOOM]] [--frames DIR] [--stats] [--max-vertices N] [--time-budget TIME] [--time T] [--max-iter N] [--max-stack N] [--seeds A..B -o 'out/{seed}.glb' [--shard K/N] [-j N]]", How::Check),
    ("mdgc check FILE…", How::Check),
    ("mdgc check --message-format json FILE", How::Check),
    ("mdgc check --program FILE", How::Check),
    ("mdgc fmt [--check] FILE…", How::Check),
    ("mdgc build FILE.mdg [-o FILE.mdgb]", How::Check),
    ("mdgc disasm FILE.mdgb|FILE.mdg", How::Check),
    ("mdgc explain E0301", How::Run),
    ("mdg-run first.mdg --png first.png", How::Run),
];

/// The command lines of the `sh` blocks: comments dropped, `\`-continued and
/// indented continuation lines joined.
fn command_lines(block: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut joining = false;
    for raw in block.lines() {
        let line = match raw.find(" #").or(raw.trim_start().starts_with('#').then_some(0)) {
            Some(i) => &raw[..i],
            None => raw,
        };
        let line = line.trim_end();
        let continued = line.ends_with('\\');
        let line = line.trim_end_matches('\\').trim();
        if line.is_empty() {
            joining = false;
            continue;
        }
        // A synopsis continues on lines indented under it.
        let indented = raw.starts_with("  ") && !out.is_empty();
        match out.last_mut() {
            Some(last) if joining || indented => {
                last.push(' ');
                last.push_str(line);
            }
            _ => out.push(line.to_string()),
        }
        joining = continued;
    }
    out
}

/// The `--flags` a line uses, for the command they belong to.
fn flags(words: &[&str]) -> Vec<String> {
    words
        .iter()
        .filter(|w| w.starts_with("--") || w.starts_with("[--"))
        .map(|w| {
            let w = w.trim_start_matches('[');
            w.split(['=', ']', '…']).next().unwrap_or_default().to_string()
        })
        .filter(|w| w.len() > 2)
        .collect()
}

/// Checks a line that is not run: every path it names exists, every flag is in its
/// command's `--help`.
fn check_line(line: &str) -> Result<(), String> {
    let root = root();
    for part in line.split("&&") {
        let words: Vec<&str> = part.split_whitespace().collect();
        let (help, args): (Vec<&str>, &[&str]) = match words.as_slice() {
            ["cargo", "run", rest @ ..] => {
                let at = rest.iter().position(|w| *w == "--").ok_or(format!("{line}: no `--`"))?;
                let bin = rest.iter().skip_while(|w| **w != "--bin").nth(1).ok_or(format!("{line}: no --bin"))?;
                (vec![*bin], &rest[at + 1..])
            }
            ["cargo", "install", rest @ ..] => {
                for (i, w) in rest.iter().enumerate() {
                    if *w == "--path" {
                        let p = rest.get(i + 1).ok_or(format!("{line}: --path without a folder"))?;
                        if !root.join(p).join("Cargo.toml").is_file() {
                            return Err(format!("{line}: {p} is not a crate"));
                        }
                    }
                }
                (vec!["cargo", "install"], rest)
            }
            ["bash", script, ..] => {
                if !root.join(script).is_file() {
                    return Err(format!("{line}: {script} does not exist"));
                }
                continue;
            }
            ["mdgc", sub, rest @ ..] => (vec!["mdgc", sub], rest),
            [cmd @ ("mdg-run" | "mdg-view"), rest @ ..] => (vec![*cmd], rest),
            _ => return Err(format!("{line}: not a command this test knows")),
        };
        for w in args {
            if w.starts_with("std/") && !root.join(w).exists() {
                return Err(format!("{line}: {w} does not exist"));
            }
        }
        let help_text = match help.as_slice() {
            ["cargo", sub] => text(&Command::new("cargo").args([sub, "--help"]).output().expect("cargo --help")),
            ["mdgc", sub] => {
                text(&Command::new(env!("CARGO_BIN_EXE_mdgc")).args([sub, "--help"]).output().expect("help"))
            }
            ["mdg-run"] => text(&Command::new(env!("CARGO_BIN_EXE_mdg-run")).arg("--help").output().expect("help")),
            ["mdg-view"] => text(&Command::new(env!("CARGO_BIN_EXE_mdg-view")).arg("--help").output().expect("help")),
            other => return Err(format!("{line}: no help for {other:?}")),
        };
        for f in flags(args) {
            if !help_text.contains(&format!("{f} "))
                && !help_text.contains(&format!("{f}\n"))
                && !help_text.contains(&format!("{f},"))
                && !help_text.contains(&format!("{f}="))
                && !help_text.contains(&format!("{f} <"))
            {
                return Err(format!("{line}: {f} is not in `{} --help`", help.join(" ")));
            }
        }
    }
    Ok(())
}

#[test]
fn every_readme_command_is_run_or_checked() {
    let md = std::fs::read_to_string(root().join("README.md")).expect("README.md");
    let bin = bin_dir();
    let work = temp_dir("readme");
    std::os::unix::fs::symlink(root().join("std"), work.join("std")).expect("link std");
    // The README's first grammar, which a later line runs.
    let mut seen = Vec::new();
    for (lang, block) in blocks(&md) {
        if lang == "mdg" {
            std::fs::write(work.join("first.mdg"), &block).expect("write");
            continue;
        }
        if lang != "sh" {
            continue;
        }
        for line in command_lines(&block) {
            let how = README_LINES
                .iter()
                .find(|(l, _)| *l == line)
                .map(|(_, h)| *h)
                .unwrap_or_else(|| panic!("README line not accounted for in cli/tests/docs.rs: {line}"));
            seen.push(line.clone());
            // Without Vulkan (MDG_SKIP_VULKAN_TESTS=1, as the viewer tests), the viewer's
            // offscreen picture is checked instead of run.
            let skip_vulkan = std::env::var("MDG_SKIP_VULKAN_TESTS").as_deref() == Ok("1");
            let how = if skip_vulkan && line.contains("mdg-view") { How::Check } else { how };
            match how {
                How::Run => {
                    // `cargo run [--release] --bin X -- ARGS` runs the built X; `cd ~`
                    // stays in the temporary folder (an installed command works anywhere).
                    let script = match line.strip_prefix("cargo run --release --bin ") {
                        Some(rest) => rest.replacen(" --", "", 1),
                        None => line.replace("cd ~ && ", ""),
                    };
                    let o = bash(&bin, &work, &script);
                    assert!(o.status.success(), "README: `{line}` failed:\n{}", text(&o));
                }
                How::Check => {
                    if let Err(e) = check_line(&line) {
                        panic!("README: {e}");
                    }
                }
            }
        }
    }
    for (l, _) in README_LINES {
        assert!(seen.iter().any(|s| s == l), "cli/tests/docs.rs lists a line the README no longer has: {l}");
    }
    // What the runs made.
    for f in ["tree.glb", "tree.png", "house.vox", "house.png", "style.mdg", "first.png"] {
        assert!(work.join(f).is_file(), "{f} was not written");
    }
    let _ = std::fs::remove_dir_all(&work);
}

// ---------------------------------------------------------------- the gallery

/// The first sentence of the leading `//` comment of an example.
fn purpose(source: &str) -> String {
    let mut comment = String::new();
    for line in source.lines() {
        let Some(t) = line.strip_prefix("//") else { break };
        let t = t.trim();
        if t.is_empty() {
            break;
        }
        if !comment.is_empty() {
            comment.push(' ');
        }
        comment.push_str(t);
    }
    let end = comment.match_indices(". ").map(|(i, _)| i + 1).next().unwrap_or(comment.len());
    let sentence = comment[..end].trim();
    // A long first sentence is cut to its head, before the first colon.
    match sentence.split_once(": ") {
        Some((head, _)) if sentence.chars().count() > MAX_PURPOSE_CHARS => format!("{head}."),
        _ => sentence.to_string(),
    }
}

/// The longest purpose shown whole.
const MAX_PURPOSE_CHARS: usize = 150;

fn short_hash(bytes: &[u8]) -> String {
    Sha256::digest(bytes).iter().take(8).map(|b| format!("{b:02x}")).collect()
}

/// The examples: (name, source).
fn examples() -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = std::fs::read_dir(root().join("std/examples"))
        .expect("std/examples")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "mdg"))
        .map(|p| {
            let name = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            (name, std::fs::read_to_string(&p).expect("read example"))
        })
        .collect();
    v.sort();
    v
}

/// The gallery page for these examples.
fn gallery_page(examples: &[(String, String)]) -> String {
    let mut md = String::from(
        "# Gallery: the std examples\n\n\
         Every grammar in `std/examples/`, drawn by `mdg-run std/examples/NAME.mdg --png NAME.png --size 320x240`\n\
         (Vulkan offscreen, lavapipe), with the first sentence of its leading comment (a long one\n\
         up to its colon). Run one\n\
         from the checkout (`mdg-run std/examples/tree.mdg`), open it in the viewer (`mdg-view\n\
         std/examples/tree.mdg`), or read it for the technique it shows. Creature evolution\n\
         (`monsters.mdg`) is shown by the contact sheet of a small run (`--generations 1\n\
         --population 3`: `--png` writes the last generation's sheet); the grid grammar\n\
         (`grid_cottage.mdg`) by one generated building.\n\n\
         This page is generated: `UPDATE_DOCS=1 cargo test -p mdg-cli --test docs` redraws the\n\
         pictures of the examples that changed and rewrites it; `cli/tests/docs.rs` fails while\n\
         it is out of date (each row records the hash of the source its picture was drawn from).\n\n\
         | picture | example |\n|---|---|\n",
    );
    for (name, source) in examples {
        md.push_str(&format!(
            "| ![{name}](img/gallery/{name}.png) | [`{name}.mdg`](../std/examples/{name}.mdg): {} <!-- source {} --> |\n",
            purpose(source).replace('|', "\\|"),
            short_hash(source.as_bytes())
        ));
    }
    md
}

/// Draws the gallery picture of one example into docs/img/gallery.
fn draw_example(bin: &Path, work: &Path, name: &str) {
    let src = root().join("std/examples").join(format!("{name}.mdg"));
    let png = root().join("docs/img/gallery").join(format!("{name}.png"));
    let out = match name {
        "monsters" => "-o monsters --generations 1 --population 3".to_string(),
        "grid_cottage" => "-o grid_cottage.vox".to_string(),
        _ => format!("-o {name}.glb"),
    };
    let script = format!("mdg-run '{}' {out} --png '{}' --size 320x240", src.display(), png.display());
    let o = bash(bin, work, &script);
    let said = text(&o);
    assert!(o.status.success(), "{script}:\n{said}");
    assert!(!software_pictures(&said), "the gallery needs Vulkan (lavapipe): {said}");
}

#[test]
fn the_gallery_lists_every_example_and_is_current() {
    let examples = examples();
    assert!(examples.len() >= 20, "{} examples", examples.len());
    let path = root().join("docs/gallery.md");
    let want = gallery_page(&examples);
    let have = std::fs::read_to_string(&path).unwrap_or_default();
    if let Some(mode) = update() {
        let bin = bin_dir();
        let work = temp_dir("gallery");
        std::fs::create_dir_all(root().join("docs/img/gallery")).expect("picture folder");
        for (name, source) in &examples {
            let current = have.contains(&format!("<!-- source {} -->", short_hash(source.as_bytes())))
                && root().join(format!("docs/img/gallery/{name}.png")).is_file();
            if mode == "all" || !current {
                draw_example(&bin, &work, name);
            }
        }
        std::fs::write(&path, &want).expect("write docs/gallery.md");
    } else {
        assert!(
            have == want,
            "docs/gallery.md is out of date (an example was added, removed or changed): \
             regenerate it with `UPDATE_DOCS=1 cargo test -p mdg-cli --test docs`"
        );
    }
    for (name, _) in &examples {
        let png = root().join(format!("docs/img/gallery/{name}.png"));
        let len = std::fs::metadata(&png).map(|m| m.len()).unwrap_or_else(|_| panic!("{} is missing", png.display()));
        assert!(len <= MAX_PICTURE_BYTES, "{}: {len} bytes", png.display());
        assert!(
            !purpose(&examples.iter().find(|e| &e.0 == name).expect("example").1).is_empty(),
            "{name}: no leading comment"
        );
    }
}

#[test]
fn command_lines_join_continuations_and_drop_comments() {
    let block =
        "# a comment\nmdg-run a.mdg   # trailing\nmdg-run FILE [-o OUT]\n        [--seed N]\n\nmdgc x \\\n  --y\n";
    assert_eq!(command_lines(block), ["mdg-run a.mdg", "mdg-run FILE [-o OUT] [--seed N]", "mdgc x --y"]);
    assert_eq!(purpose("// One. Two.\n// Three\n"), "One.");
    assert_eq!(
        purpose("// A knot (thesis §5.4): a tube\n// traced by motions. More\n"),
        "A knot (thesis §5.4): a tube traced by motions."
    );
    // What a checked line must satisfy.
    assert!(check_line("mdg-run std/examples/tree.mdg --stats").is_ok());
    assert!(check_line("mdg-run std/examples/tree.mdg --no-such-flag").is_err());
    assert!(check_line("mdg-view std/examples/no_such_example.mdg").is_err());
    assert!(check_line("mdgc check --no-such-flag FILE").is_err());
    assert!(check_line("cargo install --locked --path no-such-crate").is_err());
    assert!(check_line("cargo install --no-such-cargo-flag --path cli").is_err());
    assert!(check_line("bash .ci/no-such-script").is_err());
    let long = format!("// A head: {}.\n", "word ".repeat(40));
    assert_eq!(purpose(&long), "A head.");
}
