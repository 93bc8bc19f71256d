//! A newcomer's mistakes are errors, not silent successes (issue 36): an output
//! extension no writer makes, a `--param`/`--preset` the grammar does not declare, a
//! mistyped flag, a formatter message without the file's name, and std when `HOME`
//! cannot be written.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mdg-newcomer-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn run(bin: &str, dir: &Path, args: &[&str]) -> Output {
    Command::new(bin).current_dir(dir).args(args).output().expect("run the command")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

const MDG_RUN: &str = env!("CARGO_BIN_EXE_mdg-run");
const MDGC: &str = env!("CARGO_BIN_EXE_mdgc");
const MDG_VIEW: &str = env!("CARGO_BIN_EXE_mdg-view");

/// A small mesh grammar with a parameter and presets.
const GRAMMAR: &str = "startshape a\n@presets small large\n@param int count 3 1 10\n\
    rule a { (count) * {x 1} VERTEX {} VERTEX {x 0.5} VERTEX {y 0.5} }\n";

fn grammar(dir: &Path) -> PathBuf {
    let p = dir.join("g.mdg");
    std::fs::write(&p, GRAMMAR).expect("write grammar");
    p
}

#[test]
fn output_png_writes_the_picture() {
    let dir = temp_dir("png");
    grammar(&dir);
    let o = run(MDG_RUN, &dir, &["g.mdg", "-o", "picture.png", "--size", "64x48"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(dir.join("picture.png")).expect("picture written");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "a PNG, not GLB bytes");
    assert!(!dir.join("g.glb").exists(), "no model is written beside it");
    // Together with --png it is a usage error (two pictures, no model).
    let o = run(MDG_RUN, &dir, &["g.mdg", "-o", "a.png", "--png", "b.png"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--png"), "{}", stderr(&o));
}

#[test]
fn an_extension_no_writer_makes_is_an_error_listing_the_formats() {
    let dir = temp_dir("ext");
    grammar(&dir);
    for name in ["x.gltf", "x.fbx", "x.GLTF", "model.blend"] {
        let o = run(MDG_RUN, &dir, &["g.mdg", "-o", name]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{name}: {e}");
        assert!(e.contains(name) && e.contains(".glb") && e.contains(".obj") && e.contains(".json"), "{name}: {e}");
        assert!(!dir.join(name).exists(), "{name} must not be written");
    }
    let e = stderr(&run(MDG_RUN, &dir, &["g.mdg", "-o", "x.gltf"]));
    assert!(e.contains("binary glTF"), "a .gltf gets a hint: {e}");
    // Voxel formats are for grid grammars.
    for name in ["x.vox", "x.schem", "x.nbt", "x.txt"] {
        let o = run(MDG_RUN, &dir, &["g.mdg", "-o", name]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{name}: {e}");
        assert!(e.contains("grid grammar"), "{name}: {e}");
        assert!(!dir.join(name).exists(), "{name} must not be written");
    }
    // --format against the extension.
    let o = run(MDG_RUN, &dir, &["g.mdg", "--format", "obj", "-o", "x.glb"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--format obj") && stderr(&o).contains("x.glb"), "{}", stderr(&o));
    assert!(!dir.join("x.glb").exists());
    // What still works: a known extension, --format with a matching or no extension.
    for args in
        [&["g.mdg", "-o", "ok.obj"][..], &["g.mdg", "--format", "ply", "-o", "ok.ply"], &["g.mdg", "--format", "stl"]]
    {
        let o = run(MDG_RUN, &dir, args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    }
    assert!(dir.join("ok.obj").is_file() && dir.join("ok.ply").is_file() && dir.join("g.stl").is_file());
    // A batch template is checked the same way.
    let o = run(MDG_RUN, &dir, &["g.mdg", "--seeds", "0..2", "-o", "out/{seed}.fbx"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains(".glb"), "{}", stderr(&o));
}

#[test]
fn an_undeclared_param_or_preset_is_an_error_with_a_suggestion() {
    let dir = temp_dir("param");
    grammar(&dir);
    let cases: [(&str, &[&str]); 4] = [
        (MDG_RUN, &["g.mdg", "--param", "cont=5"]),
        (MDGC, &["check", "--param", "cont=5", "g.mdg"]),
        (MDGC, &["build", "--param", "cont=5", "g.mdg"]),
        (MDG_VIEW, &["g.mdg", "--param", "cont=5", "--png", "v.png", "--size", "32x32"]),
    ];
    for (bin, args) in cases {
        let o = run(bin, &dir, args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{bin} {args:?}: {e}");
        assert!(e.contains("--param cont=5") && e.contains("did you mean `count`"), "{bin} {args:?}: {e}");
    }
    let o = run(MDG_RUN, &dir, &["g.mdg", "--preset", "smal"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--preset smal") && stderr(&o).contains("did you mean `small`"), "{}", stderr(&o));
    // Far from every name: the message lists what the grammar declares.
    let o = run(MDG_RUN, &dir, &["g.mdg", "--param", "zzzzzz=1"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("count"), "{}", stderr(&o));
    // Declared names still work, and a preset tested only by `@ifdef` counts as used.
    std::fs::write(dir.join("h.mdg"), "startshape a\n@ifdef DETAILED\nrule a { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n@else\nrule a { VERTEX {} VERTEX {x 1} VERTEX {y 2} }\n@endif\n").expect("write");
    for args in [&["g.mdg", "--param", "count=5", "--preset", "large"][..], &["h.mdg", "--preset", "DETAILED"]] {
        let o = run(MDG_RUN, &dir, args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    }
}

#[test]
fn a_mistyped_colour_flag_gets_a_helpful_answer() {
    let dir = temp_dir("colour");
    grammar(&dir);
    let o = run(MDG_RUN, &dir, &["g.mdg", "--colour", "red"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(!e.contains("--no-enclosure"), "no suggestion of an unrelated flag: {e}");
    assert!(e.contains("@param") || e.contains("--param"), "the answer says how colours are chosen: {e}");
}

#[test]
fn fmt_names_the_file_in_its_diagnostics() {
    let dir = temp_dir("fmt");
    std::fs::write(dir.join("broken.mdg"), "startshape a\nrule a { VERTEX {x 1 }\n").expect("write");
    let o = run(MDGC, &dir, &["fmt", "broken.mdg"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("broken.mdg:2:"), "the diagnostic points into the file: {e}");
    assert!(!e.contains("<input>"), "{e}");
}

/// An installed binary (no std checkout above it, no `$MDG_STD`) with a `HOME` that
/// cannot be created still finds the built-in std.
#[test]
fn std_is_found_when_home_cannot_be_written() {
    let dir = temp_dir("home");
    // Out of the checkout, so std is not found beside the executable.
    let bin = dir.join("bin/mdg-run");
    std::fs::create_dir_all(bin.parent().expect("parent")).expect("bin dir");
    std::fs::copy(MDG_RUN, &bin).expect("copy the binary");
    let file = dir.join("a-file");
    std::fs::write(&file, "not a directory").expect("write");
    let home = file.join("home");
    let work = dir.join("work");
    std::fs::create_dir_all(&work).expect("work dir");
    std::fs::write(work.join("c.mdg"), "@import primitives\nstartshape a\nrule a { cube {} }\n").expect("write");
    let o = Command::new(&bin)
        .current_dir(&work)
        .env_remove("MDG_STD")
        .env_remove("XDG_CACHE_HOME")
        .env("HOME", &home)
        .env("TMPDIR", &home)
        .args(["c.mdg", "-o", "c.obj"])
        .output()
        .expect("run");
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(!e.contains("not found") && !e.contains("add `@import"), "{e}");
    assert!(work.join("c.obj").is_file());
}

fn std_example(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../std/examples").join(name).display().to_string()
}

/// Creature evolution writes a folder; `--png` is its last contact sheet (it used to
/// be ignored without a word).
#[test]
fn creature_evolution_writes_the_png_it_is_asked_for() {
    let dir = temp_dir("creature");
    let src = std_example("monsters.mdg");
    let o = run(MDG_RUN, &dir, &[&src, "--generations", "1", "--population", "2", "-o", "out", "--png", "sheet.png"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(dir.join("sheet.png")).expect("the picture is written");
    assert_eq!(bytes, std::fs::read(dir.join("out/gen1/sheet.png")).expect("the last sheet"));
}

/// A grid grammar takes its format from -o's extension; a --format that disagrees
/// is an error, one that agrees (or names the default output) is followed.
#[test]
fn a_grid_grammars_format_flag_must_agree() {
    let dir = temp_dir("gridfmt");
    let src = std_example("grid_cottage.mdg");
    let o = run(MDG_RUN, &dir, &[&src, "--format", "obj", "-o", "x.vox"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--format obj") && stderr(&o).contains("x.vox"), "{}", stderr(&o));
    let o = run(MDG_RUN, &dir, &[&src, "--format", "obj"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("grid_cottage.obj").is_file(), "--format names the default output's format");
}

/// A compiled bundle cannot take `--param`/`--preset` (they change how source
/// compiles); they were ignored.
#[test]
fn a_bundle_refuses_param_and_preset() {
    let dir = temp_dir("bundle");
    grammar(&dir);
    let o = run(MDGC, &dir, &["build", "g.mdg", "-o", "g.mdgb"]);
    assert!(o.status.success(), "{}", stderr(&o));
    for (bin, args) in [
        (MDG_RUN, &["g.mdgb", "--param", "count=4"][..]),
        (MDG_RUN, &["g.mdgb", "--preset", "small"]),
        (MDG_VIEW, &["g.mdgb", "--param", "count=4", "--png", "v.png", "--size", "32x32"]),
    ] {
        let o = run(bin, &dir, args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(e.contains("compiled bundle") && e.contains(args[2]), "{args:?}: {e}");
    }
    let o = run(MDG_RUN, &dir, &["g.mdgb"]);
    assert!(o.status.success(), "{}", stderr(&o));
}
