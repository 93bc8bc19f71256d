//! Hostile grammars: infinite recursion, exponential branching, iterators with 10^12
//! runs, huge isosurface grids, deep nesting, deeply nested and exploding macros,
//! self-importing files, imports escaping the project (symlinks included) and 100 MB
//! sources. Each must end within the configured limits (docs/limits.md) with the
//! specific diagnostic or warning, and keep what was produced before the limit.

use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver::{analyze_text, Analysis};
use mdg_compiler::expand::{Options, MAX_EXPANDED_TOKENS, MAX_EXPANSIONS, MAX_EXPANSION_DEPTH};
use mdg_compiler::parse::MAX_NESTING;
use mdg_compiler::source::MAX_SOURCE_BYTES;
use mdg_compiler::source::{FsLoader, MemLoader};
use mdg_tests::alloc::{bounded, PeakMemAlloc, INSTRUMENTED_SYSTEM};
use mdg_tests::{build_source, run_source};
use mdg_vm::eval::{evaluate, EvalOptions, DEFAULT_MAX_ISO_CELLS, DEFAULT_STACKSIZE};
use std::alloc::System;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Every test's heap is measured ([`bounded`]): each runs alone and fails past
/// 256 MiB of peak heap or 60 s (measured in a debug build: at most 116 MiB, for the
/// 100 MB source the test hands over as text, and 1.0 s; the failures these guard
/// against took gigabytes or ran until killed).
#[global_allocator]
static HEAP: &PeakMemAlloc<System> = &INSTRUMENTED_SYSTEM;
const BOUND_MIB: usize = 256;
const BOUND_SECS: u64 = 60;

/// Analyses `text` as `/hostile/main.mdg` with no file system.
fn analyze_mem(text: &str) -> Analysis {
    analyze_text(
        &MemLoader::default(),
        Path::new("/hostile/main.mdg"),
        text,
        &Options::default(),
        CheckOptions { require_start: true },
    )
}

fn codes(a: &Analysis) -> Vec<&'static str> {
    a.diagnostics.iter().map(|d| d.code).collect()
}

fn messages(a: &Analysis, code: &str) -> Vec<String> {
    a.diagnostics.iter().filter(|d| d.code == code).map(|d| d.message.clone()).collect()
}

fn has_rule(a: &Analysis, name: &str) -> bool {
    a.checked.symbols.rules.contains_key(name)
}

fn warning<'a>(out: &'a mdg_vm::output::Output, needle: &str) -> &'a str {
    out.stats
        .warnings
        .iter()
        .find(|w| w.contains(needle))
        .unwrap_or_else(|| panic!("no warning containing {needle:?} in {:?}", out.stats.warnings))
}

/// A scratch directory under the target directory, fresh for each test.
fn scratch(name: &str) -> PathBuf {
    let d = mdg_tests::root().join("target/tmp/hostile").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d.canonicalize().expect("canonical scratch dir")
}

/// Runs `f` on a thread with a 2 MiB stack: the language server analyses documents
/// on such threads, so nothing the compiler does may need more.
fn on_small_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::Builder::new()
        .stack_size(2 * 1024 * 1024)
        .spawn(f)
        .expect("spawn")
        .join()
        .unwrap_or_else(|_| panic!("the analysis panicked"))
}

// ---------------------------------------------------------------- evaluation limits

#[test]
fn infinite_recursion_without_limits_ends_at_the_default_stack_size() {
    bounded(HEAP, "infinite_recursion_without_limits_ends_at_the_default_stack_size", BOUND_MIB, BOUND_SECS, || {
        // No maxdepth, maxiter or stacksize: the default stack size ends the one branch.
        let b = build_source("startshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} A {z 1} }\n");
        let t0 = Instant::now();
        let out = evaluate(&b, &EvalOptions::default());
        // `bounded` is the hang guard (BOUND_SECS); the stack-size warning below shows the
        // limit, not time, ended the run.
        eprintln!("took {:?}", t0.elapsed());
        let w = warning(&out, "stack size");
        assert!(
            w.starts_with(&format!("stack size {DEFAULT_STACKSIZE} reached in rule `A` ("))
                && w.ends_with("inline.mdg:2): 1 branch(es) ended there (raise the limit with `stacksize N` in the grammar, up to the cap set by `--max-stack N`)"),
            "{w}"
        );
        // The start shape and the 99,999 calls admitted under it drew their triangles
        // (the stack then holds 100,000 activations), all kept; the refused call counts as
        // a rule call too.
        assert_eq!(out.vertex_mesh().n_vertices() as u64, 3 * u64::from(DEFAULT_STACKSIZE));
        assert_eq!(out.stats.rule_calls, u64::from(DEFAULT_STACKSIZE));
    });
}

#[test]
fn exponential_branching_ends_at_maxiter_and_keeps_the_output() {
    bounded(HEAP, "exponential_branching_ends_at_maxiter_and_keeps_the_output", BOUND_MIB, BOUND_SECS, || {
        let src = "startshape A\nmaxiter 20000\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} A {z 1} A {x 1} }\n";
        let out = run_source(src);
        assert_eq!(
            warning(&out, "maxiter"),
            "maxiter 20000 reached in rule `A` (inline.mdg:3): the run stopped; the output so far is kept (raise the limit with `maxiter N` in the grammar, up to the cap set by `--max-iter N`)"
        );
        // The start shape and the 20,000 admitted calls each drew 3 vertices (call 20,001
        // was refused and stopped the run).
        assert_eq!(out.vertex_mesh().n_vertices(), 3 * (1 + 20_000));
        assert_eq!(out.stats.rule_calls, 20_000);
    });
}

#[test]
fn exponential_branching_ends_at_the_vertex_budget() {
    bounded(HEAP, "exponential_branching_ends_at_the_vertex_budget", BOUND_MIB, BOUND_SECS, || {
        let b = build_source("startshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} A {z 1} A {x 1} }\n");
        let out = evaluate(&b, &EvalOptions { max_vertices: 5_000, ..EvalOptions::default() });
        assert_eq!(
            warning(&out, "vertex budget"),
            "vertex budget 5000 reached in rule `A` (inline.mdg:2): the run stopped; the output so far is kept (raise the limit with `--max-vertices N`)"
        );
        // The budget is checked every 4,096 calls: the output overshoots by less than that.
        let n = out.vertex_mesh().n_vertices();
        assert!(n > 5_000 && n <= 5_000 + 3 * 4_096, "{n} vertices");
        assert_eq!(out.stats.vertices, n as u64);
    });
}

#[test]
fn exponential_branching_ends_at_the_time_budget() {
    bounded(HEAP, "exponential_branching_ends_at_the_time_budget", BOUND_MIB, BOUND_SECS, || {
        let b = build_source("startshape A\nrule A { A {z 1} A {x 1} A {y 1} }\n");
        let budget = Duration::from_millis(200);
        let t0 = Instant::now();
        let out =
            evaluate(&b, &EvalOptions { time_budget: Some(budget), maxiter: Some(u64::MAX), ..EvalOptions::default() });
        let took = t0.elapsed();
        let w = warning(&out, "time budget");
        assert!(w.starts_with("time budget reached in rule `A` (inline.mdg:2): the run stopped"), "{w}");
        assert!(w.ends_with("(raise the limit with `--time-budget TIME`, e.g. `--time-budget 30s`)"), "{w}");
        // Not before the budget; how soon after it is a benchmark's business (wall time
        // on a shared machine), `bounded` is the hang guard.
        assert!(took >= budget, "took {took:?}");
        assert!(out.stats.rule_calls > 1_000, "calls before the budget ended the run are counted");
    });
}

#[test]
fn bones_with_ever_faster_tracks_end_at_the_animation_budget() {
    bounded(HEAP, "bones_with_ever_faster_tracks_end_at_the_animation_budget", BOUND_MIB, BOUND_SECS, || {
        // Every call makes a bone whose track needs fps · duration frames, and fps grows by
        // 1,000 per level: without a budget the keyframes (and the glTF file) grow without
        // bound long before maxiter.
        let b = build_source(
            "startshape A\nfps 1000\nduration 10\nrule A : X { VERTEX {} VERTEX {x 1} VERTEX {y 1} A {z 1 fps 1000} }\n\
             rule X { FRAME {} X {rz 1} }\n",
        );
        let out = evaluate(&b, &EvalOptions { max_vertices: 200_000, ..EvalOptions::default() });
        assert_eq!(
            warning(&out, "animation"),
            "animation budget of 200000 keyframes reached in rule `A` (inline.mdg:4): the run stopped; the output so far is kept (at most 10000000; a smaller `--max-vertices N` lowers it)"
        );
        // Bone k (k ≥ 1, the start shape is bone 1) runs at 1000·k fps: 10,000·k + 1
        // keyframes. The sum passes 200,000 at k = 6: that call stops the run before its
        // body, and the bones and triangles made until then are kept.
        assert_eq!(out.animation.bones.len(), 1 + 6, "the root and six bones");
        assert_eq!(out.vertex_mesh().n_vertices(), 3 * 5);
        let mut glb = Vec::new();
        mdg_export::write(mdg_export::Format::Glb, &out, &mut glb).expect("export");
        assert!(glb.len() < 64 << 20, "{} bytes", glb.len());
    });
}

#[test]
fn an_iterator_with_ten_to_the_twelve_runs_ends_at_maxiter() {
    bounded(HEAP, "an_iterator_with_ten_to_the_twelve_runs_ends_at_maxiter", BOUND_MIB, BOUND_SECS, || {
        let out = run_source("startshape A\nmaxiter 30000\nrule A { VERTEX {} 1000000000000 * {x 1} VERTEX {} }\n");
        assert_eq!(
            warning(&out, "maxiter"),
            "maxiter 30000 reached in rule `A` (inline.mdg:3): the run stopped; the output so far is kept (raise the limit with `maxiter N` in the grammar, up to the cap set by `--max-iter N`)"
        );
        // Run 1 belongs to the start call; runs 2, 3, … count as calls, and the run that
        // makes call 30,001 still draws before the run stops: the first VERTEX and 30,001
        // runs, each kept.
        let n = out.vertex_mesh().n_vertices();
        assert_eq!(n, 1 + 30_001);
        let last = out.vertex_mesh().positions[n - 1];
        assert!((last[0] - (n - 1) as f32).abs() < 1e-3, "run i is at x = i: {last:?}");
    });
}

#[test]
fn an_iterator_count_beyond_u64_saturates_and_ends_at_maxiter() {
    bounded(HEAP, "an_iterator_count_beyond_u64_saturates_and_ends_at_maxiter", BOUND_MIB, BOUND_SECS, || {
        let out = run_source("startshape A\nmaxiter 5000\nrule A { 1e30 * {x 1} VERTEX {} }\n");
        assert_eq!(
            warning(&out, "maxiter"),
            "maxiter 5000 reached in rule `A` (inline.mdg:3): the run stopped; the output so far is kept (raise the limit with `maxiter N` in the grammar, up to the cap set by `--max-iter N`)"
        );
        assert_eq!(out.vertex_mesh().n_vertices(), 5_001, "runs 1..=5001, as for any count past maxiter");
        // 2^64 exactly: wrapped it would be 0 runs (no vertex, no warning); saturated it
        // is u64::MAX runs and ends at maxiter like 1e30.
        let out = run_source("startshape A\nmaxiter 5000\nrule A { 18446744073709551616 * {x 1} VERTEX {} }\n");
        assert_eq!(
            warning(&out, "maxiter"),
            "maxiter 5000 reached in rule `A` (inline.mdg:3): the run stopped; the output so far is kept (raise the limit with `maxiter N` in the grammar, up to the cap set by `--max-iter N`)"
        );
        assert_eq!(out.vertex_mesh().n_vertices(), 5_001);
    });
}

#[test]
fn a_huge_isosurface_grid_is_skipped_with_a_warning_and_the_rest_kept() {
    bounded(HEAP, "a_huge_isosurface_grid_is_skipped_with_a_warning_and_the_rest_kept", BOUND_MIB, BOUND_SECS, || {
        let out = run_source(
            "startshape A\nisosurface BIG { xyz -1 1 100000 ; function { x*x + y*y + z*z - 1 } }\n\
             isosurface OK { xyz -1 1 4 ; function { x*x + y*y + z*z - 1 } }\n\
             rule A {\n  VERTEX {} VERTEX {x 1} VERTEX {y 1}\n  BIG {}\n  OK {x 3}\n  BIG {x 6}\n}\n",
        );
        let w = warning(&out, "BIG");
        assert_eq!(
            w,
            format!(
                "inline.mdg:6: isosurface `BIG` not built: isosurface grid has 1000000000000000 cells, more than the \
                 limit of {DEFAULT_MAX_ISO_CELLS} (raise it with `--max-iso-cells N`)"
            )
        );
        assert_eq!(out.stats.warnings.iter().filter(|w| w.contains("BIG")).count(), 1, "reported once");
        assert_eq!(out.vertex_mesh().n_vertices(), 3, "the triangle before it is kept");
        let isos: Vec<_> = out.instances.iter().filter(|i| !out.is_prototype_instance(i)).collect();
        assert_eq!(isos.len(), 1, "the small isosurface after it is instanced");
        assert_eq!(out.shared(&isos[0]).map(|s| s.name.as_str()), Some("OK"));
    });
}

#[test]
fn an_isosurface_resolution_past_u32_is_capped() {
    bounded(HEAP, "an_isosurface_resolution_past_u32_is_capped", BOUND_MIB, BOUND_SECS, || {
        // A resolution beyond u32 saturates and hits the cell limit instead of wrapping.
        let out =
            run_source("startshape A\nisosurface H { xyz -1 1 1e12 ; function { x } }\nrule A { VERTEX {} H {} }\n");
        assert!(warning(&out, "H").contains("more than the limit"), "{:?}", out.stats.warnings);
        assert_eq!(out.vertex_mesh().n_vertices(), 1);
        // 2^32 + 4: wrapped it would be a 4³ grid, built and instanced; saturated it is
        // (2^32 − 1)³ cells (the count saturates too) and refused.
        let out = run_source(
            "startshape A\nisosurface H { xyz -1 1 4294967300 ; function { x } }\nrule A { VERTEX {} H {} }\n",
        );
        assert_eq!(
            warning(&out, "H"),
            format!(
                "inline.mdg:3: isosurface `H` not built: isosurface grid has {} cells, more than the limit of \
                 {DEFAULT_MAX_ISO_CELLS} (raise it with `--max-iso-cells N`)",
                u64::MAX
            )
        );
        assert!(out.instances.is_empty(), "not built, so not instanced");
        assert_eq!(out.vertex_mesh().n_vertices(), 1);
    });
}

// ------------------------------------------------------------------- source limits

#[test]
fn a_hundred_megabyte_source_is_refused_unparsed() {
    let line = "rule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";
    let mut text = String::from("startshape A\n");
    while text.len() < 100 * 1024 * 1024 {
        text.push_str(&line.repeat(4096));
    }
    let len = text.len();
    // What the analysis allocates, not the test's own 100 MB.
    bounded(HEAP, "a_hundred_megabyte_source_is_refused_unparsed", BOUND_MIB, BOUND_SECS, || {
        let a = analyze_mem(&text);
        // The file is not parsed at all, so it has no start shape either: that is what keeps
        // the refusal quick (checked by what happened, not by a clock on a shared machine).
        assert_eq!(codes(&a), ["E0201", "E0306"]);
        assert_eq!(
            messages(&a, "E0201"),
            [format!(
                "cannot read `/hostile/main.mdg`: source file too large: {len} bytes (at most {MAX_SOURCE_BYTES})"
            )]
        );
        let rendered = mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources);
        assert!(rendered.contains("split the grammar into files joined with `@import`"), "{rendered}");
    });
}

#[test]
fn a_hundred_megabyte_import_is_refused_without_reading_it_and_the_rest_is_kept() {
    bounded(
        HEAP,
        "a_hundred_megabyte_import_is_refused_without_reading_it_and_the_rest_is_kept",
        BOUND_MIB,
        BOUND_SECS,
        || {
            let dir = scratch("big_import");
            // A sparse file: 100 MB long, no disk used.
            let big = std::fs::File::create(dir.join("big.mdg")).expect("create");
            big.set_len(100 * 1024 * 1024).expect("set_len");
            let main = dir.join("main.mdg");
            std::fs::write(&main, "@import big.mdg\nstartshape A\nrule A { VERTEX {} }\n").expect("write");
            let t0 = Instant::now();
            let a = mdg_compiler::driver::analyze(
                &FsLoader,
                &main,
                &Options::default(),
                CheckOptions { require_start: true },
            );
            // Refused by its size, unread: the message says so (`bounded` guards the time).
            eprintln!("took {:?}", t0.elapsed());
            assert_eq!(
                messages(&a, "E0201"),
                [format!(
                    "cannot read `big.mdg`: source file too large: {} bytes (at most {MAX_SOURCE_BYTES})",
                    100 << 20
                )]
            );
            assert!(has_rule(&a, "A"), "the main file's rules are kept");
        },
    );
}

/// A grammar nesting `n` levels of one construct, with a rule after it.
fn nested(kind: &str, n: usize) -> String {
    let body = match kind {
        "braces" => format!("rule A {}VERTEX {{}}{} }}", "{ ".repeat(n), " }".repeat(n)),
        "parens" => format!("rule A {{ VERTEX {{x {}1{}}} }}", "(".repeat(n), ")".repeat(n)),
        "negation" => format!("function f {{ {}x }}\nrule A {{ VERTEX {{}} }}", "-".repeat(n)),
        "power" => format!("function f {{ {}x }}\nrule A {{ VERTEX {{}} }}", "x ^ ".repeat(n)),
        "sum" => format!("function f {{ {}x }}\nrule A {{ VERTEX {{}} }}", "x + ".repeat(n)),
        "iterators" => format!("rule A {{ {}VERTEX {{}} }}", "2 * {x 1} ".repeat(n)),
        "namespaces" => format!("{}rule A {{ VERTEX {{}} }}{}", "namespace n { ".repeat(n), " }".repeat(n)),
        "ifdefs" => format!("@define D\n{}rule A {{ VERTEX {{}} }}\n{}", "@ifdef D\n".repeat(n), "@endif\n".repeat(n)),
        "ifs" => format!("rule A {{ {}VERTEX {{}}{} }}", "if (true) { ".repeat(n), " }".repeat(n)),
        "loops" => format!("rule A {{ {}VERTEX {{}} }}", "loop i = 0, 2 {x i} ".repeat(n)),
        _ => unreachable!(),
    };
    format!("startshape A\n{body}\nrule after {{ missing {{}} }}\n")
}

const KINDS: [&str; 10] =
    ["braces", "parens", "negation", "power", "sum", "iterators", "namespaces", "ifdefs", "ifs", "loops"];

#[test]
fn deep_nesting_is_cut_with_e0105_on_a_small_stack() {
    bounded(HEAP, "deep_nesting_is_cut_with_e0105_on_a_small_stack", BOUND_MIB, BOUND_SECS, || {
        for kind in KINDS {
            let text = nested(kind, 20_000);
            let t0 = Instant::now();
            let (codes, msgs, after_checked, fmt_refused) = on_small_stack(move || {
                let a = analyze_mem(&text);
                let fmt = mdg_compiler::fmt::format_source(&text);
                let doc = mdg_compiler::analysis::Document::from_analysis(a);
                let _ = doc.semantic_tokens();
                let _ = doc.folding_ranges();
                let _ = doc.document_symbols();
                let a = doc.analysis();
                (
                    codes(a),
                    messages(a, "E0105"),
                    // The rule after the deep one is still checked: its unknown call is found
                    // (the checker's own list: the report keeps the first 100 errors).
                    a.checked.diagnostics.iter().any(|d| d.code == "E0301" && d.message.contains("missing")),
                    fmt.is_err_and(|e| e.to_string().contains("E0105")),
                )
            });
            eprintln!("{kind}: took {:?}", t0.elapsed()); // `bounded` is the hang guard
            assert_eq!(msgs, [format!("nesting too deep: more than {MAX_NESTING} levels")], "{kind}: {codes:?}");
            assert!(after_checked, "{kind}: the rest of the file was not checked: {codes:?}");
            assert!(fmt_refused, "{kind}: the formatter must refuse it with E0105");
            assert!(!codes.contains(&"E0101") && !codes.contains(&"E0104"), "{kind}: cascading errors {codes:?}");
        }
    });
}

#[test]
fn nesting_within_the_limit_goes_through_every_pass_on_a_small_stack() {
    bounded(HEAP, "nesting_within_the_limit_goes_through_every_pass_on_a_small_stack", BOUND_MIB, BOUND_SECS, || {
        for kind in KINDS {
            // Every construct's own limit, less the levels around it (rule body, `VERTEX {`).
            let mut n = MAX_NESTING - 3;
            let text = loop {
                let t = nested(kind, n);
                if !analyze_mem(&t).diagnostics.iter().any(|d| d.code == "E0105") {
                    break t;
                }
                n -= 1;
            };
            assert!(n > MAX_NESTING / 4, "{kind}: only {n} levels accepted");
            on_small_stack(move || {
                let a = analyze_mem(&text);
                let b = mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources);
                let _ = mdg_compiler::fmt::format_source(&text);
                let doc = mdg_compiler::analysis::Document::from_analysis(a);
                let len = doc.text().len() as u32;
                let _ = doc.semantic_tokens();
                let _ = doc.inlay_hints(0, len);
                let _ = doc.code_actions(0, len);
                let _ = doc.hover(len / 2);
                let _ = doc.format();
                drop(b);
            });
        }
    });
}

#[test]
fn a_long_call_chain_is_checked_in_linear_time() {
    bounded(HEAP, "a_long_call_chain_is_checked_in_linear_time", BOUND_MIB, BOUND_SECS, || {
        // r0 → r1 → … → r5000: the termination analysis used to take a pass per link
        // (quadratic: 90 s for 20,000 rules in release).
        let n = 5_000;
        let mut src = String::from("startshape r0\n");
        for i in 0..n {
            src.push_str(&format!("rule r{i} {{ VERTEX {{x {i}}} r{} {{s 0.5}} }}\n", i + 1));
        }
        src.push_str(&format!("rule r{n} {{ VERTEX {{}} }}\nrule spin {{ spin {{}} }}\nrule a {{ spin {{}} }}\n"));
        src.push_str("rule b { b {} }\nrule b { VERTEX {} }\n");
        let t0 = Instant::now();
        let a = analyze_mem(&src);
        // A quadratic check of the chain would take minutes: `bounded` (BOUND_SECS) fails it.
        eprintln!("took {:?}", t0.elapsed());
        // The chain ends, so only the unreachable endless rules are reported.
        let w: Vec<(&str, String)> = a.diagnostics.iter().map(|d| (d.code, d.message.clone())).collect();
        assert_eq!(
            w,
            [
                ("W0002", "rule `spin` is unreachable from the start shape".to_string()),
                ("W0001", "rule `a` is never used".to_string()),
                ("W0002", "rule `b` is unreachable from the start shape".to_string()),
            ],
        );
        let out =
            run_source(&format!("maxiter 100000\n{}", src.replace("rule spin { spin {} }\nrule a { spin {} }\n", "")));
        assert_eq!(out.vertex_mesh().n_vertices(), n + 1, "every rule of the chain ran once");
    });
}

// ---------------------------------------------------------------------- macros

#[test]
fn deeply_nested_macros_stop_at_the_expansion_depth_and_keep_the_rules_before() {
    bounded(
        HEAP,
        "deeply_nested_macros_stop_at_the_expansion_depth_and_keep_the_rules_before",
        BOUND_MIB,
        BOUND_SECS,
        || {
            // M0 defines rule R0 and expands M1, … : a chain deeper than the limit.
            let n = MAX_EXPANSION_DEPTH + 8;
            let mut src = String::from("startshape R0\n");
            for i in 0..n {
                src.push_str(&format!("@macro M{i}()\nrule R{i} {{ VERTEX {{}} }}\n@expand M{}()\n@endmacro\n", i + 1));
            }
            src.push_str(&format!("@macro M{n}()\nrule R{n} {{ VERTEX {{}} }}\n@endmacro\n@expand M0()\n"));
            let t0 = Instant::now();
            let a = analyze_mem(&src);
            eprintln!("took {:?}", t0.elapsed()); // `bounded` is the hang guard
            assert_eq!(
                messages(&a, "E0208"),
                [format!("expansion of macro `M{MAX_EXPANSION_DEPTH}` nests too deeply")]
            );
            for i in 0..MAX_EXPANSION_DEPTH {
                assert!(has_rule(&a, &format!("R{i}")), "rule R{i} from expansion depth {i} is kept");
            }
            assert!(!has_rule(&a, &format!("R{MAX_EXPANSION_DEPTH}")));
        },
    );
}

#[test]
fn a_branching_recursive_macro_ends_quickly() {
    bounded(HEAP, "a_branching_recursive_macro_ends_quickly", BOUND_MIB, BOUND_SECS, || {
        let src = "startshape A\n@macro R(a)\n@expand R(a)\n@expand R(a)\nVERTEX {x a}\n@endmacro\nrule A { VERTEX {} @expand R(1) }\n";
        let t0 = Instant::now();
        let a = analyze_mem(src);
        eprintln!("took {:?}", t0.elapsed()); // `bounded` is the hang guard
        assert_eq!(messages(&a, "E0208"), ["expansion of macro `R` nests too deeply"]);
        assert!(a.expanded.expansions.len() <= MAX_EXPANSIONS);
        assert!(has_rule(&a, "A"));
    });
}

#[test]
fn a_macro_whose_arguments_double_at_each_level_ends_quickly() {
    bounded(HEAP, "a_macro_whose_arguments_double_at_each_level_ends_quickly", BOUND_MIB, BOUND_SECS, || {
        // Each level doubles the argument: 2^32 tokens at the depth limit if unchecked.
        let src = "startshape A\n@macro D(a)\n@expand D(a a)\n@endmacro\nrule A { VERTEX {} }\n@expand D(x)\n";
        let t0 = Instant::now();
        let a = analyze_mem(src);
        eprintln!("took {:?}", t0.elapsed()); // `bounded` is the hang guard
        assert_eq!(messages(&a, "E0208"), ["expansion of macro `D` nests too deeply"]);
        let rendered = mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources);
        assert!(rendered.contains(&format!("make {MAX_EXPANDED_TOKENS} tokens in all")), "{rendered}");
        assert!(has_rule(&a, "A"));
    });
}

#[test]
fn ten_thousand_and_one_shallow_expansions_stop_at_the_expansion_count() {
    bounded(HEAP, "ten_thousand_and_one_shallow_expansions_stop_at_the_expansion_count", BOUND_MIB, BOUND_SECS, || {
        // Top-level expansions of a one-rule macro: never deeper than 1, few tokens, so
        // only the count can stop them.
        let mut src = String::from("startshape R0\n@macro M(n)\nrule n { VERTEX {} }\n@endmacro\n");
        for i in 0..=MAX_EXPANSIONS {
            src.push_str(&format!("@expand M(R{i})\n"));
        }
        let t0 = Instant::now();
        let a = analyze_mem(&src);
        eprintln!("took {:?}", t0.elapsed()); // `bounded` is the hang guard
        assert_eq!(messages(&a, "E0208"), ["expansion of macro `M` nests too deeply"]);
        assert_eq!(a.expanded.expansions.len(), MAX_EXPANSIONS);
        for i in [0, 1, MAX_EXPANSIONS / 2, MAX_EXPANSIONS - 1] {
            assert!(has_rule(&a, &format!("R{i}")), "rule R{i} from expansion {i} is kept");
        }
        assert!(!has_rule(&a, &format!("R{MAX_EXPANSIONS}")), "expansion 10,001 is not made");
    });
}

// --------------------------------------------------------------------- imports

#[test]
fn self_importing_files_and_cycles_are_reported_and_their_rules_kept() {
    bounded(HEAP, "self_importing_files_and_cycles_are_reported_and_their_rules_kept", BOUND_MIB, BOUND_SECS, || {
        let dir = scratch("self_import");
        std::fs::write(dir.join("main.mdg"), "@import self.mdg\n@import a.mdg\nstartshape A\nrule A { S {} B {} }\n")
            .expect("write");
        std::fs::write(dir.join("self.mdg"), "@import self.mdg\nrule S { VERTEX {} }\n").expect("write");
        std::fs::write(dir.join("a.mdg"), "@import b.mdg\nrule AA { VERTEX {} }\n").expect("write");
        std::fs::write(dir.join("b.mdg"), "@import a.mdg\n@import main.mdg\nrule B { AA {} }\n").expect("write");
        let a = mdg_compiler::driver::analyze(
            &FsLoader,
            &dir.join("main.mdg"),
            &Options::default(),
            CheckOptions { require_start: true },
        );
        let cycles = messages(&a, "E0203");
        assert_eq!(
            cycles,
            [
                "`self.mdg` imports itself (an import cycle)",
                "`a.mdg` imports itself (an import cycle)",
                "`main.mdg` imports itself (an import cycle)"
            ],
            "{}",
            mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources)
        );
        for r in ["A", "S", "AA", "B"] {
            assert!(has_rule(&a, r), "rule {r} is kept");
        }
        assert_eq!(a.sources.files.len(), 4, "each file is read once");
    });
}

/// Writes `c0.mdg … c{n-1}.mdg` in `dir`, each importing the next and defining
/// `rule C{i}`, and `main.mdg` importing `c0.mdg`.
fn import_chain(dir: &Path, n: usize) {
    for i in 0..n {
        let next = if i + 1 < n { format!("@import c{}.mdg\n", i + 1) } else { String::new() };
        std::fs::write(dir.join(format!("c{i}.mdg")), format!("{next}rule C{i} {{ VERTEX {{}} }}\n")).expect("write");
    }
    std::fs::write(dir.join("main.mdg"), "@import c0.mdg\nstartshape A\nrule A { C0 {} }\n").expect("write");
}

#[test]
fn a_chain_of_a_thousand_imports_stops_at_the_import_depth_on_a_small_stack() {
    bounded(
        HEAP,
        "a_chain_of_a_thousand_imports_stops_at_the_import_depth_on_a_small_stack",
        BOUND_MIB,
        BOUND_SECS,
        || {
            // 1,000 chained files overflowed the language server's 2 MiB stack (5,000 the
            // compiler's main thread): the chain stops at MAX_IMPORT_DEPTH with E0212.
            let dir = scratch("import_chain");
            import_chain(&dir, 1000);
            let main = dir.join("main.mdg");
            let t0 = Instant::now();
            let a = on_small_stack(move || {
                mdg_compiler::driver::analyze(
                    &FsLoader,
                    &main,
                    &Options::default(),
                    CheckOptions { require_start: true },
                )
            });
            assert!(t0.elapsed() < Duration::from_secs(30), "took {:?}", t0.elapsed());
            let depth = mdg_compiler::expand::MAX_IMPORT_DEPTH;
            // main.mdg and c0 … c{depth-2} fill the chain; c{depth-1} is refused.
            assert_eq!(
                messages(&a, "E0212"),
                [format!(
                    "imports nest too deeply: `c{}.mdg` would be file {} of one import chain",
                    depth - 1,
                    depth + 1
                )]
            );
            assert_eq!(codes(&a).iter().filter(|c| c.starts_with('E')).count(), 1, "{:?}", codes(&a));
            for i in 0..depth - 1 {
                assert!(has_rule(&a, &format!("C{i}")), "rule C{i} of a file within the limit is kept");
            }
            assert!(!has_rule(&a, &format!("C{}", depth - 1)));
            assert_eq!(a.sources.files.len(), depth, "nothing past the limit is read");
        },
    );
}

#[test]
fn many_files_imported_from_one_file_are_not_a_chain() {
    bounded(HEAP, "many_files_imported_from_one_file_are_not_a_chain", BOUND_MIB, BOUND_SECS, || {
        let dir = scratch("import_flat");
        let n = 100;
        assert!(n > mdg_compiler::expand::MAX_IMPORT_DEPTH);
        let mut main = String::new();
        for i in 0..n {
            std::fs::write(dir.join(format!("f{i}.mdg")), format!("rule F{i} {{ VERTEX {{}} }}\n")).expect("write");
            main.push_str(&format!("@import f{i}.mdg\n"));
        }
        main.push_str("startshape A\nrule A { F0 {} }\n");
        std::fs::write(dir.join("main.mdg"), main).expect("write");
        let a = mdg_compiler::driver::analyze(
            &FsLoader,
            &dir.join("main.mdg"),
            &Options::default(),
            CheckOptions { require_start: true },
        );
        assert!(!codes(&a).contains(&"E0212"), "{:?}", messages(&a, "E0212"));
        assert!(!a.diagnostics.iter().any(|d| d.is_error()), "{:?}", codes(&a));
        for i in 0..n {
            assert!(has_rule(&a, &format!("F{i}")), "rule F{i} is kept");
        }
        assert_eq!(a.sources.files.len(), n + 1);
    });
}

#[test]
fn a_chain_of_imports_at_the_limit_compiles_on_a_small_stack() {
    bounded(HEAP, "a_chain_of_imports_at_the_limit_compiles_on_a_small_stack", BOUND_MIB, BOUND_SECS, || {
        let dir = scratch("import_chain_ok");
        let depth = mdg_compiler::expand::MAX_IMPORT_DEPTH;
        import_chain(&dir, depth - 1);
        let main = dir.join("main.mdg");
        let a = on_small_stack(move || {
            mdg_compiler::driver::analyze(&FsLoader, &main, &Options::default(), CheckOptions { require_start: true })
        });
        assert!(!a.diagnostics.iter().any(|d| d.is_error()), "{:?}", codes(&a));
        assert!(has_rule(&a, &format!("C{}", depth - 2)));
    });
}

#[test]
fn imports_cannot_leave_the_project_or_std_even_through_symlinks() {
    bounded(HEAP, "imports_cannot_leave_the_project_or_std_even_through_symlinks", BOUND_MIB, BOUND_SECS, || {
        let dir = scratch("containment");
        let proj = dir.join("proj");
        let std_dir = dir.join("std");
        let outside = dir.join("outside");
        for d in [&proj, &std_dir, &outside, &proj.join("lib")] {
            std::fs::create_dir_all(d).expect("mkdir");
        }
        std::fs::write(outside.join("secret.mdg"), "rule SECRET { VERTEX {} }\n").expect("write");
        std::fs::write(proj.join("lib/ok.mdg"), "rule OK { VERTEX {} }\n").expect("write");
        std::fs::write(std_dir.join("prims.mdg"), "rule PRIM { VERTEX {} }\n").expect("write");
        // Links: a directory and a file inside the project pointing out, a link inside
        // pointing in (allowed), and a std link pointing out.
        std::os::unix::fs::symlink(&outside, proj.join("escape")).expect("symlink");
        std::os::unix::fs::symlink(outside.join("secret.mdg"), proj.join("lib/secret.mdg")).expect("symlink");
        std::os::unix::fs::symlink(proj.join("lib/ok.mdg"), proj.join("alias.mdg")).expect("symlink");
        std::os::unix::fs::symlink(outside.join("secret.mdg"), std_dir.join("evil.mdg")).expect("symlink");
        let main = proj.join("main.mdg");
        std::fs::write(
            &main,
            format!(
                "@import ../outside/secret.mdg\n@import escape/secret.mdg\n@import lib/secret.mdg\n\
                 @import {}\n@import evil\n@import alias.mdg\n@import prims\nstartshape A\nrule A {{ OK {{}} PRIM {{}} }}\n",
                outside.join("secret.mdg").display()
            ),
        )
        .expect("write");
        let opts = Options { std_dir: Some(std_dir.clone()), ..Options::default() };
        let a = mdg_compiler::driver::analyze(&FsLoader, &main, &opts, CheckOptions { require_start: true });
        let escaped: Vec<String> = messages(&a, "E0202");
        let abs = outside.join("secret.mdg").display().to_string();
        assert_eq!(
            escaped,
            [
                "`../outside/secret.mdg` is outside the project and the std library".to_string(),
                "`escape/secret.mdg` is outside the project and the std library".to_string(),
                "`lib/secret.mdg` is outside the project and the std library".to_string(),
                format!("`{abs}` is outside the project and the std library"),
                "`evil` is outside the project and the std library".to_string(),
            ]
        );
        assert!(!has_rule(&a, "SECRET"), "nothing outside was read");
        assert!(a.sources.files.iter().all(|f| !f.text.contains("SECRET")));
        assert!(has_rule(&a, "OK") && has_rule(&a, "PRIM") && has_rule(&a, "A"), "contained imports work");
    });
}

// ---------------------------------------------------------------- superlinear inputs (issue 35)

/// A bound for the inputs below: linear work takes well under a second each; the
/// quadratic behaviour they guard against took 22 to over 60 s.
const LINEAR_SECS: u64 = 30;

#[test]
fn a_call_with_a_million_adjustments_checks_in_linear_memory() {
    // 4 MB of source. 3,000,000 adjustments used to take 2.1 GB and 22 s in `mdgc
    // check`; a million took 581 MiB of heap (145 bytes per source byte), now 360
    // MiB (94; the bound leaves room for noise). Mature compilers manage ~30 bytes per source byte: the AST's
    // adjustment (name and number texts as `String`s, arguments in a `Vec`) is what
    // stands between (docs/limits.md).
    let n = 1_000_000;
    let mut text = String::from("startshape A\nrule A { B {");
    for _ in 0..n {
        text.push_str("x 1 ");
    }
    text.push_str("} }\nrule B { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
    let bytes = text.len();
    bounded(HEAP, "a_call_with_a_million_adjustments", (120 * bytes) >> 20, LINEAR_SECS, move || {
        let a = analyze_mem(&text);
        assert!(!a.has_errors(), "{:?}", codes(&a));
    });
}

#[test]
fn a_rule_with_100000_parameters_checks_in_linear_time() {
    // E0321's check for a repeated name scanned every parameter before: 108 s in a
    // debug `mdgc check`, now 2.5 s.
    let n = 100_000;
    let params: Vec<String> = (0..n).map(|i| format!("float p{i} = 0")).collect();
    let text = format!("startshape A\nrule A({}) {{ VERTEX {{x p{}}} }}\n", params.join(", "), n - 1);
    let bytes = text.len();
    bounded(HEAP, "a_rule_with_100000_parameters", (128 * bytes) >> 20, LINEAR_SECS, move || {
        let a = analyze_mem(&text);
        assert!(!a.has_errors(), "{:?}", &a.diagnostics.iter().take(3).map(|d| &d.message).collect::<Vec<_>>());
    });
}

#[test]
fn a_chain_of_80000_distinct_rules_compiles_and_evaluates_in_linear_time() {
    // Each rule draws a triangle, so each is a prototype: lowering moved every
    // source-map entry for every rule, and the evaluator looked a prototype's rule
    // up by a walk over all rules (40,000 rules: 12.5 s to build, 7 s to evaluate;
    // now under 5 s and 0.1 s).
    bounded(HEAP, "a_chain_of_80000_distinct_rules", 2 * BOUND_MIB, BOUND_SECS, || {
        let n = 80_000;
        let mut text = String::from("startshape r0\n");
        for i in 0..n {
            text.push_str(&format!("rule r{i} {{ VERTEX {{}} VERTEX {{y 1}} VERTEX {{x 1}} r{} {{x 1}} }}\n", i + 1));
        }
        text.push_str(&format!("rule r{n} {{ VERTEX {{}} }}\n"));
        let b = build_source(&text);
        let out = evaluate(&b, &EvalOptions::default());
        assert_eq!(out.stats.rule_calls, n as u64);
        assert_eq!(out.stats.triangles, n as u64);
    });
}

// ------------------------------------------- terminal control text and Trojan Source

/// Whether rendered text holds a character a terminal may act on: a C0 control
/// other than newline, DEL, a C1 control, or a bidirectional control.
fn has_raw_control(text: &str) -> Option<char> {
    text.chars().find(|&c| {
        (c.is_control() && c != '\n')
            || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}' | '\u{2028}' | '\u{2029}')
    })
}

/// A grammar written to take over the terminal of whoever checks it: an OSC that
/// retitles the window (`ESC ] 0 ; … BEL`), `ESC [2J` (clear screen), a C1 CSI
/// (`U+009B`) colour change and DEL in a comment before an error, in a file whose name
/// holds `ESC [2J` too. The rendered diagnostic shows them escaped, and the caret
/// still points at the error.
#[test]
fn diagnostics_escape_terminal_control_sequences_in_lines_and_file_names() {
    bounded(
        HEAP,
        "diagnostics_escape_terminal_control_sequences_in_lines_and_file_names",
        BOUND_MIB,
        BOUND_SECS,
        || {
            let line = "rule A { VERTEX {} } /* \u{1b}]0;pwned\u{7} \u{1b}[2J \u{9b}31m \u{7f} */ %";
            let text = format!("startshape A\n{line}\n");
            let a = analyze_text(
                &MemLoader::default(),
                Path::new("/hostile/ev\u{1b}[2Jil.mdg"),
                &text,
                &Options::default(),
                CheckOptions { require_start: true },
            );
            assert!(!a.diagnostics.is_empty());
            let shown = mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources);
            assert_eq!(has_raw_control(&shown), None, "{shown:?}");
            assert!(shown.contains(r"/* \u{1b}]0;pwned\u{7} \u{1b}[2J \u{9b}31m \u{7f} */ %"), "{shown}");
            assert!(shown.contains(r"ev\u{1b}[2Jil.mdg:2:"), "the file name is escaped too: {shown}");
            // The caret stands under the `%` of the escaped line.
            let lines: Vec<&str> = shown.lines().collect();
            let at = lines.iter().position(|l| l.contains("pwned")).expect("the source line");
            let col = lines[at].find('%').expect("% in the shown line");
            assert_eq!(lines[at + 1].find('^'), Some(col), "{shown}");
        },
    );
}

/// Bidirectional overrides and isolates, and line/paragraph separators, in comments
/// and strings reorder what a reader sees ("Trojan Source"): each comment or string
/// holding one gets a warning naming the code points, at the first one.
#[test]
fn bidirectional_controls_in_comments_and_strings_are_warned_about() {
    bounded(HEAP, "bidirectional_controls_in_comments_and_strings_are_warned_about", BOUND_MIB, BOUND_SECS, || {
        let text = "startshape A\n\
                    // access \u{202e} }nimda{ \u{2066}check\u{2069}\n\
                    rule A { VERTEX {} }\n\
                    /* a\u{2028}b \u{85} */\n\
                    grid g { source \"x\u{202b}.vox\"; }\n\
                    // clean comment\n";
        let a = analyze_mem(text);
        let bidi: Vec<_> = a.diagnostics.iter().filter(|d| d.code == "W0014").collect();
        assert_eq!(bidi.len(), 3, "{}", mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources));
        assert!(bidi.iter().all(|d| !d.is_error()));
        let first = bidi.iter().find(|d| d.message.contains("U+202E")).expect("the line comment");
        assert!(first.message.contains("U+2066") && first.message.contains("U+2069"), "{}", first.message);
        assert_eq!(&text[first.span.range()], "\u{202e}", "the span is the first code point");
        assert!(bidi.iter().any(|d| d.message.contains("U+2028") && d.message.contains("U+0085")));
        assert!(bidi.iter().any(|d| d.message.contains("U+202B")));
        let shown = mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources);
        assert_eq!(has_raw_control(&shown), None, "the snippet shows them escaped: {shown:?}");
        assert!(shown.contains(r"\u{202e}"), "{shown}");
    });
}
