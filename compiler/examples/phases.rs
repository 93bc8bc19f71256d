//! Times the phases of one analysis of the language server's typing benchmark
//! grammar (10,600 lines): lex, parse, expand, check, assemble, drop. A measuring
//! aid for issue 39 (`cargo run --release -p mdg-compiler --example phases`).

use mdg_compiler::benchmark::grammar;
use mdg_compiler::check::CheckOptions;
use mdg_compiler::source::{MemLoader, Sources};
use std::path::Path;
use std::time::Instant;

fn med(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let src = grammar(10_600);
    let std_dir = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../std"));
    let opts = mdg_compiler::expand::Options { std_dir: Some(std_dir), ..Default::default() };
    let loader = MemLoader { files: Default::default(), disk_fallback: true };
    let path = Path::new("/bench/big.mdg");
    let (mut lex, mut parse, mut expand, mut check, mut full, mut drop) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    let first = if std::env::var("PHASES_REPARSE_ONLY").is_ok() { 0 } else { 15 };
    for _ in 0..first {
        let t = Instant::now();
        let l = mdg_compiler::lexer::lex(&src, mdg_compiler::span::FileId(0));
        lex.push(t.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(l);
        let mut sources = Sources::default();
        let id = sources.add(path, "big".to_string(), &src);
        let t = Instant::now();
        let p = mdg_compiler::parse::parse_file(&sources, id);
        parse.push(t.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(p);
        let t = Instant::now();
        let ex = mdg_compiler::expand::expand_file(&mut sources, &loader, id, &opts);
        expand.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let c = mdg_compiler::check::check(&ex, CheckOptions::default());
        check.push(t.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(c);
        let t = Instant::now();
        let a = mdg_compiler::driver::analyze_text(&loader, path, &src, &opts, CheckOptions::default());
        full.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        std::mem::drop(a);
        drop.push(t.elapsed().as_secs_f64() * 1e3);
    }
    // One character typed into the middle rule: the parse reusing the previous one.
    let anchor = format!("  r{} {{x 1 rz 10 s 0.9}}\n", 10_600 / 12 + 1);
    let at = src.find(&anchor).unwrap_or(0) + anchor.len();
    let mut edited = src.clone();
    edited.insert_str(at, "  r5 {y");
    let (mut reparse, mut clone_items, mut whole_edited) = (vec![], vec![], vec![]);
    let mut sources = Sources::default();
    let id = sources.add(path, "big".to_string(), &src);
    let (prev_parsed, prev_memo, _) = mdg_compiler::parse::parse_file_reusing(&sources, id, None);
    // `PHASES_TYPING=1`: the typing benchmark's edits analysed in this process, each
    // version from nothing and from the previous version's analysis, interleaved.
    if std::env::var("PHASES_TYPING").is_ok() {
        let typed = "  r5 {y 2 rz 15}\n";
        let mut versions = Vec::new();
        let mut t = src.clone();
        for (i, c) in typed.char_indices() {
            t.insert(at + i, c);
            versions.push(t.clone());
        }
        for i in (0..typed.len()).rev() {
            t.remove(at + i);
            versions.push(t.clone());
        }
        let run = |text: &str, previous: Option<&mdg_compiler::driver::Analysis>, chain: bool| {
            // The whole analyses record nothing for a next version (the language
            // server's `MDG_LSP_WHOLE_PARSE=1`); the chain of reusing ones does.
            let record = previous.is_some() || chain;
            let effort = mdg_compiler::driver::Effort { skip_shaders: true, previous, record, ..Default::default() };
            mdg_compiler::driver::analyze_text_with(&loader, path, text, &opts, CheckOptions::default(), effort)
        };
        // This thread's CPU time in ms (utime + stime of /proc/thread-self/stat, 10 ms ticks).
        let cpu = || -> f64 {
            let stat = std::fs::read_to_string("/proc/thread-self/stat").unwrap_or_default();
            let rest = stat.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
            let f: Vec<&str> = rest.split_whitespace().collect();
            let n = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
            (n(11) + n(12)) * 10.0
        };
        let (mut whole_cpu, mut reusing_cpu) = (0.0, 0.0);
        let (mut whole, mut reusing) = (0.0, 0.0);
        // `PHASES_TYPING=reusing`: only the analyses from the previous version (for a
        // profiler, whose counts are then those of the incremental path alone).
        let only_reusing = std::env::var("PHASES_TYPING").is_ok_and(|v| v == "reusing");
        let mut prev = run(&src, None, true);
        let (mut replayed, mut checked) = (0, 0);
        for v in &versions {
            let (t0, c0) = (Instant::now(), cpu());
            if !only_reusing {
                let a = run(v, None, false);
                std::mem::drop(a);
            }
            whole += t0.elapsed().as_secs_f64() * 1e3;
            whole_cpu += cpu() - c0;
            let (t0, c0) = (Instant::now(), cpu());
            // One version from the previous one, the previous one dropped: a
            // function of its own, for `valgrind --tool=callgrind
            // --collect-atstart=no --toggle-collect='*typing_step*'`.
            #[inline(never)]
            fn typing_step<A>(step: impl FnOnce() -> A) -> A {
                step()
            }
            prev = typing_step(|| {
                let a = run(v, prev.as_ref(), true);
                std::mem::drop(prev);
                a
            });
            if let Some(a) = &prev {
                replayed += a.checked.cache.replayed;
                checked += a.checked.cache.checked;
            }
            reusing += t0.elapsed().as_secs_f64() * 1e3;
            reusing_cpu += cpu() - c0;
        }
        let n = versions.len() as f64;
        println!(
            "typing, {n} versions (analysis and drop): parsed whole {:.1} ms wall, {:.1} ms CPU per version; reusing {:.1} ms wall, {:.1} ms CPU",
            whole / n,
            whole_cpu / n,
            reusing / n,
            reusing_cpu / n
        );
        println!("rules the reusing analyses replayed / checked: {replayed} / {checked}");
        return;
    }
    // `PHASES_REPARSE_ONLY=N`: only the parse reusing the previous, N times (for a profiler).
    if let Some(n) = std::env::var("PHASES_REPARSE_ONLY").ok().and_then(|v| v.parse::<usize>().ok()) {
        let mut s2 = Sources::default();
        let id2 = s2.add(path, "big".to_string(), &edited);
        let prev = mdg_compiler::parse::Previous { text: &src, items: &prev_parsed.file.items, memo: &prev_memo };
        let t = Instant::now();
        for _ in 0..n {
            std::hint::black_box(mdg_compiler::parse::parse_file_reusing(&s2, id2, Some(prev)));
        }
        println!("parse reusing the previous: {:.2} ms each", t.elapsed().as_secs_f64() * 1e3 / n as f64);
        return;
    }
    for _ in 0..15 {
        let mut s2 = Sources::default();
        let id2 = s2.add(path, "big".to_string(), &edited);
        let prev = mdg_compiler::parse::Previous { text: &src, items: &prev_parsed.file.items, memo: &prev_memo };
        let t = Instant::now();
        let (p, _, reused) = mdg_compiler::parse::parse_file_reusing(&s2, id2, Some(prev));
        reparse.push(t.elapsed().as_secs_f64() * 1e3);
        assert!(reused.parsed < 10, "{reused:?}");
        let t = Instant::now();
        let c = p.file.items.clone();
        clone_items.push(t.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(c);
        let t = Instant::now();
        let w = mdg_compiler::parse::parse_file(&s2, id2);
        whole_edited.push(t.elapsed().as_secs_f64() * 1e3);
        assert_eq!(w.file, p.file);
    }
    println!(
        "after a 7-character edit: whole parse {:.2} ms, parse reusing the previous {:.2} ms; a clone of the items {:.2} ms",
        med(&mut whole_edited), med(&mut reparse), med(&mut clone_items)
    );
    if first == 0 {
        lex.push(0.0);
        parse.push(0.0);
        expand.push(0.0);
        check.push(0.0);
        full.push(0.0);
        drop.push(0.0);
    }
    println!(
        "medians (ms): lex {:.2}, parse_file {:.2} (lex included), expand {:.2} (parse included), check {:.2}, analyze_text {:.2}, drop {:.2}",
        med(&mut lex), med(&mut parse), med(&mut expand), med(&mut check), med(&mut full), med(&mut drop)
    );
}
