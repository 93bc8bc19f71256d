//! Tidy: every Rust source file opens with a `//!` line saying what it is.

use mdg_tests::root;

fn rs_files(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else { return };
    for e in rd.flatten() {
        let p = e.path();
        let name = p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        if p.is_dir() {
            if name != "target" && name != "node_modules" && !name.starts_with('.') {
                rs_files(&p, out);
            }
        } else if name.ends_with(".rs") {
            out.push(p);
        }
    }
}

#[test]
fn every_rust_file_starts_with_a_module_doc() {
    let mut files = Vec::new();
    for dir in
        ["compiler", "vm", "export", "guided", "creature", "grid", "lsp", "viewer", "cli", "tests", "fuzz", "benches"]
    {
        rs_files(&root().join(dir), &mut files);
    }
    assert!(files.len() > 20);
    let missing: Vec<String> = files
        .iter()
        .filter(|f| !std::fs::read_to_string(f).unwrap_or_default().starts_with("//!"))
        .map(|f| f.strip_prefix(root()).unwrap_or(f).display().to_string())
        .collect();
    assert!(missing.is_empty(), "files without a leading `//!` line: {missing:?}");
}

/// Lines of Rust code: each line with its `//` comment cut off (strings are not
/// parsed; the checks below look for patterns that do not occur in strings here).
fn code_lines(text: &str) -> Vec<(usize, &str)> {
    text.lines().enumerate().map(|(i, l)| (i + 1, l.split("//").next().unwrap_or(""))).collect()
}

fn workspace_members() -> Vec<String> {
    let manifest = std::fs::read_to_string(root().join("Cargo.toml")).expect("Cargo.toml");
    let line = manifest.lines().find(|l| l.trim_start().starts_with("members")).expect("members");
    line.split('"').skip(1).step_by(2).map(str::to_string).collect()
}

#[test]
fn every_crate_but_the_viewer_denies_unsafe_code() {
    let manifest = std::fs::read_to_string(root().join("Cargo.toml")).expect("Cargo.toml");
    assert!(manifest.contains("[workspace.lints.rust]\nunsafe_code = \"deny\""), "the workspace must deny unsafe_code");
    let members = workspace_members();
    assert!(members.len() >= 5, "{members:?}");
    let mut problems = Vec::new();
    for m in &members {
        let toml = std::fs::read_to_string(root().join(m).join("Cargo.toml")).unwrap_or_default();
        let lints = toml.split("[lints]").nth(1).map(|rest| rest.split("\n[").next().unwrap_or(""));
        if !lints.is_some_and(|l| l.lines().any(|l| l.trim() == "workspace = true")) {
            problems.push(format!("{m}/Cargo.toml does not take the workspace lints (`[lints] workspace = true`)"));
        }
        if m == "viewer" {
            continue;
        }
        let mut files = Vec::new();
        rs_files(&root().join(m), &mut files);
        for f in files {
            let text = std::fs::read_to_string(&f).unwrap_or_default();
            for (n, code) in code_lines(&text) {
                // (A pattern right after a quote is this test's own string.)
                let has = |p: &str| code.contains(p) && !code.contains(&format!("\"{p}"));
                let patterns =
                    ["allow(unsafe_code", "warn(unsafe_code", "unsafe {", "unsafe{", "unsafe fn", "unsafe impl"];
                // The Python crate's one exception is checked by its own test below.
                let python_view =
                    f.ends_with("python/src/lib.rs") && (code.trim() == PYTHON_ALLOW || code.trim() == PYTHON_BLOCK);
                if patterns.iter().any(|p| has(p)) && !python_view {
                    problems.push(format!(
                        "{}:{n}: unsafe outside the viewer",
                        f.strip_prefix(root()).unwrap_or(&f).display()
                    ));
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The lines of the Python crate's exception (split so as not to match the scan).
const PYTHON_ALLOW: &str = concat!("#[allow", "(unsafe_code)]");
const PYTHON_BLOCK: &str = concat!("let array = unsafe", " {");

/// The Python crate's only `unsafe`: `record_view` (numpy views of the evaluator's
/// instance records, the lead's decision in docs/decisions.md), allowed on that
/// function alone, with one `unsafe` block preceded by a `SAFETY:` comment.
#[test]
fn the_python_crate_has_one_unsafe_block_in_record_view() {
    let text = std::fs::read_to_string(root().join("python/src/lib.rs")).unwrap_or_default();
    let lines: Vec<&str> = text.lines().map(|l| l.split("//").next().unwrap_or("").trim()).collect();
    let allows: Vec<usize> = (0..lines.len()).filter(|&i| lines[i] == PYTHON_ALLOW).collect();
    assert_eq!(allows.len(), 1, "python/src/lib.rs: one allow of unsafe code, on record_view");
    assert!(lines[allows[0] + 1].starts_with("fn record_view<"), "the allow is on {}", lines[allows[0] + 1]);
    let blocks: Vec<usize> = (0..lines.len()).filter(|&i| lines[i].contains("unsafe")).collect();
    assert_eq!(blocks.len(), 2, "python/src/lib.rs: the allow and one unsafe block, found lines {blocks:?}");
    let block = blocks[1];
    let raw: Vec<&str> = text.lines().collect();
    let end = (allows[0] + 1..raw.len()).find(|&i| raw[i] == "}").unwrap_or(raw.len());
    assert!(block < end, "the unsafe block is outside record_view");
    let comment: Vec<&str> =
        raw[..block].iter().rev().take_while(|l| l.trim_start().starts_with("//")).copied().collect();
    assert!(comment.iter().any(|c| c.contains("SAFETY:")), "the unsafe block has no `// SAFETY:` comment above it");
}

/// Every `unsafe` block (and `unsafe impl`) in the viewer is preceded by a comment
/// block containing `SAFETY:` — directly above the statement the block is in.
#[test]
fn every_unsafe_block_in_the_viewer_has_a_safety_comment() {
    let mut files = Vec::new();
    rs_files(&root().join("viewer"), &mut files);
    let mut blocks = 0;
    let mut missing = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            let is_block = code.split("unsafe").skip(1).any(|rest| {
                let rest = rest.trim_start();
                rest.starts_with('{') || rest.starts_with("impl")
            }) && !code.contains("\"");
            if !is_block {
                continue;
            }
            blocks += 1;
            // Back to the start of the statement (lines that do not end one).
            let mut j = i;
            while j > 0 {
                let prev = lines[j - 1].trim();
                if prev.is_empty() || prev.starts_with("//") || prev.ends_with([';', '{', '}', ',']) {
                    break;
                }
                j -= 1;
            }
            // The comment block right above it.
            let comment: Vec<&str> =
                lines[..j].iter().rev().take_while(|l| l.trim_start().starts_with("//")).copied().collect();
            if !comment.iter().any(|c| c.contains("SAFETY:")) {
                missing.push(format!("{}:{}: {}", f.strip_prefix(root()).unwrap_or(&f).display(), i + 1, line.trim()));
            }
        }
    }
    assert!(blocks > 50, "only {blocks} unsafe blocks found in the viewer: is the scan broken?");
    assert!(missing.is_empty(), "unsafe blocks without a `// SAFETY:` comment:\n{}", missing.join("\n"));
}

/// Output files are written atomically (temporary file + rename, see
/// `mdg_export::write_atomic`): no other code creates or overwrites files,
/// except in tests.
#[test]
fn files_are_written_only_through_write_atomic() {
    let mut files = Vec::new();
    for dir in
        ["compiler/src", "vm/src", "export/src", "guided/src", "creature/src", "grid/src", "lsp/src", "viewer/src"]
    {
        rs_files(&root().join(dir), &mut files);
    }
    let mut found = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap_or_default();
        // Unit tests (after `#[cfg(test)]`) may write scratch files.
        let text = text.split("#[cfg(test)]").next().unwrap_or("");
        for (n, code) in code_lines(text) {
            if ["fs::write(", "File::create(", "OpenOptions::new("].iter().any(|p| code.contains(p))
                && !f.ends_with("export/src/lib.rs")
                // The bounded reader opens files read-only (checked below).
                && !(f.ends_with("vm/src/input.rs") && code.contains("OpenOptions::new("))
            {
                found.push(format!("{}:{n}: {}", f.strip_prefix(root()).unwrap_or(&f).display(), code.trim()));
            }
        }
    }
    let input = std::fs::read_to_string(root().join("vm/src/input.rs")).unwrap_or_default();
    assert!(input.contains(".read(true)") && !input.contains(".write(") && !input.contains(".create("));
    assert!(found.is_empty(), "files written without write_atomic:\n{}", found.join("\n"));
}

/// The library crates and what each may depend on among the workspace's crates:
/// dependencies point one way (README's code map draws them): the VM at the bottom,
/// the exporters, guided search, creatures and grid grammars on it, the compiler and
/// the viewer above, the CLI on top.
const LIBRARIES: [(&str, &[&str]); 7] = [
    ("vm", &[]),
    ("export", &["mdg-vm"]),
    ("guided", &["mdg-vm"]),
    ("creature", &["mdg-vm", "mdg-export"]),
    ("grid", &["mdg-vm"]),
    ("compiler", &["mdg-vm", "mdg-export", "mdg-creature", "mdg-grid", "mdg-guided"]),
    ("viewer", &["mdg-vm", "mdg-export", "mdg-guided"]),
];

/// Whether `file` is a module its parent declares under `#[cfg(test)]`.
fn is_test_module(file: &std::path::Path) -> bool {
    let Some(stem) = file.file_stem().map(|s| s.to_string_lossy().into_owned()) else { return false };
    let Some(dir) = file.parent() else { return false };
    let parents = [dir.join("mod.rs"), dir.join("lib.rs"), dir.with_extension("rs")];
    parents.iter().any(|p| std::fs::read_to_string(p).is_ok_and(|t| t.contains(&format!("#[cfg(test)]\nmod {stem};"))))
}

/// The libraries do no process work: they print nothing, never exit, draw no
/// progress bars and parse no command lines; the CLI crate (`cli/`) does all of
/// that and passes sinks and callbacks in.
#[test]
fn library_crates_print_nothing_and_never_exit() {
    let mut found = Vec::new();
    for (lib, allowed) in LIBRARIES {
        let toml = std::fs::read_to_string(root().join(lib).join("Cargo.toml")).expect("Cargo.toml");
        let deps = toml.split("[dependencies]").nth(1).map(|r| r.split("\n[").next().unwrap_or("")).unwrap_or("");
        for line in deps.lines() {
            let name = line.split(['=', ' ', '.']).next().unwrap_or("").trim();
            if ["clap", "indicatif"].contains(&name) || (name.starts_with("mdg-") && !allowed.contains(&name)) {
                found.push(format!("{lib}/Cargo.toml depends on {name}"));
            }
        }
        let mut files = Vec::new();
        rs_files(&root().join(lib).join("src"), &mut files);
        for f in files.iter().filter(|f| !is_test_module(f)) {
            let text = std::fs::read_to_string(f).unwrap_or_default();
            let text = text.split("#[cfg(test)]").next().unwrap_or("");
            for (n, code) in code_lines(text) {
                let bad = [
                    "println!(",
                    "print!(",
                    "eprintln!(",
                    "eprint!(",
                    "dbg!(",
                    "process::exit",
                    "ExitCode",
                    "indicatif",
                    "Command::new",
                    "clap::",
                ];
                if let Some(p) = bad.iter().find(|p| code.contains(*p) && !code.contains(&format!("\"{p}"))) {
                    found.push(format!(
                        "{}:{n}: `{p}` in a library crate",
                        f.strip_prefix(root()).unwrap_or(f).display()
                    ));
                }
            }
        }
    }
    assert!(found.is_empty(), "process work outside cli/:\n{}", found.join("\n"));
}

/// The one-way dependencies, as Cargo sees them: no library crate (nor the language
/// server) depends on the CLI, the viewer does not depend on the compiler, the
/// compiler does not depend on the viewer.
#[test]
fn dependencies_point_one_way() {
    let deps_of = |krate: &str| -> Vec<String> {
        let toml = std::fs::read_to_string(root().join(krate).join("Cargo.toml")).expect("Cargo.toml");
        toml.lines()
            .filter(|l| l.trim_start().starts_with("mdg-"))
            .map(|l| l.split([' ', '=']).next().unwrap_or("").trim().to_string())
            .collect()
    };
    let expect: [(&str, &[&str]); 9] = [
        ("vm", &[]),
        ("export", &["mdg-vm"]),
        ("guided", &["mdg-vm"]),
        ("creature", &["mdg-vm", "mdg-export"]),
        ("grid", &["mdg-vm"]),
        ("compiler", &["mdg-vm", "mdg-export", "mdg-creature", "mdg-grid", "mdg-guided"]),
        ("viewer", &["mdg-vm", "mdg-export", "mdg-guided"]),
        // (lsp's dev-dependency on the VM: the shared test generator, `mdg_vm::rng`.)
        ("lsp", &["mdg-compiler", "mdg-vm", "mdg-export"]),
        ("cli", &["mdg-compiler", "mdg-vm", "mdg-export", "mdg-creature", "mdg-grid", "mdg-guided", "mdg-viewer"]),
    ];
    for (krate, want) in expect {
        let got = deps_of(krate);
        assert_eq!(got, want, "{krate}/Cargo.toml: workspace dependencies (normal and dev) {got:?}, want {want:?}");
    }
}

/// The top-level module a `.rs` file of `src` belongs to (`lib`/`main` for the root).
fn top_module(src: &std::path::Path, file: &std::path::Path) -> String {
    let rel = file.strip_prefix(src).unwrap_or(file);
    let first = rel.components().next().map(|c| c.as_os_str().to_string_lossy().into_owned()).unwrap_or_default();
    first.trim_end_matches(".rs").to_string()
}

/// The top-level modules `code` names as `crate::NAME` (also inside `crate::{a, b}`).
fn crate_refs(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        rest = &rest[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let inner = group.split('}').next().unwrap_or("");
            for part in inner.split(',') {
                let name: String = part.trim().chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                out.push(name);
            }
        } else {
            out.push(rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect());
        }
    }
    out.retain(|n| !n.is_empty() && n.chars().next().is_some_and(|c| c.is_lowercase()));
    out
}

/// A cycle in `graph` (module → modules it uses), if there is one.
fn find_cycle(graph: &std::collections::BTreeMap<String, std::collections::BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        m: &str,
        graph: &std::collections::BTreeMap<String, std::collections::BTreeSet<String>>,
        state: &mut std::collections::BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(m) {
            Some(2) => return None,
            Some(1) => {
                let at = path.iter().position(|p| p == m).unwrap_or(0);
                let mut cycle = path[at..].to_vec();
                cycle.push(m.to_string());
                return Some(cycle);
            }
            _ => {}
        }
        state.insert(m.to_string(), 1);
        path.push(m.to_string());
        for next in graph.get(m).into_iter().flatten() {
            if let Some(c) = visit(next, graph, state, path) {
                return Some(c);
            }
        }
        path.pop();
        state.insert(m.to_string(), 2);
        None
    }
    let mut state = std::collections::BTreeMap::new();
    graph.keys().find_map(|m| visit(m, graph, &mut state, &mut Vec::new()))
}

/// Exceptions to the layering (crate, module, module). None: the bundle carries the
/// extension tables as opaque typed sections (`bundle::Section`), so it no longer
/// names the types of the modules that read it (docs/decisions.md "Issue 38: crates
/// that show the architecture").
const ALLOWED_CYCLES: &[(&str, &str, &str)] = &[];

/// The modules of each crate import one another without cycles, so each can be read
/// (and would compile) after the ones it uses.
#[test]
fn modules_import_one_another_without_cycles() {
    let allowed = ALLOWED_CYCLES;
    let mut found = Vec::new();
    for krate in ["compiler", "vm", "export", "guided", "creature", "grid", "lsp", "viewer", "cli"] {
        let src = root().join(krate).join("src");
        let mut files = Vec::new();
        rs_files(&src, &mut files);
        assert!(!files.is_empty(), "{krate}/src has no sources");
        let mut graph = std::collections::BTreeMap::<String, std::collections::BTreeSet<String>>::new();
        for f in files.iter().filter(|f| !is_test_module(f)) {
            let from = top_module(&src, f);
            if from == "bin" {
                continue;
            }
            let text = std::fs::read_to_string(f).unwrap_or_default();
            let text = text.split("#[cfg(test)]").next().unwrap_or("");
            let entry = graph.entry(from.clone()).or_default();
            for (_, code) in code_lines(text) {
                for to in crate_refs(code) {
                    if to != from && !allowed.contains(&(krate, from.as_str(), to.as_str())) {
                        entry.insert(to);
                    }
                }
            }
        }
        if let Some(cycle) = find_cycle(&graph) {
            found.push(format!("{krate}: {}", cycle.join(" → ")));
        }
    }
    assert!(found.is_empty(), "module import cycles (break them, or move the shared item down):\n{}", found.join("\n"));
}

/// The module path of `file` under `src`: empty for `lib.rs`/`main.rs`, `a::b` for
/// `a/b.rs` and `a/b/mod.rs`.
fn module_path(src: &std::path::Path, file: &std::path::Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap_or(file).with_extension("");
    let mut parts: Vec<String> = rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    if parts.last().is_some_and(|l| l == "mod" || l == "lib" || l == "main") {
        parts.pop();
    }
    parts
}

/// The module paths `code` (a line of the file of module `at`) names through
/// `crate::`, `super::` and `self::` paths, also inside one `{…}` group, as full
/// paths of identifiers (the caller keeps the longest prefix that is a module).
fn path_refs(code: &str, at: &[String]) -> Vec<Vec<String>> {
    let ident = |s: &str| -> String { s.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect() };
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(i) = ["crate::", "super::", "self::"].iter().filter_map(|k| rest.find(k)).min() {
        let before = rest[..i].chars().next_back();
        rest = &rest[i..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            rest = &rest[rest.find("::").map_or(rest.len(), |k| k + 2)..];
            continue;
        }
        let mut base: Vec<String> = if rest.starts_with("crate::") { Vec::new() } else { at.to_vec() };
        let mut segs = Vec::new();
        loop {
            if let Some(r) = rest.strip_prefix("crate::").or_else(|| rest.strip_prefix("self::")) {
                rest = r;
            } else if let Some(r) = rest.strip_prefix("super::") {
                base.pop();
                rest = r;
            } else if let Some(group) = rest.strip_prefix('{') {
                let inner = group.split('}').next().unwrap_or("");
                for part in inner.split(',') {
                    let path: Vec<String> = part.trim().split("::").map(ident).take_while(|p| !p.is_empty()).collect();
                    out.push([base.clone(), segs.clone(), path].concat());
                }
                break;
            } else {
                let name = ident(rest);
                if name.is_empty() {
                    out.push([base.clone(), segs.clone()].concat());
                    break;
                }
                rest = &rest[name.len()..];
                segs.push(name);
                match rest.strip_prefix("::") {
                    Some(r) => rest = r,
                    None => {
                        out.push([base.clone(), segs.clone()].concat());
                        break;
                    }
                }
            }
        }
    }
    out
}

/// The files of each crate import one another without cycles at any depth
/// (`lsp/src/handlers/sync.rs` and `handlers/workspace.rs` used to call each other).
/// A file's references are its `crate::`, `super::` and `self::` paths, each taken
/// to the deepest module it names; a module and the modules inside it are one unit
/// (a child reads its parent's items through `super::`), so references between them
/// do not count. The exceptions of [`modules_import_one_another_without_cycles`]
/// hold here too.
#[test]
fn files_import_one_another_without_cycles_at_any_depth() {
    let allowed = ALLOWED_CYCLES;
    let mut found = Vec::new();
    for krate in ["compiler", "vm", "export", "guided", "creature", "grid", "lsp", "viewer", "cli"] {
        let src = root().join(krate).join("src");
        let mut files = Vec::new();
        rs_files(&src, &mut files);
        let files: Vec<_> =
            files.into_iter().filter(|f| !is_test_module(f) && !f.starts_with(src.join("bin"))).collect();
        let modules: std::collections::BTreeSet<Vec<String>> = files.iter().map(|f| module_path(&src, f)).collect();
        let mut graph = std::collections::BTreeMap::<String, std::collections::BTreeSet<String>>::new();
        for f in &files {
            let from = module_path(&src, f);
            let text = std::fs::read_to_string(f).unwrap_or_default();
            let text = text.split("#[cfg(test)]").next().unwrap_or("");
            let entry = graph.entry(from.join("::")).or_default();
            for (_, code) in code_lines(text) {
                for path in path_refs(code, &from) {
                    let Some(to) = (0..=path.len()).rev().map(|n| &path[..n]).find(|p| modules.contains(*p)) else {
                        continue;
                    };
                    let nested = to.starts_with(&from) || from.starts_with(to);
                    let top = |m: &[String]| m.first().cloned().unwrap_or_default();
                    if nested || allowed.contains(&(krate, top(&from).as_str(), top(to).as_str())) {
                        continue;
                    }
                    entry.insert(to.join("::"));
                }
            }
        }
        if let Some(cycle) = find_cycle(&graph) {
            found.push(format!("{krate}: {}", cycle.join(" → ")));
        }
    }
    assert!(found.is_empty(), "file import cycles (break them, or move the shared item down):\n{}", found.join("\n"));
}

#[test]
fn path_refs_resolve_crate_super_and_self_paths() {
    let at = ["handlers".to_string(), "sync".to_string()];
    let joined = |code: &str| -> Vec<String> { path_refs(code, &at).iter().map(|p| p.join("::")).collect() };
    assert_eq!(joined("super::workspace::closed(b, &uri).await;"), ["handlers::workspace::closed"]);
    assert_eq!(joined("use crate::{backend::Backend, guard};"), ["backend::Backend", "guard"]);
    assert_eq!(joined("use self::x::{a, b::c};"), ["handlers::sync::x::a", "handlers::sync::x::b::c"]);
    assert_eq!(joined("let s = my_crate::f(); use super::super::lib;"), ["lib"]);
}

/// No source file of the VM, nor of the crates on it, is over 1,000 lines, but those
/// listed, which may only shrink (each with the most lines it may have; remove an
/// entry once it is split).
#[test]
fn no_vm_file_is_over_1000_lines() {
    const LARGE: [(&str, usize); 2] = [("grid/src/infer.rs", 1145), ("guided/src/search.rs", 1132)];
    let mut files = Vec::new();
    for dir in ["vm/src", "export/src", "guided/src", "creature/src", "grid/src"] {
        rs_files(&root().join(dir), &mut files);
    }
    let mut over = Vec::new();
    for f in &files {
        let name = f.strip_prefix(root()).unwrap_or(f).display().to_string();
        let lines = std::fs::read_to_string(f).unwrap_or_default().lines().count();
        let most = LARGE.iter().find(|(n, _)| *n == name).map_or(1000, |&(_, m)| m);
        if lines > most {
            over.push(format!("{name}: {lines} lines (at most {most})"));
        }
    }
    assert!(over.is_empty(), "files over their line limit (split them by concern):\n{}", over.join("\n"));
}

#[test]
fn the_cycle_finder_finds_cycles() {
    let g = |edges: &[(&str, &str)]| {
        let mut m = std::collections::BTreeMap::<String, std::collections::BTreeSet<String>>::new();
        for (a, b) in edges {
            m.entry(a.to_string()).or_default().insert(b.to_string());
            m.entry(b.to_string()).or_default();
        }
        m
    };
    assert_eq!(find_cycle(&g(&[("a", "b"), ("b", "c")])), None);
    assert_eq!(find_cycle(&g(&[("a", "b"), ("b", "c"), ("c", "a")])).map(|c| c.len()), Some(4));
    assert_eq!(crate_refs("use crate::{ast::Expr, diag}; x = crate::lower::f();"), ["ast", "diag", "lower"]);
}

/// The README's code map names every top-level folder and every folder of a crate's
/// `src/` (as `` `PATH/` ``), so a newcomer finds each in it.
#[test]
fn the_readme_code_map_names_every_folder() {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README.md");
    let map = readme.split("### Code map").nth(1).expect("a `### Code map` section");
    let map = map.split("\n## ").next().unwrap_or(map);
    let dirs = |p: &std::path::Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(p)
            .map(|rd| {
                rd.flatten()
                    .filter(|e| e.path().is_dir())
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .filter(|n| n != "target" && n != "node_modules" && (!n.starts_with('.') || n == ".ci"))
                    .collect()
            })
            .unwrap_or_default();
        v.sort();
        v
    };
    let mut want: Vec<String> = dirs(&root()).into_iter().map(|d| format!("{d}/")).collect();
    for krate in ["cli", "compiler", "vm", "export", "guided", "creature", "grid", "lsp", "viewer"] {
        want.extend(dirs(&root().join(krate).join("src")).into_iter().map(|d| format!("{krate}/src/{d}/")));
    }
    assert!(want.len() > 15, "found only {want:?}");
    let missing: Vec<&String> = want.iter().filter(|d| !map.contains(&format!("`{d}`"))).collect();
    assert!(missing.is_empty(), "folders the README's code map does not name: {missing:?}");
}

/// No library function returns a string as its error (issue 38, "errors as data"):
/// the `pub fn`s of the library crates return an error type that says what failed,
/// and `cli/src/failure.rs` turns it into a message and an exit status. Counted:
/// the `pub fn`s whose return type is a `Result<…, String>` (signatures read up to
/// their body's `{` or a `;` outside brackets, test modules left out). Trait methods
/// are not counted (`Section::check`, the compiler's `FileLoader`).
#[test]
fn no_library_function_returns_a_string_error() {
    let mut found = Vec::new();
    for (krate, _) in LIBRARIES {
        let mut files = Vec::new();
        rs_files(&root().join(krate).join("src"), &mut files);
        for f in files.iter().filter(|f| !is_test_module(f)) {
            let text = std::fs::read_to_string(f).unwrap_or_default();
            let text = text.split("#[cfg(test)]").next().unwrap_or("");
            let code: String = code_lines(text).iter().map(|(_, c)| format!("{c}\n")).collect();
            let n = string_error_fns(&code);
            if n > 0 {
                found.push(format!("{}: {n}", f.strip_prefix(root()).unwrap_or(f).display()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "library functions that return Result<_, String> (give them an error type):\n{}",
        found.join("\n")
    );
}

/// How many `pub fn`s in `code` return a `Result<…, String>`.
fn string_error_fns(code: &str) -> usize {
    let mut n = 0;
    let mut rest = code;
    while let Some(i) = rest.find("pub fn ") {
        rest = &rest[i..];
        // The signature ends at its body's `{` or at a `;` outside brackets (an
        // array type, `[u8; 3]`, has one inside).
        let mut depth = 0i32;
        let end = rest
            .char_indices()
            .find(|&(_, c)| {
                match c {
                    '[' | '(' => depth += 1,
                    ']' | ')' => depth -= 1,
                    _ => {}
                }
                c == '{' || (c == ';' && depth == 0)
            })
            .map_or(rest.len(), |(i, _)| i);
        let ret = rest[..end].split_once("->").map_or("", |(_, r)| r);
        let compact: String = ret.chars().filter(|c| !c.is_whitespace()).collect();
        if compact.contains("Result<") && (compact.contains(",String>") || compact.contains(",String,>")) {
            n += 1;
        }
        rest = &rest[end..];
    }
    n
}

#[test]
fn string_errors_are_counted_across_lines() {
    let code = "pub fn a() -> Result<u32, String> {}\npub fn b(\n    x: u8,\n) -> Result<\n    Vec<u8>,\n    String,\n> {}\npub fn c() -> Result<(), Error> {}\nfn d() -> Result<(), String> {}\npub fn e(s: String) -> u8;";
    assert_eq!(
        string_error_fns(code),
        2,
        "`a` and `b` (written over lines, with a trailing comma); `c` has an error type, `d` is private"
    );
    assert_eq!(string_error_fns("pub fn b(\n) -> Result<\n    Vec<u8>,\n    String>;"), 1);
    assert_eq!(
        string_error_fns("pub fn c(tiles: &[u8], bg: [u8; 3]) -> Result<Vec<u8>, String> {}"),
        1,
        "the `;` of an array type does not end the signature"
    );
}

/// No operator is written as a number: the expression languages' binary operators
/// are `BinOp::Mul`, never `Bin(2)` (issue 38; the lowering once wrote `ExprOp::Bin(2)`
/// to mean "multiply"). Looks for `Bin(` followed by a digit in the code of every
/// crate.
#[test]
fn no_operator_is_written_as_a_number() {
    let mut found = Vec::new();
    for krate in
        ["compiler", "vm", "export", "guided", "creature", "grid", "lsp", "viewer", "cli", "python", "tests", "fuzz"]
    {
        let mut files = Vec::new();
        rs_files(&root().join(krate), &mut files);
        // (This file names the pattern in its own test strings.)
        for f in files.iter().filter(|f| !f.ends_with("tests/tests/tidy.rs")) {
            let text = std::fs::read_to_string(f).unwrap_or_default();
            for (n, code) in code_lines(&text) {
                if numbered_operator(code) {
                    found.push(format!("{}:{n}: {}", f.strip_prefix(root()).unwrap_or(f).display(), code.trim()));
                }
            }
        }
    }
    assert!(found.is_empty(), "operators written as numbers (name them: `BinOp::Mul`):\n{}", found.join("\n"));
}

/// Whether `code` writes `Bin(` with a number.
fn numbered_operator(code: &str) -> bool {
    code.match_indices("Bin(").any(|(i, _)| {
        let before = code[..i].chars().next_back();
        let after = code[i + 4..].trim_start().chars().next();
        !before.is_some_and(|c| c.is_alphanumeric() || c == '_') && after.is_some_and(|c| c.is_ascii_digit())
    })
}

#[test]
fn numbered_operators_are_recognised() {
    assert!(numbered_operator("code.extend([ExprOp::Push(f), ExprOp::Bin(2)]);"));
    assert!(numbered_operator("CondOp::Bin( 0 )"));
    assert!(!numbered_operator("ExprOp::Bin(BinOp::Mul)"));
    assert!(!numbered_operator("MyBin(2)"));
}
