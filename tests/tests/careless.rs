//! Careless input (issue 25): files in another encoding or with a byte-order mark,
//! numbers beyond the floats, directive values that overflow, geometry that
//! overflows at run time, and megabyte lines in diagnostics. Each gets a clear
//! message, never silence and never a megabyte of output.

use mdg_compiler::check::CheckOptions;
use mdg_compiler::diag::{render_plain, MAX_SHOWN_LINE};
use mdg_compiler::driver::{analyze, analyze_text, Analysis};
use mdg_compiler::expand::Options;
use mdg_compiler::source::{decode_source, DecodeError, FsLoader, MemLoader};
use mdg_tests::alloc::{bounded, PeakMemAlloc, INSTRUMENTED_SYSTEM};
use mdg_tests::{root, run_source};
use std::alloc::System;
use std::path::Path;

/// Every test's heap is measured ([`bounded`]): each runs alone and fails past
/// 512 MiB of peak heap or 60 s (measured in a debug build: at most 293 MiB, the
/// analysis of a 2 MB line of a million tokens, and 0.2 s).
#[global_allocator]
static HEAP: &PeakMemAlloc<System> = &INSTRUMENTED_SYSTEM;
const BOUND_MIB: usize = 512;
const BOUND_SECS: u64 = 60;

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
    bounded(HEAP, "a_utf8_byte_order_mark_is_not_part_of_the_text", BOUND_MIB, BOUND_SECS, || {
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
    });
}

#[test]
fn utf16_and_other_encodings_say_what_the_file_is() {
    bounded(HEAP, "utf16_and_other_encodings_say_what_the_file_is", BOUND_MIB, BOUND_SECS, || {
        let u16le: Vec<u8> =
            [0xFF, 0xFE].into_iter().chain("startshape A\n".encode_utf16().flat_map(u16::to_le_bytes)).collect();
        let unmarked: Vec<u8> = "startshape A\n".encode_utf16().flat_map(u16::to_le_bytes).collect();
        for bytes in [u16le, unmarked] {
            let e = decode_source(bytes).expect_err("UTF-16 is refused");
            assert_eq!(e, DecodeError::Utf16);
            let e = e.to_string();
            assert!(e.contains("UTF-16") && e.contains("save it as UTF-8"), "{e}");
        }
        let e = decode_source(b"startshape A\n// caf\xE9\n".to_vec()).expect_err("Latin-1 is refused");
        assert_eq!(e, DecodeError::NotUtf8 { line: 2, column: 7, byte: 0xE9 });
        let e = e.to_string();
        assert!(e.contains("line 2, byte 7") && e.contains("0xE9"), "{e}");
        // Through the loader, with the file's name and a code.
        let dir = scratch("utf16");
        let path = dir.join("u16.mdg");
        std::fs::write(&path, [0xFF, 0xFE, b's', 0]).expect("write");
        let a = analyze(&FsLoader, &path, &Options::default(), CheckOptions { require_start: true });
        let text = render_plain(&a.diagnostics, &a.sources);
        assert!(codes(&a) == ["E0201"] && text.contains("u16.mdg") && text.contains("UTF-16"), "{text}");
    });
}

#[test]
fn numbers_beyond_the_floats_are_errors_at_the_literal() {
    bounded(HEAP, "numbers_beyond_the_floats_are_errors_at_the_literal", BOUND_MIB, BOUND_SECS, || {
        let a = analyze_mem("startshape A\nfps 1e999\nrule A { VERTEX {x 1e400} }\n");
        assert_eq!(codes(&a), ["E0109", "E0109"], "{}", render_plain(&a.diagnostics, &a.sources));
        let text = render_plain(&a.diagnostics, &a.sources);
        assert!(text.contains("number `1e999` is too large") && text.contains("main.mdg:3:20"), "{text}");
    });
}

#[test]
fn directive_expressions_are_checked_like_literals() {
    bounded(HEAP, "directive_expressions_are_checked_like_literals", BOUND_MIB, BOUND_SECS, || {
        let a = analyze_mem("startshape A\nfps (1e308 * 10)\nduration (0 - 1)\nrule A { VERTEX {} }\n");
        let text = render_plain(&a.diagnostics, &a.sources);
        assert_eq!(codes(&a), ["E0407", "E0407"], "{text}");
        assert!(text.contains("invalid value inf for `fps`") && text.contains("not a finite number"), "{text}");
        assert!(text.contains("invalid value -1 for `duration`"), "{text}");
    });
}

#[test]
fn geometry_that_overflows_at_run_time_warns() {
    bounded(HEAP, "geometry_that_overflows_at_run_time_warns", BOUND_MIB, BOUND_SECS, || {
        // 1e30 cubed is past f32: the vertex positions overflow to infinity.
        let out = run_source("startshape A\nrule A { VERTEX {s 1e30 1e30 1e30 x 1e30} }\n");
        let w = out.stats.warnings.iter().find(|w| w.contains("not finite"));
        assert!(w.is_some_and(|w| w.starts_with("1 position")), "{:?}", out.stats.warnings);
        let fine = run_source("startshape A\nrule A { VERTEX {x 1e6} }\n");
        assert!(fine.stats.warnings.is_empty(), "{:?}", fine.stats.warnings);
    });
}

#[test]
fn a_megabyte_line_is_shown_as_a_window_around_the_error() {
    bounded(HEAP, "a_megabyte_line_is_shown_as_a_window_around_the_error", BOUND_MIB, BOUND_SECS, || {
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
    });
}

fn build(text: &str) -> mdg_vm::bundle::Bundle {
    mdg_tests::build_source(text)
}

#[test]
fn the_time_budget_stops_isosurfaces_midway() {
    bounded(HEAP, "the_time_budget_stops_isosurfaces_midway", BOUND_MIB, BOUND_SECS, || {
        // Twenty 200³ isosurfaces: minutes of sampling without a deadline inside.
        let mut text = String::from("startshape A\n");
        for i in 0..20 {
            text.push_str(&format!("isosurface S{i} {{ xyz -1 1 200 ; function {{ x*x + y*y + z*z - 0.{i}5 }} }}\n"));
        }
        text.push_str("rule A {\n  VERTEX {} VERTEX {x 1} VERTEX {y 1}\n");
        for i in 0..20 {
            text.push_str(&format!("  S{i} {{x {i}}}\n"));
        }
        text.push_str("}\n");
        let opts = mdg_vm::eval::EvalOptions {
            time_budget: Some(std::time::Duration::from_millis(200)),
            max_iso_cells: u64::MAX,
            ..Default::default()
        };
        let started = std::time::Instant::now();
        let out = mdg_vm::eval::evaluate(&build(&text), &opts);
        let took = started.elapsed();
        // The warning shows the budget ended it; `bounded` is the hang guard.
        eprintln!("took {took:?}");
        assert!(out.stats.warnings.iter().any(|w| w.starts_with("time budget reached")), "{:?}", out.stats.warnings);
        assert_eq!(out.vertex_mesh().n_vertices(), 3, "what came before is kept");
        assert!(out.instances.len() < 20);
    });
}

#[test]
fn the_cell_limit_counts_every_isosurface_of_the_run() {
    bounded(HEAP, "the_cell_limit_counts_every_isosurface_of_the_run", BOUND_MIB, BOUND_SECS, || {
        let text = "startshape A\nisosurface P { xyz -1 1 100 ; function { x*x + y*y + z*z - 0.5 } }\n\
                    isosurface Q { xyz -1 1 100 ; function { x*x + y*y + z*z - 0.25 } }\n\
                    rule A { P {} P {x 3} Q {x 6} }\n";
        let opts = mdg_vm::eval::EvalOptions { max_iso_cells: 1_500_000, ..Default::default() };
        let out = mdg_vm::eval::evaluate(&build(text), &opts);
        let w: Vec<&String> = out.stats.warnings.iter().filter(|w| w.contains("isosurface `Q` not built")).collect();
        assert_eq!(w.len(), 1, "{:?}", out.stats.warnings);
        assert!(
            w[0].contains(
                "would take the run past the limit of 1500000 cells for all isosurfaces (1000000 already used"
            ) && w[0].contains("--max-iso-cells"),
            "{}",
            w[0]
        );
        assert_eq!(
            out.instances.iter().filter(|i| out.shared(i).is_some_and(|s| s.name == "P")).count(),
            2,
            "P is built once, instanced twice"
        );
    });
}

#[test]
fn the_vertex_budget_counts_instances_and_line_points() {
    bounded(HEAP, "the_vertex_budget_counts_instances_and_line_points", BOUND_MIB, BOUND_SECS, || {
        // Lines only: no mesh vertex at all, yet a budget of 10,000 stops the run (checked
        // every 4,096 rule calls).
        let lines = "startshape A\nrule A { 100000 * {x 1} LINETO {} }\n";
        let opts = mdg_vm::eval::EvalOptions { max_vertices: 10_000, ..Default::default() };
        let out = mdg_vm::eval::evaluate(&build(lines), &opts);
        let points: usize = out.lines.iter().map(|l| l.points.len()).sum();
        assert!(points <= 10_000 + 4096, "{points} line points");
        assert!(out.stats.warnings.iter().any(|w| w.contains("vertex budget 10000")), "{:?}", out.stats.warnings);
        // A shared mesh counts its vertices once, each instance one.
        let inst = "startshape A\nisosurface S { xyz -1 1 8 ; function { x*x + y*y + z*z - 0.5 } }\n\
                    rule A { 100000 * {x 3} S {} }\n";
        let out = mdg_vm::eval::evaluate(&build(inst), &opts);
        let per = out.shared_meshes[0].mesh.n_vertices();
        assert!(per > 10 && out.instances.len() + per <= 10_000 + 4096, "{} instances of {per}", out.instances.len());
        assert!(out.stats.warnings.iter().any(|w| w.contains("vertex budget 10000")), "{:?}", out.stats.warnings);
        // An isosurface mesh larger than the budget stops the run when it is built.
        let big = "startshape A\nisosurface S { xyz -1 1 100 ; function { x*x + y*y + z*z - 0.5 } }\n\
                   rule A { S {} VERTEX {} }\n";
        let out = mdg_vm::eval::evaluate(&build(big), &opts);
        assert!(out.stats.warnings.iter().any(|w| w.contains("vertex budget 10000")), "{:?}", out.stats.warnings);
        assert_eq!(out.vertex_mesh().n_vertices(), 0, "nothing after it ran");
    });
}

/// A file saved with old Mac line endings (a lone CR ends each line) checks exactly
/// like its LF twin: `//` comments end at the CR, and every diagnostic is at the same
/// line and column. It used to be one line, all of it a comment after the first `//`.
#[test]
fn cr_only_line_endings_check_like_lf() {
    bounded(HEAP, "cr_only_line_endings_check_like_lf", BOUND_MIB, BOUND_SECS, || {
        let lf = "// a tree\nstartshape A\n\nrule A { // the trunk\n  VERTEX {} VERTEX {x 1} VERTEX {y 1}\n  B {}\n}\n\
                  rule C { \"s\" }\n";
        let cr = lf.replace('\n', "\r");
        let crlf = lf.replace('\n', "\r\n");
        let (a_lf, a_cr, a_crlf) = (analyze_mem(lf), analyze_mem(&cr), analyze_mem(&crlf));
        assert!(!places(&a_lf).is_empty(), "the LF file has its errors");
        assert_eq!(places(&a_cr), places(&a_lf), "{}", render_plain(&a_cr.diagnostics, &a_cr.sources));
        assert_eq!(places(&a_crlf), places(&a_lf));
        assert_eq!(a_cr.sources.file(a_cr.diagnostics[0].span.file).n_lines(), 9);
        let shown = render_plain(&a_cr.diagnostics, &a_cr.sources);
        assert_eq!(shown, render_plain(&a_lf.diagnostics, &a_lf.sources), "rendered alike");
    });
}

/// A `#` comment (Python, shell, Context Free) is one error with the hint, not an
/// error for `#` and more for every word after it; `#define` points at `@define`.
#[test]
fn a_hash_comment_is_one_error_with_a_hint() {
    bounded(HEAP, "a_hash_comment_is_one_error_with_a_hint", BOUND_MIB, BOUND_SECS, || {
        let a = analyze_mem("# a tree, with (brackets} and \"quotes\nstartshape A\nrule A { VERTEX {} } # trunk\n");
        let shown = render_plain(&a.diagnostics, &a.sources);
        assert_eq!(codes(&a), ["E0103", "E0103"], "{shown}");
        assert!(a.diagnostics.iter().all(|d| a.sources.text(d.span) == "#"), "{shown}");
        assert!(shown.contains("MDG comments are `//` or `/* */`"), "{shown}");
        assert_eq!(a.diagnostics[0].suggestion.as_ref().map(|s| s.replacement.as_str()), Some("//"));
        let a = analyze_mem("#define N 3\nstartshape A\nrule A { VERTEX {} }\n");
        let shown = render_plain(&a.diagnostics, &a.sources);
        assert_eq!(codes(&a), ["E0103"], "{shown}");
        assert!(shown.contains("`@define`"), "{shown}");
        assert_eq!(a.diagnostics[0].suggestion.as_ref().map(|s| s.replacement.as_str()), Some("@"));
    });
}

/// A shader block in a CR-only file compiles like its LF twin (glslang itself does
/// not end lines at a lone CR: the `#version` line ran on into the code), and a GLSL
/// error is at the same line and column.
#[test]
fn a_shader_block_with_cr_only_line_endings_compiles_like_lf() {
    bounded(HEAP, "a_shader_block_with_cr_only_line_endings_compiles_like_lf", BOUND_MIB, BOUND_SECS, || {
        let lf = "startshape A\n@vertexshader vs\n#version 450\nvoid main() {\n  gl_Position = vec4(nope);\n}\n\
                  @endshader\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";
        let a_lf = analyze_mem(lf);
        assert_eq!(places(&a_lf), [("E0501", 4, 21)], "{}", render_plain(&a_lf.diagnostics, &a_lf.sources));
        let a_cr = analyze_mem(&lf.replace('\n', "\r"));
        assert_eq!(places(&a_cr), places(&a_lf), "{}", render_plain(&a_cr.diagnostics, &a_cr.sources));
        let good = analyze_mem(&lf.replace("nope", "1.0").replace('\n', "\r"));
        assert!(!good.has_errors(), "{}", render_plain(&good.diagnostics, &good.sources));
    });
}

/// Each diagnostic's code, line and column.
fn places(a: &Analysis) -> Vec<(&'static str, u32, u32)> {
    a.diagnostics
        .iter()
        .map(|d| {
            let (l, c) = a.sources.file(d.span.file).line_col(d.span.start);
            (d.code, l, c)
        })
        .collect()
}
