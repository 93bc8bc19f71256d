//! Careless input (issue 25): files in another encoding or with a byte-order mark,
//! numbers beyond the floats, directive values that overflow, geometry that
//! overflows at run time, and megabyte lines in diagnostics. Each gets a clear
//! message, never silence and never a megabyte of output.

use mdg_compiler::check::CheckOptions;
use mdg_compiler::diag::{render_plain, MAX_SHOWN_LINE};
use mdg_compiler::driver::{analyze, analyze_text, Analysis};
use mdg_compiler::expand::Options;
use mdg_compiler::source::{decode_source, FsLoader, MemLoader};
use mdg_tests::{root, run_source};
use std::path::Path;

fn analyze_mem(text: &str) -> Analysis {
    analyze_text(
        &MemLoader::default(),
        Path::new("/careless/main.mdg"),
        text,
        &Options::default(),
        CheckOptions { require_start: true },
    )
}

fn codes(a: &Analysis) -> Vec<&'static str> {
    a.diagnostics.iter().map(|d| d.code).collect()
}

/// A scratch directory under the target directory, fresh for each test.
fn scratch(name: &str) -> std::path::PathBuf {
    let d = root().join("target/tmp/careless").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

#[test]
fn a_utf8_byte_order_mark_is_not_part_of_the_text() {
    let dir = scratch("bom");
    let path = dir.join("bom.mdg");
    std::fs::write(&path, b"\xEF\xBB\xBFstartshape A\nrule A { VERTEX {} }\n").expect("write");
    let a = analyze(&FsLoader, &path, &Options::default(), CheckOptions { require_start: true });
    assert!(!a.has_errors(), "{}", render_plain(&a.diagnostics, &a.sources));
    // Text given directly (an editor's buffer) may hold the mark too.
    let a = analyze_mem("\u{feff}startshape A\nrule A { VERTEX {} }\n");
    assert!(!a.has_errors(), "{}", render_plain(&a.diagnostics, &a.sources));
    // An error on the first line is still at its column.
    let a = analyze_mem("\u{feff}startshape A\nrule A { VERTEX {} } $\n");
    let text = render_plain(&a.diagnostics, &a.sources);
    assert!(text.contains("main.mdg:2:22"), "{text}");
}

#[test]
fn utf16_and_other_encodings_say_what_the_file_is() {
    let u16le: Vec<u8> =
        [0xFF, 0xFE].into_iter().chain("startshape A\n".encode_utf16().flat_map(u16::to_le_bytes)).collect();
    let unmarked: Vec<u8> = "startshape A\n".encode_utf16().flat_map(u16::to_le_bytes).collect();
    for bytes in [u16le, unmarked] {
        let e = decode_source(bytes).expect_err("UTF-16 is refused");
        assert!(e.contains("UTF-16") && e.contains("save it as UTF-8"), "{e}");
    }
    let e = decode_source(b"startshape A\n// caf\xE9\n".to_vec()).expect_err("Latin-1 is refused");
    assert!(e.contains("line 2, byte 7") && e.contains("0xE9"), "{e}");
    // Through the loader, with the file's name and a code.
    let dir = scratch("utf16");
    let path = dir.join("u16.mdg");
    std::fs::write(&path, [0xFF, 0xFE, b's', 0]).expect("write");
    let a = analyze(&FsLoader, &path, &Options::default(), CheckOptions { require_start: true });
    let text = render_plain(&a.diagnostics, &a.sources);
    assert!(codes(&a) == ["E0201"] && text.contains("u16.mdg") && text.contains("UTF-16"), "{text}");
}

#[test]
fn numbers_beyond_the_floats_are_errors_at_the_literal() {
    let a = analyze_mem("startshape A\nfps 1e999\nrule A { VERTEX {x 1e400} }\n");
    assert_eq!(codes(&a), ["E0109", "E0109"], "{}", render_plain(&a.diagnostics, &a.sources));
    let text = render_plain(&a.diagnostics, &a.sources);
    assert!(text.contains("number `1e999` is too large") && text.contains("main.mdg:3:20"), "{text}");
}

#[test]
fn directive_expressions_are_checked_like_literals() {
    let a = analyze_mem("startshape A\nfps (1e308 * 10)\nduration (0 - 1)\nrule A { VERTEX {} }\n");
    let text = render_plain(&a.diagnostics, &a.sources);
    assert_eq!(codes(&a), ["E0407", "E0407"], "{text}");
    assert!(text.contains("invalid value inf for `fps`") && text.contains("not a finite number"), "{text}");
    assert!(text.contains("invalid value -1 for `duration`"), "{text}");
}

#[test]
fn geometry_that_overflows_at_run_time_warns() {
    // 1e30 cubed is past f32: the vertex positions overflow to infinity.
    let out = run_source("startshape A\nrule A { VERTEX {s 1e30 1e30 1e30 x 1e30} }\n");
    let w = out.stats.warnings.iter().find(|w| w.contains("not finite"));
    assert!(w.is_some_and(|w| w.starts_with("1 position")), "{:?}", out.stats.warnings);
    let fine = run_source("startshape A\nrule A { VERTEX {x 1e6} }\n");
    assert!(fine.stats.warnings.is_empty(), "{:?}", fine.stats.warnings);
}

#[test]
fn a_megabyte_line_is_shown_as_a_window_around_the_error() {
    let mut text = String::from("startshape A\nrule A { VERTEX { ");
    text.push_str(&"x 1 ".repeat(250_000));
    text.push_str("é $ ");
    text.push_str(&"y 2 ".repeat(250_000));
    text.push_str("} }\n");
    let a = analyze_mem(&text);
    let shown = render_plain(&a.diagnostics, &a.sources);
    let n = a.diagnostics.len();
    assert!(n >= 1, "no diagnostics");
    assert!(shown.len() < n * (3 * MAX_SHOWN_LINE + 400), "{} bytes for {n} diagnostic(s)", shown.len());
    // The header gives the real column; the window holds the offending character.
    let col = "rule A { VERTEX { ".len() + 4 * 250_000 + 1;
    assert!(shown.contains(&format!("main.mdg:2:{col}")), "{shown}");
    assert!(shown.contains("…x 1 x 1") && shown.contains("é $ y 2") && shown.contains("y 2…"), "{shown}");
    // Short lines are untouched.
    let a = analyze_mem("startshape A\nrule A { VERTEX { $ } }\n");
    assert!(!render_plain(&a.diagnostics, &a.sources).contains('…'));
}
