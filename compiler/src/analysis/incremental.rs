//! Incremental analysis gives what a whole analysis gives (issue 39): seeded random
//! edits of the std examples and of a large generated grammar — fragments whole and
//! broken, typing one character at a time and deleting again, comments opened and
//! closed, renamed colour components, and undone now and then — each analysed from
//! the previous version's
//! analysis and from nothing, compared after every edit: the lexing, the parsed tree, the
//! expanded program, every diagnostic, the checker's symbol table (rules,
//! signatures, references …) and the editor's occurrence index (what hovers,
//! references, rename, lenses and hints read).

use super::fixture::std_dir;
use super::robustness::FRAGMENTS;
use super::Document;
use crate::check::CheckOptions;
use crate::driver::{analyze_text_with, Analysis, Effort};
use crate::expand::Options;
use crate::source::MemLoader;
use mdg_vm::rng::Rng;
use std::path::Path;

/// More fragments: what makes the parse of an edited item reach into the rest.
const MORE: &[&str] = &[
    "rule r5 {",
    "rule q {x 1}\n",
    "}\n",
    "/*\n",
    "*/\n",
    "color red green blue alpha\n",
    "startshape ",
    "@endmacro\n",
    "namespace m {\n",
    "\"",
    "r5 {y 2 rz 15}\n",
    "{{{",
    ")]}",
];

fn analyse(text: &str, opts: &Options, previous: Option<&Analysis>) -> Analysis {
    let loader = MemLoader { files: Default::default(), disk_fallback: true };
    let effort = Effort { skip_shaders: true, previous, record: true, ..Effort::default() };
    analyze_text_with(&loader, Path::new("/test/main.mdg"), text, opts, CheckOptions::default(), effort)
        .unwrap_or_else(|| panic!("an analysis that cannot be cancelled was cancelled"))
}

/// The checker's symbol table as text (it has no `PartialEq`): every table.
fn symbols(a: &Analysis) -> String {
    let s = &a.checked.symbols;
    format!(
        "rules {:?}\nfunctions {:?}\nisosurfaces {:?}\nnamespaces {:?}\nselectors {:?}\nstart {:?}\n\
         components {:?}\nreferences {:?}\nsignatures {:?}",
        s.rules,
        s.functions,
        s.isosurfaces,
        s.namespaces,
        s.selectors,
        s.startshape,
        s.components,
        s.references,
        s.signatures
    )
}

/// The expanded program besides its items, as text.
fn program(a: &Analysis) -> String {
    let e = &a.expanded;
    format!(
        "shaders {:?}\nparams {:?}\ndefines {:?}\npresets {:?}\nexpansions {:?}\nfiles {:?}",
        e.shaders, e.params, e.defines, e.presets, e.expansions, e.files
    )
}

/// Compares an incremental analysis with a whole one: everything the editor's
/// features read. Returns the incremental one.
fn same(inc: Analysis, whole: Analysis, context: &dyn Fn() -> String) -> Analysis {
    // The lexing the next version starts from (`lexer::relex`): tokens, comments, diagnostics.
    let (il, wl) = (&inc.expanded.main_memo.lexed, &whole.expanded.main_memo.lexed);
    assert!(wl.is_some(), "a whole analysis recorded no lexing: {}", context());
    assert_eq!(il, wl, "the lexing differs: {}", context());
    assert_eq!(inc.expanded.main_ast, whole.expanded.main_ast, "parsed tree differs: {}", context());
    assert_eq!(inc.expanded.items, whole.expanded.items, "expanded items differ: {}", context());
    assert_eq!(program(&inc), program(&whole), "expanded program differs: {}", context());
    assert_eq!(inc.diagnostics, whole.diagnostics, "diagnostics differ: {}", context());
    assert_eq!(symbols(&inc), symbols(&whole), "symbols differ: {}", context());
    // The checker's per-rule cache: what each rule contributes, where it is now (a
    // replayed rule's result moved with it), recorded or not alike.
    let rules = |a: &Analysis| -> Vec<Option<crate::check_cache::RuleResult>> {
        let rules = a.expanded.items.iter().filter_map(|i| match &i.item.kind {
            crate::ast::ItemKind::Rule(r) => Some(r),
            _ => None,
        });
        rules.map(|r| a.checked.cache.result(r)).collect()
    };
    assert_eq!(rules(&inc), rules(&whole), "the checker's cached rule results differ: {}", context());
    let (inc, whole) = (Document::from_analysis(inc), Document::from_analysis(whole));
    let (i, w) = (inc.index(), whole.index());
    assert_eq!(i.main, w.main, "occurrences differ: {}", context());
    assert_eq!(i.symbols, w.symbols, "symbol occurrences differ: {}", context());
    assert_eq!(i.calls, w.calls, "call sites differ: {}", context());
    inc.analysis
}

/// A char boundary of `text` near a random place (at a line start one time in three).
fn place(rng: &mut Rng, text: &str) -> usize {
    let mut at = rng.below(text.len() + 1);
    while !text.is_char_boundary(at) {
        at -= 1;
    }
    if rng.below(3) == 0 {
        at = text[..at].rfind('\n').map_or(0, |i| i + 1);
    }
    at
}

/// The versions of one random edit: a fragment inserted, a range deleted, or a
/// fragment typed in one character at a time (each keystroke a version).
fn edits(rng: &mut Rng, text: &str) -> Vec<String> {
    let at = place(rng, text);
    match rng.below(4) {
        0 if !text.is_empty() => {
            let mut end = (at + 1 + rng.below(40)).min(text.len());
            while !text.is_char_boundary(end) {
                end += 1;
            }
            let mut t = text.to_string();
            t.replace_range(at..end, "");
            vec![t]
        }
        1 => typing(rng, text, at),
        _ => {
            let all = FRAGMENTS.len() + MORE.len();
            let k = rng.below(all);
            let frag = if k < FRAGMENTS.len() { FRAGMENTS[k] } else { MORE[k - FRAGMENTS.len()] };
            let mut t = text.to_string();
            t.insert_str(at, frag);
            vec![t]
        }
    }
}

/// A fragment typed in at `at` one character at a time, then deleted one at a time
/// (each keystroke a version).
fn typing(rng: &mut Rng, text: &str, at: usize) -> Vec<String> {
    let frag = MORE[rng.below(MORE.len())];
    let mut out: Vec<String> = Vec::new();
    let mut t = text.to_string();
    for (i, c) in frag.char_indices() {
        t.insert(at + i, c);
        out.push(t.clone());
    }
    for (i, _) in frag.char_indices().rev() {
        t.remove(at + i);
        out.push(t.clone());
    }
    out
}

/// A grammar of about `lines` lines of many kinds of items.
fn big(lines: usize) -> String {
    let mut s = String::from("startshape r0\nmaxdepth 12\n@import primitives\nselector r1 random\n");
    s.push_str("isosurface BLOB { xyz -1 1 8 ; function { x*x + y*y + z*z - 1 } }\n");
    s.push_str("@macro TRI(a)\n  VERTEX {x a} VERTEX {y a} VERTEX {z a}\n@endmacro\n");
    s.push_str("function wave(t) { sin(t * 2) }\n");
    let n = lines / 7;
    for i in 0..n {
        let next = (i + 1) % n;
        match i % 5 {
            0 => s.push_str(&format!(
                "rule r{i} {{\n  VERTEX {{x 1}} VERTEX {{y 1}} VERTEX {{z 1 R -0.1}}\n  r{next} {{x 1 rz 10 s 0.9}}\n  30/30 * [ry 360] cube {{s 0.1}}\n}}\n\n"
            )),
            1 => s.push_str(&format!(
                "// rule {i}\nrule r{i} 0.5 {{\n  @expand TRI(2)\n  r{next} [y (wave(3)) rx 45d x (let(a = 1; if(a > 0, a * 2, 0)))]\n}}\n\n"
            )),
            2 => s.push_str(&format!(
                "namespace n{i} {{\n  rule leaf {{ r{next} {{s 0.5}} }}\n}}\nrule r{i} {{ n{i}.leaf {{}} }}\n\n"
            )),
            3 => s.push_str(&format!(
                "rule r{i}(int k = 3) {{\n  if (k > 0) {{ r{next} {{x 1}} }}\n  loop j = 0, k {{rz 30}} cube {{}}\n}}\n\n"
            )),
            _ => s.push_str(&format!("/* block\n comment */\nrule r{i} {{ r{next} {{z 1}} BLOB {{}} }}\n\n")),
        }
    }
    s
}

/// Counts over a run of random edits: items reused and parsed, rules replayed and
/// checked.
#[derive(Default)]
struct Counts {
    reused: usize,
    parsed: usize,
    replayed: usize,
    checked: usize,
}

/// Runs `steps` random edits from `text`, comparing after each.
fn compare(name: &str, mut text: String, steps: usize, rng: &mut Rng, opts: &Options, typing_only: bool) -> Counts {
    let mut prev = analyse(&text, opts, None);
    let mut n = Counts::default();
    let original = text.clone();
    let mut step = 0;
    while step < steps {
        // Undo now and then (back to the original text), as errors get mended: else
        // the random errors pile up and most items parse with one.
        let versions = if typing_only {
            let at = place(rng, &text);
            typing(rng, &text, at)
        } else if rng.below(4) == 0 {
            vec![original.clone()]
        } else {
            edits(rng, &text)
        };
        for version in versions {
            step += 1;
            let whole = analyse(&version, opts, None);
            let inc = analyse(&version, opts, Some(&prev));
            let context = || format!("{name}, edit {step}: the text was\n{text}\n---- and is now\n{version}");
            n.reused += inc.expanded.reused.items;
            n.parsed += inc.expanded.reused.parsed;
            n.replayed += inc.checked.cache.replayed;
            n.checked += inc.checked.cache.checked;
            prev = same(inc, whole, &context);
            text = version;
        }
    }
    n
}

#[test]
fn incremental_analysis_equals_a_whole_analysis_after_every_random_edit() {
    let opts = Options { std_dir: Some(std_dir()), ..Options::default() };
    let mut rng = Rng(0x39_1ec5_eed5);
    let dir = std_dir().join("examples");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .expect("std/examples")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "mdg"))
        .collect();
    names.sort();
    assert!(names.len() >= 20, "std examples missing: {names:?}");
    let mut ex = Counts::default();
    for path in &names {
        let text = std::fs::read_to_string(path).expect("example");
        let c = compare(&path.display().to_string(), text, 40, &mut rng, &opts, false);
        ex.reused += c.reused;
        ex.parsed += c.parsed;
        ex.replayed += c.replayed;
        ex.checked += c.checked;
    }
    // (Their own stream: the edits to the large grammar do not change when a std
    // example is added.)
    let mut rng = Rng(0x39_1ec5_eed5);
    let big_ = compare("a 1,400-line grammar", big(1_400), 100, &mut rng, &opts, false);
    let ty = compare("typing into a 1,400-line grammar", big(1_400), 100, &mut rng, &opts, true);
    eprintln!(
        "items reused / parsed: std examples {} / {}; a large grammar {} / {}; typing into it {} / {}",
        ex.reused, ex.parsed, big_.reused, big_.parsed, ty.reused, ty.parsed
    );
    eprintln!(
        "rules replayed / checked: std examples {} / {}; a large grammar {} / {}; typing into it {} / {}",
        ex.replayed, ex.checked, big_.replayed, big_.checked, ty.replayed, ty.checked
    );
    // The comparisons mean something only if items were reused: most of them while
    // typing into a file without other syntax errors. (Random edits leave syntax
    // errors behind, and a parse reuses only the items before the first and after the
    // last segment with an error or an edit.)
    assert!(ty.reused > 10 * ty.parsed, "typing reused {} items and parsed {}", ty.reused, ty.parsed);
    assert!(big_.reused > big_.parsed / 2 && ex.reused > ex.parsed / 8, "random edits reused too little");
    // And only if rules were replayed: most of them while typing (a version whose
    // rule names or signatures changed, a rule with `@expand` — expanded again — or
    // one whose diagnostics point outside it is checked again).
    assert!(ty.replayed > 2 * ty.checked, "typing replayed {} rules and checked {}", ty.replayed, ty.checked);
    assert!(ex.replayed > 0 && big_.replayed > 0, "random edits replayed no rule");
}

/// Rules whose diagnostics point outside them (E0320's first definition, the
/// "add `@import`" fix at the top of the file), after and before an edit typed
/// into another rule: the secondary spans and fixes stay where they point, so such
/// rules are checked again, not replayed.
#[test]
fn rules_whose_diagnostics_point_elsewhere_are_checked_again() {
    let opts = Options { std_dir: Some(std_dir()), ..Options::default() };
    // The edit goes into `b`; the rule after it, `f`, is parsed again (the parse
    // reuse's guard); those after `f` are the previous version's, moved.
    let texts = [
        // The first definition before the edit, the second (other parameters) after it.
        "startshape a\nrule a(int n) { b {} f {} }\nrule b { }\nrule f { }\nrule a(float m) { b {} }\n",
        // A std name called without its import, after the edit; and before it.
        "startshape a\nrule a { b {} f {} c {} }\nrule b { }\nrule f { }\nrule c { SPHERE {} }\n",
        "startshape c\nrule c { SPHERE {} b {} f {} }\nrule b { }\nrule f { }\n",
    ];
    for text in texts {
        let at = text.find("rule b { }").expect("rule b") + "rule b {".len();
        let mut prev = analyse(text, &opts, None);
        let mut t = text.to_string();
        for (i, c) in "  x {}".char_indices() {
            t.insert(at + i, c);
            let whole = analyse(&t, &opts, None);
            let inc = analyse(&t, &opts, Some(&prev));
            assert!(whole.diagnostics.iter().any(|d| d.code == "E0320" || d.code == "E0301"), "{t}");
            let context = || format!("the text is now\n{t}");
            prev = same(inc, whole, &context);
        }
    }
}
