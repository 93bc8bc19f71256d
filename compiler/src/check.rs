//! The checker: name resolution, value checks, reachability and termination.
//!
//! Works on the expanded program ([`crate::expand::Expanded`]); every finding is a
//! [`Diagnostic`] with a code from `docs/diagnostics.md`. The symbol table it builds
//! ([`Symbols`]) is reused by lowering and the language server.
//!
//! [`check_with`] replays the rules a previous version's check recorded where
//! neither the rule nor the facts its check reads changed ([`crate::check_cache`]):
//! the language server's check after an edit.

use crate::ast::*;
use crate::check_cache::{Entry, RuleResult};
use crate::diag::{did_you_mean, Diagnostic};
use crate::expand::{ExpItem, Expanded};
use crate::span::Span;
use crate::types::{type_of, SigParam, Signature, Ty, TYPE_NAMES};
use std::collections::{BTreeSet, HashMap};
use std::sync::Arc;

pub use crate::symbols::{DRAWABLES, PEN_DRAWABLES, PROFILE_DRAWABLES};

/// Selector modes.
pub const SELECTOR_MODES: &[&str] = &["random", "frequency", "depth", "scale", "sequential", "pattern", "function"];

/// Angle modes for `angle`.
pub const ANGLE_MODES: &[&str] = &["degrees", "radians", "orbits", "arcdegrees", "frequency"];

/// Math functions usable in expressions, with their arity (the VM's table).
pub use mdg_vm::expr::FUNCTIONS;

/// Variables available inside `function`, selector and isosurface expressions.
pub const FUNCTION_VARS: &[&str] = &["x", "y", "z", "depth", "scale", "g"];

/// Numeric directives: name, minimum and maximum argument count, whether values must be integers.
pub const NUMERIC_DIRECTIVES: &[(&str, usize, usize, bool)] = &[
    ("maxdepth", 1, 1, true),
    ("minsize", 1, 1, false),
    ("maxiter", 1, 1, true),
    ("maxobjects", 1, 1, true),
    ("breadthfirst", 0, 0, false),
    ("stacksize", 1, 1, true),
    ("randseed", 1, 1, true),
    ("normal", 3, 3, false),
    ("background", 3, 4, false),
    ("flat", 0, 0, false),
    ("fps", 1, 1, false),
    ("duration", 1, 1, false),
    ("camerafov", 1, 1, false),
    ("cameranearplane", 1, 1, false),
    ("camerafarplane", 1, 1, false),
];

/// Every directive name, for "did you mean".
pub fn directive_names() -> Vec<&'static str> {
    let mut v: Vec<&str> = NUMERIC_DIRECTIVES.iter().map(|d| d.0).collect();
    v.extend(crate::lexer::KEYWORDS);
    v
}

pub use crate::adjust::{AdjKind, Components};

pub use crate::symbols::{RuleDef, Symbols};

/// Options for checking.
#[derive(Clone, Copy, Debug, Default)]
pub struct CheckOptions {
    /// Require a `startshape` even if the file looks like a library (building, running).
    pub require_start: bool,
}

/// The result of checking.
pub struct Checked {
    pub symbols: Symbols,
    pub diagnostics: Vec<Diagnostic>,
    /// Each rule's contributions, for the next version's check ([`check_with`]).
    pub cache: Cache,
}

pub use crate::check_cache::Cache;

/// The previous version's check, for [`check_with`]: its program, its result, and
/// how its parse was reused (the main file's rules the edit moved).
#[derive(Clone, Copy)]
pub struct Previous<'p> {
    pub expanded: &'p Expanded,
    pub checked: &'p Checked,
}

/// Checks an expanded program.
pub fn check(ex: &Expanded, opts: CheckOptions) -> Checked {
    check_with(ex, opts, None, false)
}

/// [`check`] that replays the rules `previous` recorded, where the rule and the
/// facts its check reads are unchanged ([`crate::check_cache`]), and records each
/// rule's contributions for the next version when `record` is set. The result is
/// [`check`]'s.
pub fn check_with(ex: &Expanded, opts: CheckOptions, previous: Option<Previous>, record: bool) -> Checked {
    // Vectors are groups of scalars: the program without them is what is checked
    // (and lowered), the vector errors found on the way first. That program is a
    // new copy each version, so none of its rules is the previous version's: it is
    // checked whole, neither replayed nor recorded (the cache matches rules by
    // identity, which a freed copy's address must not fake).
    let scalar = crate::vectors::scalarize(ex);
    let (ex, vector_diags, previous, record) = match &scalar {
        Some((s, d)) => (s, d.clone(), None, false),
        None => (ex, Vec::new(), previous, record),
    };
    let mut c = Checker {
        ex,
        sym: Symbols::default(),
        diags: vector_diags,
        call_graph: HashMap::new(),
        must_graph: HashMap::new(),
        scope: None,
        guards: Vec::new(),
        conditional: 0,
        rule_name: None,
        param_reads: BTreeSet::new(),
        unread_params: Vec::new(),
        in_path: false,
        profile_rules: BTreeSet::new(),
        function: None,
        lets: Vec::new(),
        cache: Cache { recorded: record, ..Cache::default() },
        replay: None,
        rule_reads: Vec::new(),
    };
    c.collect();
    c.cross_file_definitions();
    c.collect_profiles();
    c.cache.has_limit = c.has_limit();
    if let Some(p) = previous {
        let facts = crate::check_cache::same_facts(
            (p.expanded, &p.checked.symbols, &p.checked.cache),
            (ex, &c.sym),
            &c.profile_rules,
            c.cache.has_limit,
        );
        if facts {
            let moved = ex.reused.moved.iter().copied().collect();
            c.replay = Some((&p.checked.cache, moved, ex.reused.delta));
        }
    }
    if record {
        c.cache.profile_rules = c.profile_rules.clone();
    }
    c.items();
    c.unread_params();
    c.whole_program(opts);
    crate::ext::check(ex, &c.sym, &mut c.diags);
    Checked { symbols: c.sym, diagnostics: c.diags, cache: c.cache }
}

struct Checker<'a> {
    ex: &'a Expanded,
    /// While a function's body is checked: its index among the items and its
    /// parameters (a function may call only functions declared before it).
    function: Option<(usize, Vec<String>)>,
    /// The `let(…)` names of the expressions around the one being checked,
    /// innermost last.
    lets: Vec<String>,
    sym: Symbols,
    diags: Vec<Diagnostic>,
    /// Rule full name → rules its definitions call (per definition).
    call_graph: HashMap<String, Vec<Vec<String>>>,
    /// Like `call_graph`, only the calls every run of the definition makes (not those
    /// inside an `if` or a loop whose count is known only at run time).
    must_graph: HashMap<String, Vec<Vec<String>>>,
    /// The parameters and locals in scope while a rule body is checked (`None`
    /// outside rule bodies).
    scope: Option<Vec<Local>>,
    /// The `if` conditions around the item being checked, with the branch taken
    /// (`true`: then).
    guards: Vec<(&'a Expr, bool)>,
    /// How many `if` branches or run-time loops enclose the item being checked.
    conditional: u32,
    /// The full name of the rule whose body is being checked.
    rule_name: Option<String>,
    /// Rules some drawable uses as its profile (`LINETO circle {…}`), by full name.
    profile_rules: BTreeSet<String>,
    /// Parameters read somewhere (rule, parameter index): by any definition's body
    /// or by the rule's selector.
    param_reads: BTreeSet<(String, usize)>,
    /// Parameters a definition did not read: (rule, index, span), reported when no
    /// definition and no selector reads them.
    unread_params: Vec<(String, usize, Span, String)>,
    /// The definition being checked is a flat path ([`crate::paths`]).
    in_path: bool,
    /// This check's per-rule results, for the next version's.
    cache: Cache,
    /// The previous check's cache, when the facts a rule's check reads are
    /// unchanged: with the moved rules (new `Arc` address → previous one) and the
    /// edit's change in length.
    replay: Option<(&'a Cache, HashMap<usize, usize>, i64)>,
    /// The parameters the rule being checked reads (for its [`RuleResult`]).
    rule_reads: Vec<usize>,
}

/// A parameter, `let` binding or loop variable in scope.
#[derive(Clone, Debug)]
struct Local {
    name: String,
    ty: Ty,
    span: Span,
    used: bool,
    /// Its index in the rule's parameter list, for a parameter.
    param: Option<usize>,
}

/// W0006 for a binding that is never read.
fn unused(l: &Local, what: &str) -> Diagnostic {
    Diagnostic::warning("W0006", l.span, format!("{what} `{}` is never used", l.name))
        .with_label("never read")
        .with_note(format!("use it, remove it, or name it `_{}`", l.name))
}

/// `e` without the parentheses around it.
fn strip(e: &Expr) -> &Expr {
    match &e.kind {
        ExprKind::Paren(x) => strip(x),
        _ => e,
    }
}

fn qualify(ns: &Option<String>, name: &str) -> String {
    match ns {
        Some(ns) => format!("{ns}.{name}"),
        None => name.to_string(),
    }
}

fn num_of(a: &DirArg) -> Option<(f64, &Number)> {
    match a {
        DirArg::Num(n) => Some((n.value, n)),
        DirArg::Neg(n) => Some((-n.value, n)),
        _ => None,
    }
}

fn dir_arg_span(a: &DirArg) -> Span {
    match a {
        DirArg::Num(n) | DirArg::Neg(n) => n.span,
        DirArg::Word(w) => w.span,
        DirArg::Expr(e) => e.span,
    }
}

impl<'a> Checker<'a> {
    fn collect(&mut self) {
        for (idx, ExpItem { item, namespace }) in self.ex.items.iter().enumerate() {
            match &item.kind {
                ItemKind::Rule(r) if !r.name.text.is_empty() => {
                    let full = qualify(namespace, &r.name.text);
                    if DRAWABLES.contains(&r.name.text.as_str()) && !self.sym.rules.contains_key(&full) {
                        self.diags.push(
                            Diagnostic::warning(
                                "W0004",
                                r.name.span,
                                format!("rule `{}` has the name of a drawable", r.name.text),
                            )
                            .with_label("calls of this name draw, they do not run this rule")
                            .with_note("rename the rule"),
                        );
                    }
                    if !self.sym.rules.contains_key(&full) {
                        let sig = self.signature(r);
                        self.sym.signatures.insert(full.clone(), sig);
                    }
                    self.sym.rules.entry(full).or_default().push(RuleDef {
                        item: idx,
                        name_span: r.name.span,
                        namespace: namespace.clone(),
                    });
                }
                ItemKind::Function { name, .. } => self.define_unique(true, name, namespace),
                ItemKind::Isosurface { name, .. } => self.define_unique(false, name, namespace),
                ItemKind::Namespace { name, .. } => {
                    let full = qualify(namespace, &name.text);
                    if let Some(prev) = self.sym.namespaces.get(&full) {
                        self.diags.push(
                            Diagnostic::error("E0309", name.span, format!("namespace `{full}` is declared twice"))
                                .with_secondary(*prev, "first declared here")
                                .with_note("put all of its rules in one `namespace` block"),
                        );
                    } else {
                        self.sym.namespaces.insert(full, name.span);
                    }
                }
                ItemKind::Directive { name, args } if name.text == "color" || name.text == "weight" => {
                    let words: Vec<String> = args
                        .iter()
                        .filter_map(|a| if let DirArg::Word(w) = a { Some(w.text.clone()) } else { None })
                        .collect();
                    if let Ok(arr) = <[String; 4]>::try_from(words) {
                        if name.text == "color" {
                            self.sym.components.color = arr;
                        } else {
                            self.sym.components.weight = arr;
                        }
                    }
                }
                _ => {}
            }
        }
    }

    /// W0015 and W0016: definitions of one rule in several files merge into one
    /// random choice between them. That is said, naming both places, unless the
    /// definition is written `rule NAME += …`; a `+=` with nothing to add to is said too.
    /// The warning goes to the file nearest the main file (the one a user edits):
    /// the definer read last (std, or the deepest import) owns the rule.
    fn cross_file_definitions(&mut self) {
        let order = |f: crate::span::FileId| self.ex.files.iter().position(|x| *x == f).unwrap_or(0);
        let adds = |d: &RuleDef| match self.ex.items.get(d.item).map(|i| &i.item.kind) {
            Some(ItemKind::Rule(r)) => r.adds.map(|a| (a, r)),
            _ => None,
        };
        let mut out = Vec::new();
        for (full, defs) in &self.sym.rules {
            let mut files: Vec<crate::span::FileId> = Vec::new();
            for d in defs {
                if !files.contains(&d.name_span.file) {
                    files.push(d.name_span.file);
                }
            }
            let Some(owner) = files.iter().copied().max_by_key(|f| order(*f)) else { continue };
            if files.len() < 2 {
                for d in defs {
                    if let Some((at, r)) = adds(d) {
                        // The fix rewrites what precedes `+=` up to it (an empty
                        // replacement would make editors delete the whole line).
                        let (from, keep) = match &r.params {
                            Some(p) => (p.span.end.saturating_sub(1), ")".to_string()),
                            None => (r.name.span.start, r.name.text.clone()),
                        };
                        out.push(
                            Diagnostic::warning(
                                "W0016",
                                at,
                                format!("`+=` adds to `{full}`, but no other file defines it"),
                            )
                            .with_label("nothing to add to")
                            .with_note(
                                "`+=` marks a definition that adds to a rule of an imported file or the std \
                                     library; remove it, or import the file that defines the rule",
                            )
                            .with_suggestion(
                                "remove `+=`",
                                Span::new(at.file, from, at.end),
                                keep,
                            ),
                        );
                    }
                }
                continue;
            }
            let Some(home) = defs.iter().find(|d| d.name_span.file == owner) else { continue };
            for f in files.iter().copied().filter(|f| *f != owner) {
                let here: Vec<&RuleDef> = defs.iter().filter(|d| d.name_span.file == f).collect();
                if here.iter().any(|d| adds(d).is_some()) {
                    continue;
                }
                let Some(first) = here.first() else { continue };
                let lib =
                    crate::stdlib::library_defining(full).map(|l| format!(" (std library `{l}`)")).unwrap_or_default();
                let after = match self.ex.items.get(first.item).map(|i| &i.item.kind) {
                    Some(ItemKind::Rule(r)) => r.params.as_ref().map_or(first.name_span.end, |p| p.span.end),
                    _ => first.name_span.end,
                };
                let insert = Span::new(f, after, after);
                out.push(
                    Diagnostic::warning(
                        "W0015",
                        first.name_span,
                        format!("rule `{full}` is also defined in another file{lib}: this adds a definition to it"),
                    )
                    .with_label("a second definition: each call picks one of them at random, by weight")
                    .with_secondary(home.name_span, format!("`{full}` is defined here"))
                    .with_note(format!(
                        "rename this rule if it is a new one; write `rule {full} += …` to add to the other file's rule on purpose"
                    ))
                    .with_suggestion(format!("add to `{full}` on purpose: `rule {full} +=`"), insert, " +=".to_string()),
                );
            }
        }
        self.diags.extend(out);
    }

    /// The rules used as profiles anywhere in the program (for W0010).
    fn collect_profiles(&mut self) {
        for ExpItem { item, namespace } in &self.ex.items {
            if let ItemKind::Rule(r) = &item.kind {
                let (sym, profiles) = (&self.sym, &mut self.profile_rules);
                walk_body(&r.body, &mut |it| {
                    if let BodyKind::Call { profile: Some(p), .. } = &it.kind {
                        profiles.extend(sym.resolve(&p.text, namespace.as_deref()));
                    }
                });
            }
        }
    }

    /// The signature a definition declares (bad types count as `float`; they are
    /// reported when the definition is checked).
    fn signature(&self, r: &Rule) -> Signature {
        let params = r.params.iter().flat_map(|p| &p.params);
        Signature {
            params: params
                .map(|p| SigParam {
                    name: p.name.text.clone(),
                    ty: Ty::parse(&p.ty.text).unwrap_or(Ty::Float),
                    default: p.default.as_ref().and_then(|d| self.const_value(d)),
                    span: p.span,
                })
                .collect(),
        }
    }

    /// Reports a rule used where no caller passes arguments (start shape, profile,
    /// transform, iterator, line or camera rule) that has a parameter without default.
    fn no_arguments_needed(&mut self, full: &str, at: Span, what: &str) {
        let Some(sig) = self.sym.signatures.get(full) else { return };
        if let Some(p) = sig.params.iter().find(|p| p.default.is_none()) {
            let label = sig.label(full);
            let d = Diagnostic::error(
                "E0324",
                at,
                format!("the {what} `{full}` is run without arguments, but its parameter `{}` has no default", p.name),
            )
            .with_label(format!("`{label}`"))
            .with_secondary(p.span, "give this parameter a default")
            .with_note(format!("write `{} {} = VALUE` in the parameter list", p.ty.name(), p.name));
            self.diags.push(d);
        }
    }

    fn define_unique(&mut self, function: bool, name: &Name, ns: &Option<String>) {
        let full = qualify(ns, &name.text);
        let table = if function { &mut self.sym.functions } else { &mut self.sym.isosurfaces };
        if let Some(prev) = table.get(&full) {
            let what = if function { "function" } else { "isosurface" };
            let prev = *prev;
            self.diags.push(
                Diagnostic::error("E0313", name.span, format!("{what} `{full}` is defined twice"))
                    .with_secondary(prev, "first defined here"),
            );
        } else {
            table.insert(full, name.span);
        }
    }

    fn rule_ref(&mut self, name: &Name, ns: &Option<String>, code: &'static str, what: &str) -> Option<String> {
        match self.sym.resolve(&name.text, ns.as_deref()) {
            Some(full) => {
                self.sym.references.push((name.span, full.clone()));
                Some(full)
            }
            None => {
                let mut d = Diagnostic::error(code, name.span, format!("{what} `{}` is not defined", name.text));
                if let Some(s) = did_you_mean(&name.text, self.sym.rules.keys().map(|k| k.as_str())) {
                    d = d.with_suggestion(format!("did you mean `{s}`?"), name.span, s.to_string());
                } else {
                    d = d.with_label("no rule has this name");
                }
                self.diags.push(d);
                None
            }
        }
    }

    fn items(&mut self) {
        let mut seen_directives: HashMap<String, Span> = HashMap::new();
        let ex = self.ex;
        for (index, ExpItem { item, namespace }) in ex.items.iter().enumerate() {
            match &item.kind {
                ItemKind::Startshape(n) => {
                    if let Some((_, prev)) = &self.sym.startshape {
                        let prev = *prev;
                        self.diags.push(
                            Diagnostic::error("E0312", n.span, "`startshape` is given twice")
                                .with_secondary(prev, "first given here"),
                        );
                        continue;
                    }
                    self.sym.startshape = Some((n.text.clone(), n.span));
                    if let Some(full) = self.rule_ref(n, namespace, "E0307", "start shape") {
                        self.no_arguments_needed(&full, n.span, "start shape");
                        self.sym.startshape = Some((full, n.span));
                    }
                }
                ItemKind::Rule(r) => self.cached_rule(r, namespace, item.span),
                ItemKind::Selector { rules, mode } => self.selector(rules, mode, namespace),
                ItemKind::Linerule(n) => {
                    if let Some(full) = self.rule_ref(n, namespace, "E0308", "line rule") {
                        self.no_arguments_needed(&full, n.span, "line rule");
                    }
                }
                ItemKind::Camerarule(n) => {
                    if let Some(full) = self.rule_ref(n, namespace, "E0308", "camera rule") {
                        self.no_arguments_needed(&full, n.span, "camera rule");
                    }
                }
                ItemKind::Directive { name, args } => self.directive(name, args, namespace, &mut seen_directives),
                ItemKind::Function { name, body, params, .. } => {
                    let builtin = FUNCTIONS.iter().map(|(n, _)| *n).chain(SPECIAL_FORMS.iter().map(|(n, _)| *n));
                    if let Some(b) = builtin.into_iter().find(|b| *b == name.text) {
                        self.diags.push(
                            Diagnostic::error("E0330", name.span, format!("a function named like the built-in `{b}`"))
                                .with_label("every call would run the built-in, never this function")
                                .with_note("choose another name"),
                        );
                    }
                    self.function_params(params);
                    self.function = Some((index, params.iter().map(|p| p.text.clone()).collect()));
                    self.expr(body, true, false);
                    self.function = None;
                    if !params.is_empty() {
                        self.never_returns(index, name);
                    }
                }
                ItemKind::Isosurface { name, entries } => self.isosurface(name, entries),
                ItemKind::Program { words } => self.program(words),
                // Checked by `crate::ext` once every rule is known.
                ItemKind::Section(_) => {}
                ItemKind::Namespace { .. } | ItemKind::Pre(_) | ItemKind::Error => {}
            }
        }
        self.maxobjects_needs_breadth(&seen_directives);
    }

    /// `maxobjects` counts the objects of a breadth-first run: without
    /// `breadthfirst` it is E0407, with the line that asks for that order as the fix.
    fn maxobjects_needs_breadth(&mut self, seen: &HashMap<String, Span>) {
        let Some(&at) = seen.get("maxobjects") else { return };
        if seen.contains_key("breadthfirst") {
            return;
        }
        let d = Diagnostic::error("E0407", at, "`maxobjects` needs `breadthfirst`")
            .with_label("counts the objects of a breadth-first run")
            .with_note("depth first, the first N objects would be one branch's; Structure Synth's `set maxobjects` grows breadth first")
            .with_suggestion("ask for breadth-first order", Span::new(at.file, at.start, at.start), "breadthfirst\n");
        self.diags.push(d);
    }

    /// A rule's check: replayed from the previous version's where it can be,
    /// recorded for the next where asked.
    fn cached_rule(&mut self, r: &'a Arc<Rule>, ns: &Option<String>, span: Span) {
        let addr = Arc::as_ptr(r) as usize;
        let hit = self.replay.as_ref().and_then(|(prev, moved, delta)| {
            let (old, d) = match prev.rules.get(&addr) {
                Some(e) if Arc::ptr_eq(&e.rule, r) => (e, 0),
                _ => (prev.rules.get(moved.get(&addr)?)?, *delta),
            };
            (old.namespace == *ns).then(|| (old.result.clone(), old.delta + d))
        });
        if let Some((result, delta)) = hit {
            self.replay_rule(&result, delta);
            self.cache.replayed += 1;
            if self.cache.recorded {
                let entry = Entry { rule: r.clone(), namespace: ns.clone(), result, delta };
                self.cache.rules.insert(addr, entry);
            }
            return;
        }
        self.cache.checked += 1;
        self.rule_reads.clear();
        if !self.cache.recorded {
            self.rule(r, ns);
            return;
        }
        let (d0, r0, u0) = (self.diags.len(), self.sym.references.len(), self.unread_params.len());
        self.rule(r, ns);
        let full = (!r.name.text.is_empty()).then(|| qualify(ns, &r.name.text));
        let graph = full.map(|f| {
            let calls = self.call_graph.get(&f).and_then(|g| g.last()).cloned().unwrap_or_default();
            let must = self.must_graph.get(&f).and_then(|g| g.last()).cloned().unwrap_or_default();
            (f, calls, must)
        });
        let inside = |s: Span| s.file == span.file && span.start <= s.start && s.end <= span.end;
        let result = RuleResult {
            diags: self.diags[d0..].to_vec(),
            references: self.sym.references[r0..].to_vec(),
            graph,
            reads: std::mem::take(&mut self.rule_reads),
            unread: self.unread_params[u0..].iter().map(|(_, i, s, n)| (*i, *s, n.clone())).collect(),
        };
        let keep = result.diags.iter().all(|d| crate::check_cache::diag_within(d, span))
            && result.references.iter().all(|(s, _)| inside(*s))
            && result.unread.iter().all(|(_, s, _)| inside(*s));
        if keep {
            let entry = Entry { rule: r.clone(), namespace: ns.clone(), result: Arc::new(result), delta: 0 };
            self.cache.rules.insert(addr, entry);
        }
    }

    /// Adds a recorded rule's contributions, its spans moved by `delta`.
    fn replay_rule(&mut self, r: &RuleResult, delta: i64) {
        use crate::check_cache::{shift, shift_diag};
        self.diags.extend(r.diags.iter().map(|d| shift_diag(d.clone(), delta)));
        self.sym.references.extend(r.references.iter().map(|(s, n)| (shift(*s, delta), n.clone())));
        let Some((full, calls, must)) = &r.graph else { return };
        self.call_graph.entry(full.clone()).or_default().push(calls.clone());
        self.must_graph.entry(full.clone()).or_default().push(must.clone());
        for &i in &r.reads {
            self.param_reads.insert((full.clone(), i));
        }
        for (i, s, n) in &r.unread {
            self.unread_params.push((full.clone(), *i, shift(*s, delta), n.clone()));
        }
    }

    fn rule(&mut self, r: &'a Rule, ns: &Option<String>) {
        if let Some(i) = &r.iter {
            if let Some(full) = self.rule_ref(i, ns, "E0308", "iterator rule") {
                self.no_arguments_needed(&full, i.span, "iterator rule");
            }
        }
        for t in &r.transforms {
            if let Some(full) = self.rule_ref(t, ns, "E0308", "transform rule") {
                self.no_arguments_needed(&full, t.span, "transform rule");
            }
        }
        let full = (!r.name.text.is_empty()).then(|| qualify(ns, &r.name.text));
        self.params(r, full.as_deref());
        if let Some(e) = &r.weight_expr {
            let before = self.diags.len();
            self.expr(e, false, true);
            if self.diags.len() == before {
                let given = type_of(e, &|n| self.var_type(n));
                self.type_mismatch(Ty::Float, given, e, "a weight");
            }
        }
        let retire_to = r.retire.as_ref().and_then(|t| self.retirement(t, ns));
        self.rule_name = full.clone();
        let mut calls = Vec::new();
        let mut must = Vec::new();
        self.in_path = crate::paths::is_path(&r.body);
        self.body(&r.body, ns, &mut calls, &mut must);
        self.in_path = false;
        if r.retire.is_some() {
            // A retiring definition ends by turning into its other rule (or nothing):
            // for termination it must call only that rule.
            must = retire_to.iter().cloned().collect();
            calls.extend(retire_to);
        }
        self.unused_locals(0);
        self.scope = None;
        self.rule_name = None;
        if let Some(full) = full {
            self.call_graph.entry(full.clone()).or_default().push(calls);
            self.must_graph.entry(full).or_default().push(must);
        }
    }

    /// `maxdepth N > OTHER` after a rule's weight: the word, a whole N ≥ 1, and an
    /// OTHER that is defined and needs no arguments. Returns OTHER's full name.
    fn retirement(&mut self, t: &Retire, ns: &Option<String>) -> Option<String> {
        if t.keyword.text != "maxdepth" {
            self.diags.push(
                Diagnostic::error(
                    "E0302",
                    t.keyword.span,
                    format!("unknown word `{}` after the rule's weight", t.keyword.text),
                )
                .with_suggestion(
                    "rule-local retirement is `maxdepth N > OTHER`",
                    t.keyword.span,
                    "maxdepth",
                ),
            );
        }
        let n = &t.depth;
        if n.unit.is_some() || n.value.fract() != 0.0 || n.value < 1.0 || n.value > u32::MAX as f64 {
            self.diags.push(
                Diagnostic::error("E0407", n.span, format!("invalid rule-local maxdepth {}", n.text))
                    .with_label("expected a whole number of runs, 1 or more"),
            );
        }
        let other = t.other.as_ref()?;
        let full = self.rule_ref(other, ns, "E0308", "retirement rule")?;
        self.no_arguments_needed(&full, other.span, "retirement rule");
        Some(full)
    }

    /// Checks a definition's parameter list against the rule's signature and opens
    /// the body's scope with the parameters.
    fn params(&mut self, r: &'a Rule, full: Option<&str>) {
        let mut scope = Vec::new();
        if let Some(p) = &r.params {
            let mut seen_default: Option<Span> = None;
            // Names declared so far, for E0321 (a scan of `scope` per parameter made
            // a rule with 100,000 parameters take minutes).
            let mut declared: HashMap<&str, Span> = HashMap::new();
            for (i, d) in p.params.iter().enumerate() {
                let ty = match Ty::parse(&d.ty.text) {
                    Some(t) => t,
                    None => {
                        let mut diag =
                            Diagnostic::error("E0325", d.ty.span, format!("unknown parameter type `{}`", d.ty.text));
                        // Context Free's `natural` and `number`.
                        let fix = match d.ty.text.as_str() {
                            "natural" | "integer" => Some("int"),
                            "number" | "real" | "double" => Some("float"),
                            "boolean" => Some("bool"),
                            t => did_you_mean(t, TYPE_NAMES.iter().copied()),
                        };
                        diag = match fix {
                            Some(f) => diag.with_suggestion(format!("write `{f}`"), d.ty.span, f.to_string()),
                            None => diag.with_label("not a type"),
                        };
                        self.diags
                            .push(diag.with_note("parameter types: int, float, bool, and vectors vector2 … vector99"));
                        Ty::Float
                    }
                };
                let reserved = crate::lexer::KEYWORDS.contains(&d.name.text.as_str()) || d.name.text.contains('.');
                if reserved {
                    self.diags.push(
                        Diagnostic::error("E0327", d.name.span, format!("`{}` cannot name a parameter", d.name.text))
                            .with_label("a reserved word (or a dotted name)")
                            .with_note(format!(
                                "reserved words: {}; pick another name",
                                crate::lexer::KEYWORDS.join(", ")
                            )),
                    );
                }
                let twice = declared.get(d.name.text.as_str()).copied();
                if let Some(prev) = twice {
                    self.diags.push(
                        Diagnostic::error(
                            "E0321",
                            d.name.span,
                            format!("parameter `{}` is declared twice", d.name.text),
                        )
                        .with_secondary(prev, "first declared here"),
                    );
                }
                match &d.default {
                    Some(e) => {
                        let before = self.diags.len();
                        self.expr(e, false, false);
                        match self.const_value(e) {
                            None if self.diags.len() > before => {}
                            None => self.diags.push(
                                Diagnostic::error(
                                    "E0408",
                                    e.span,
                                    "a parameter default must be a compile-time constant",
                                )
                                .with_note("defaults may use numbers, @param and @define names"),
                            ),
                            Some(_) => {
                                let given = type_of(e, &|n| self.global_type(n));
                                self.type_mismatch(ty, given, e, &format!("the default of `{}`", d.name.text));
                            }
                        }
                        seen_default = Some(d.span);
                    }
                    None => {
                        if let Some(prev) = seen_default {
                            self.diags.push(
                                Diagnostic::error(
                                    "E0326",
                                    d.span,
                                    format!("parameter `{}` has no default but comes after one that has", d.name.text),
                                )
                                .with_secondary(prev, "this one has a default")
                                .with_note("parameters with defaults come last (calls pass arguments by position)"),
                            );
                        }
                    }
                }
                if twice.is_none() && !reserved {
                    declared.insert(&d.name.text, d.name.span);
                    scope.push(Local { name: d.name.text.clone(), ty, span: d.name.span, used: false, param: Some(i) });
                }
            }
        }
        // Every definition of a rule takes the same parameters as its first.
        if let Some(sig) = full.and_then(|f| self.sym.signatures.get(f)) {
            let mine = self.signature(r);
            let same = mine.params.len() == sig.params.len()
                && mine.params.iter().zip(&sig.params).all(|(a, b)| a.ty == b.ty && a.name == b.name);
            if !same {
                let first = self.sym.rules.get(full.unwrap_or_default()).and_then(|d| d.first()).map(|d| d.name_span);
                let at = r.params.as_ref().map(|p| p.span).unwrap_or(r.name.span);
                let mut d = Diagnostic::error(
                    "E0320",
                    at,
                    format!("this definition of `{}` takes different parameters", r.name.text),
                )
                .with_label(format!("the rule is `{}`", sig.label(&r.name.text)));
                if let Some(f) = first.filter(|f| *f != r.name.span) {
                    d = d.with_secondary(f, "its first definition");
                }
                self.diags.push(d.with_note("every definition of a rule has the same parameter list"));
            }
        }
        self.scope = Some(scope);
    }

    /// Warns about locals from `from` on that were never read, and closes their
    /// scope (parameters are reported once the whole rule is known).
    fn unused_locals(&mut self, from: usize) {
        let Some(scope) = self.scope.as_mut() else { return };
        let gone: Vec<Local> = scope.drain(from.min(scope.len())..).collect();
        for l in gone {
            match (l.param, &self.rule_name) {
                (Some(i), Some(rule)) if l.used => {
                    self.param_reads.insert((rule.clone(), i));
                    self.rule_reads.push(i);
                }
                (Some(i), Some(rule)) => self.unread_params.push((rule.clone(), i, l.span, l.name)),
                (Some(_), None) => {}
                // A vector's components (`v[1]`): `crate::vectors` reports the vector.
                (None, _) if !l.used && !l.name.starts_with('_') && !l.name.contains('[') => {
                    self.diags.push(unused(&l, "local"))
                }
                (None, _) => {}
            }
        }
    }

    /// W0006 for the parameters no definition and no selector reads (at the first
    /// definition that declares them).
    fn unread_params(&mut self) {
        let mut seen = BTreeSet::new();
        for (rule, i, span, name) in std::mem::take(&mut self.unread_params) {
            if self.param_reads.contains(&(rule.clone(), i)) || !seen.insert((rule.clone(), i)) {
                continue;
            }
            if !name.starts_with('_') && !name.contains('[') {
                let l = Local { name, ty: Ty::Float, span, used: false, param: Some(i) };
                self.diags.push(unused(&l, "parameter"));
            }
        }
    }

    /// Opens a binding (`let`, loop variable) in the current scope.
    fn bind(&mut self, name: &Name, ty: Ty) {
        let Some(scope) = self.scope.as_mut() else { return };
        if let Some(prev) = scope.iter().find(|l| l.name == name.text) {
            let prev = prev.span;
            self.diags.push(
                Diagnostic::error("E0321", name.span, format!("`{}` is already defined in this rule", name.text))
                    .with_secondary(prev, "defined here")
                    .with_note("give the new binding another name (bindings cannot shadow each other)"),
            );
            return;
        }
        scope.push(Local { name: name.text.clone(), ty, span: name.span, used: false, param: None });
    }

    /// The type of a name outside rule bodies: `@param` by its declared type,
    /// `@define` by its value, `true`/`false`, and the run-time variables.
    fn global_type(&self, name: &str) -> Option<Ty> {
        if let Some(p) = self.ex.params.iter().find(|p| p.name.text == name) {
            return Ty::parse(&p.ty).or(Some(Ty::Float));
        }
        if let Some(v) = self.ex.defines.get(name) {
            return Some(if v.is_some_and(|v| v.fract() != 0.0) { Ty::Float } else { Ty::Int });
        }
        match name {
            "true" | "false" => Some(Ty::Bool),
            "depth" => Some(Ty::Int),
            _ => None,
        }
    }

    /// The type of a name in the current scope.
    fn var_type(&self, name: &str) -> Option<Ty> {
        if let Some(l) = self.scope.as_ref().and_then(|s| s.iter().rev().find(|l| l.name == name)) {
            return Some(l.ty);
        }
        self.global_type(name)
    }

    /// Reports `e` (of type `given`) where a `want` is expected.
    fn type_mismatch(&mut self, want: Ty, given: Ty, e: &Expr, what: &str) {
        if want.accepts(given) {
            return;
        }
        let text = crate::fmt::expr(strip(e));
        let mut d = Diagnostic::error(
            "E0323",
            e.span,
            format!("{what} is {}, but this is {}", want.article(), given.article()),
        );
        d = match crate::types::conversion(want, given, &text) {
            Some(fix) => d.with_suggestion(format!("convert it: `{fix}`"), e.span, fix),
            None => d.with_label(format!("expected `{}`", want.name())),
        };
        self.diags.push(d);
    }

    /// Checks a call's arguments against the callee's signature.
    fn call_args(&mut self, full: &str, name: &Name, args: Option<&'a CallArgs>) {
        let sig = self.sym.signatures.get(full).cloned().unwrap_or_default();
        let given = args.map(|a| a.args.len()).unwrap_or(0);
        let (lo, hi) = (sig.required(), sig.params.len());
        if given < lo || given > hi {
            let want = if lo == hi { format!("{lo}") } else { format!("{lo} to {hi}") };
            let at = args.map(|a| a.span).unwrap_or(name.span);
            let mut d = Diagnostic::error(
                "E0322",
                at,
                format!("`{}` takes {want} argument(s) but {given} were given", name.text),
            )
            .with_label(format!("the rule is `{}`", sig.label(&name.text)));
            if args.is_none() && lo > 0 {
                let names: Vec<&str> = sig.params[..lo].iter().map(|p| p.name.as_str()).collect();
                let end = Span::new(name.span.file, name.span.end, name.span.end);
                d = d.with_suggestion("pass the arguments", end, format!("({})", names.join(", ")));
            }
            self.diags.push(d);
        }
        let Some(args) = args else { return };
        for (a, p) in args.args.iter().zip(&sig.params) {
            self.expr(a, false, true);
            let given = type_of(a, &|n| self.var_type(n));
            self.type_mismatch(p.ty, given, a, &format!("parameter `{}` of `{}`", p.name, name.text));
        }
        for a in args.args.iter().skip(sig.params.len()) {
            self.expr(a, false, true);
        }
        self.runaway(full, name, &sig, args);
    }

    /// W0007: a direct recursion whose guard can never become false (`if (n > 0)`
    /// around `R(n + 1)`), in a program with no `maxdepth` or `minsize`.
    fn runaway(&mut self, full: &str, name: &Name, sig: &Signature, args: &CallArgs) {
        if self.rule_name.as_deref() != Some(full) || self.guards.is_empty() || self.has_limit() {
            return;
        }
        let param_of = |e: &Expr| -> Option<usize> {
            match &strip(e).kind {
                ExprKind::Var(v) => sig.params.iter().position(|p| p.name == v.text),
                _ => None,
            }
        };
        // The change an argument makes to parameter i: `p`, `p + k`, `p - k`.
        let change = |i: usize, a: &Expr| -> Option<f64> {
            let a = strip(a);
            if param_of(a) == Some(i) {
                return Some(0.0);
            }
            match &a.kind {
                ExprKind::Binary(op @ (BinOp::Add | BinOp::Sub), x, k) if param_of(x) == Some(i) => {
                    let k = self.const_value(k)?;
                    Some(if *op == BinOp::Add { k } else { -k })
                }
                _ => None,
            }
        };
        for &(cond, taken) in &self.guards {
            let ExprKind::Binary(op, l, r) = &strip(cond).kind else { continue };
            let Some(i) = param_of(l) else { continue };
            if self.const_value(r).is_none() {
                continue;
            }
            let Some(arg) = args.args.get(i) else { continue };
            let Some(delta) = change(i, arg) else { continue };
            // Whether the guard, true now, stays true for the argument.
            let stays = match (op, taken) {
                (BinOp::Gt | BinOp::Ge, true) | (BinOp::Lt | BinOp::Le, false) => delta >= 0.0,
                (BinOp::Lt | BinOp::Le, true) | (BinOp::Gt | BinOp::Ge, false) => delta <= 0.0,
                _ => false,
            };
            if stays {
                let p = &sig.params[i].name;
                let dir = if delta > 0.0 {
                    "grows"
                } else if delta < 0.0 {
                    "shrinks"
                } else {
                    "stays the same"
                };
                self.diags.push(
                    Diagnostic::warning("W0007", arg.span, format!("this recursion of `{}` never stops", name.text))
                        .with_label(format!("`{p}` {dir} here"))
                        .with_secondary(cond.span, "so this condition stays true")
                        .with_note("move the parameter towards the end of the condition, or add `maxdepth N`"),
                );
                return;
            }
        }
    }

    fn has_limit(&self) -> bool {
        self.ex.items.iter().any(|ExpItem { item, .. }| {
            matches!(&item.kind, ItemKind::Directive { name, .. } if matches!(name.text.as_str(), "maxdepth" | "minsize" | "maxobjects"))
        })
    }

    fn body(&mut self, items: &'a [BodyItem], ns: &Option<String>, calls: &mut Vec<String>, must: &mut Vec<String>) {
        let scope_at = self.scope.as_ref().map(|s| s.len()).unwrap_or(0);
        for item in items {
            self.item(item, ns, calls, must);
        }
        self.unused_locals(scope_at);
    }

    /// One body item. Kept small (the heavy cases are functions of their own): blocks
    /// nest up to the parse limit, and each level costs this frame and `body`'s on the
    /// stack of the language server's analysis thread.
    fn item(&mut self, item: &'a BodyItem, ns: &Option<String>, calls: &mut Vec<String>, must: &mut Vec<String>) {
        match &item.kind {
            BodyKind::Call { name, args, profile, adj } => {
                self.call_item(name, args.as_ref(), profile.as_ref(), adj, ns, calls, must)
            }
            BodyKind::Iterate { count, divisor, adj, item, .. } => {
                let dynamic = self.count(count, false);
                if let Some(d) = divisor {
                    self.count(d, true);
                }
                self.adj_list(adj);
                self.no_seed(adj, "an iterator");
                self.conditional += dynamic as u32;
                self.body(std::slice::from_ref(item), ns, calls, must);
                self.conditional -= dynamic as u32;
            }
            BodyKind::Block(items) => self.body(items, ns, calls, must),
            // Expansion replaces a `switch` by what it means; read that here too.
            BodyKind::Switch(s) => self.item(&s.lowered, ns, calls, must),
            BodyKind::If { cond, then, otherwise, .. } => {
                self.expr(cond, false, true);
                self.conditional += 1;
                self.guards.push((cond, true));
                self.body(then, ns, calls, must);
                self.guards.pop();
                if let Some(o) = otherwise {
                    self.guards.push((cond, false));
                    self.body(std::slice::from_ref(o), ns, calls, must);
                    self.guards.pop();
                }
                self.conditional -= 1;
            }
            BodyKind::Let { name, value } => {
                self.expr(value, false, true);
                let ty = type_of(value, &|n| self.var_type(n));
                if self.scope.is_some() {
                    self.bind(name, ty);
                }
            }
            BodyKind::Loop { var, range, adj, item } => {
                let LoopRange { start, end, step } = &**range;
                for e in [Some(start), Some(end), step.as_ref()].into_iter().flatten() {
                    self.expr(e, false, true);
                }
                let tys: Vec<Ty> = [Some(start), step.as_ref()]
                    .into_iter()
                    .flatten()
                    .map(|e| type_of(e, &|n| self.var_type(n)))
                    .collect();
                if let Some(s) = step {
                    if self.const_value(s) == Some(0.0) {
                        self.diags.push(
                            Diagnostic::error("E0403", s.span, "a loop step of 0 never reaches the end")
                                .with_label("this is 0"),
                        );
                    }
                }
                self.adj_list(adj);
                self.no_seed(adj, "a `loop`");
                let mark = self.scope.as_ref().map(|s| s.len()).unwrap_or(0);
                let ty = if tys.iter().all(|t| *t == Ty::Int) { Ty::Int } else { Ty::Float };
                self.bind(var, ty);
                self.conditional += 1;
                self.body(std::slice::from_ref(item), ns, calls, must);
                self.conditional -= 1;
                self.unused_locals(mark);
            }
            BodyKind::Pre(_) | BodyKind::Error => {}
        }
    }

    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn call_item(
        &mut self,
        name: &'a Name,
        args: Option<&'a CallArgs>,
        profile: Option<&'a Name>,
        adj: &'a AdjList,
        ns: &Option<String>,
        calls: &mut Vec<String>,
        must: &mut Vec<String>,
    ) {
        if self.sym.is_drawable(&name.text) {
            self.no_seed(adj, "a drawable");
        }
        if self.sym.is_drawable(&name.text) && crate::paths::is_path_op(&name.text, self.in_path) {
            self.path_item(name, args, profile);
        } else if self.sym.is_drawable(&name.text) {
            if let Some(a) = args {
                let d = Diagnostic::error("E0322", a.span, format!("`{}` takes no arguments", name.text))
                    .with_suggestion("remove them", a.span, String::new());
                self.diags.push(if !matches!(name.text.as_str(), "MOVETO" | "LINETO") {
                    d
                } else {
                    d.with_note(
                        "`MOVETO(x, y)` and `LINETO(x, y)` are flat path points: only in a rule that paints a path \
                             (FILL, STROKE) or uses ARCTO, CURVETO or CLOSEPOLY (reference §9, \"Flat paths\")",
                    )
                });
            }
            if let Some(p) = profile {
                let last = name.text.rsplit('.').next().unwrap_or("");
                if !PROFILE_DRAWABLES.contains(&last) {
                    self.diags.push(Diagnostic::error(
                        "E0101",
                        p.span,
                        format!("`{}` does not take a profile rule", name.text),
                    ));
                } else if let Some(full) = self.rule_ref(p, ns, "E0301", "profile rule") {
                    self.no_arguments_needed(&full, p.span, "profile rule");
                    self.called(full, calls, must);
                }
            }
        } else if let Some(p) = profile {
            self.diags.push(
                Diagnostic::error("E0101", p.span, format!("unexpected `{}` after the rule name", p.text))
                    .with_label("only MOVETO, LINETO, BLENDTO, SLINETO and ALINETO take a profile rule"),
            );
        } else {
            match self.sym.resolve(&name.text, ns.as_deref()) {
                Some(full) => {
                    self.sym.references.push((name.span, full.clone()));
                    self.call_args(&full, name, args);
                    if self.profile_rules.contains(&full) {
                        self.diags.push(
                            Diagnostic::warning(
                                "W0010",
                                name.span,
                                format!("`{}` is a profile rule, called here as a shape", name.text),
                            )
                            .with_label("its VERTEX points outline a swept profile; here they draw triangles")
                            .with_note(format!(
                                "sweep it along a path: `MOVETO {{}} LINETO {} {{z 1}}` (Context Free's `CIRCLE` is a shape; MDG's `circle` is a profile, `SPHERE` or `disc` are shapes)",
                                name.text
                            )),
                        );
                    }
                    self.called(full, calls, must);
                }
                None => {
                    self.unknown_rule(name);
                    for a in args.iter().flat_map(|a| &a.args) {
                        self.expr(a, false, true);
                    }
                }
            }
        }
        self.adj_list(adj);
    }

    /// A flat path's drawable (reference §9, "Flat paths"): its option word and
    /// number of arguments (E0411, E0401), and its arguments as expressions.
    fn path_item(&mut self, name: &'a Name, args: Option<&'a CallArgs>, word: Option<&'a Name>) {
        let mut bits = 0;
        if let Some(w) = word {
            match crate::paths::option_bits(&name.text, &w.text) {
                Ok(b) => bits = b,
                Err(e) => {
                    let d = Diagnostic::error("E0411", w.span, e.to_string());
                    self.diags.push(if matches!(name.text.as_str(), "MOVETO" | "LINETO") {
                        d.with_note("in a flat path MOVETO and LINETO take no profile rule: they draw no 3D line")
                    } else {
                        d
                    });
                }
            }
        }
        let given = args.map(|a| a.args.len()).unwrap_or(0);
        if !crate::paths::arities(&name.text, bits).contains(&given) {
            let span = args.map_or(name.span, |a| a.span);
            self.diags.push(Diagnostic::error(
                "E0401",
                span,
                format!(
                    "`{}` in a flat path takes {} arguments, not {given}",
                    name.text,
                    crate::paths::arity_text(&name.text, bits)
                ),
            ));
        }
        for a in args.iter().flat_map(|a| &a.args) {
            self.expr(a, false, true);
        }
    }

    /// Records a call of rule `full` in the call graphs.
    fn called(&mut self, full: String, calls: &mut Vec<String>, must: &mut Vec<String>) {
        if self.conditional == 0 {
            must.push(full.clone());
        }
        calls.push(full);
    }

    fn unknown_rule(&mut self, name: &Name) {
        let mut cands: Vec<&str> = self.sym.rules.keys().map(|k| k.as_str()).collect();
        cands.extend(DRAWABLES);
        cands.extend(self.sym.isosurfaces.keys().map(|k| k.as_str()));
        let mut d = Diagnostic::error("E0301", name.span, format!("unknown rule `{}`", name.text));
        if let Some(lib) = crate::stdlib::library_defining(&name.text) {
            // A std name (thesis Listing 4.1 calls `SPHERE {}` as if it
            // were built in): the fix adds the import.
            let top = crate::span::Span::new(name.span.file, 0, 0);
            d = d
                .with_label(format!("`{}` is defined by the std library `{lib}`, which is not imported", name.text))
                .with_suggestion(format!("add `@import {lib}`"), top, format!("@import {lib}\n"));
        } else if let Some(s) = did_you_mean(&name.text, cands) {
            d = d.with_suggestion(format!("did you mean `{s}`?"), name.span, s.to_string());
        } else {
            d = d.with_label("no rule or drawable has this name");
        }
        self.diags.push(d);
    }

    /// The compile-time value of a count expression, if it has one.
    fn const_value(&self, e: &Expr) -> Option<f64> {
        let scope = self.scope.as_deref().unwrap_or(&[]);
        crate::consteval::eval(e, &|n| {
            if scope.iter().any(|l| l.name == n) {
                return None;
            }
            self.ex.constant(n)
        })
    }

    /// Checks an iterator count (or divisor); returns whether it is known only at run
    /// time (a count over parameters, locals, `depth` or `scale`).
    fn count(&mut self, c: &Count, divisor: bool) -> bool {
        let value = match c {
            Count::Num(n) => {
                if n.unit.is_some() {
                    self.unit_error(n);
                    return false;
                }
                n.value
            }
            Count::Neg(n) => -n.value,
            Count::Expr(e) if !divisor && self.const_value(e).is_none() => {
                let before = self.diags.len();
                self.expr(e, false, false);
                if self.diags.len() == before {
                    let given = type_of(e, &|n| self.var_type(n));
                    self.type_mismatch(Ty::Int, given, e, "an iteration count");
                }
                return true;
            }
            Count::Expr(e) => {
                // Run-time variables are known names here, just not constants.
                let before = self.diags.len();
                self.expr(e, true, false);
                match self.const_value(e) {
                    Some(v) => v,
                    None => {
                        if self.diags.len() == before {
                            self.diags.push(
                                Diagnostic::error(
                                    "E0408",
                                    e.span,
                                    "an iterator divisor must be a compile-time constant",
                                )
                                .with_note("divisors may use numbers, @param and @define names"),
                            );
                        }
                        return false;
                    }
                }
            }
        };
        if divisor {
            // (NaN and infinity too: every step would be NaN or 0.)
            if !(value > 0.0 && value.is_finite()) {
                self.diags.push(
                    Diagnostic::error("E0402", c.span(), "the iterator divisor must be greater than 0")
                        .with_label(format!("this is {value}")),
                );
            }
        } else if value < 0.0 || value.fract() != 0.0 {
            self.diags.push(
                Diagnostic::error("E0403", c.span(), "the iteration count must be a whole number ≥ 0")
                    .with_label(format!("this is {value}")),
            );
        }
        false
    }

    fn unit_error(&mut self, n: &Number) {
        let unit = n.unit.unwrap_or('?');
        let plain = &n.text[..n.text.len() - 1];
        self.diags.push(
            Diagnostic::error("E0404", n.span, format!("unit suffix `{unit}` on a value that is not an angle"))
                .with_suggestion("remove the suffix", n.span, plain.to_string()),
        );
    }

    /// Reports a malformed colour value (`#ff880`, `#tomatoe`): E0410.
    fn colour_value(&mut self, name: &Name) {
        use crate::colour::ColourError;
        let Err(e) = crate::colour::parse(&name.text) else { return };
        let word = &name.text[1..];
        let d = match e {
            ColourError::Length(n) => {
                Diagnostic::error("E0410", name.span, format!("colour value `{}` has {n} hex digits", name.text))
                    .with_label("3, 4, 6 or 8 hex digits")
                    .with_note("`#rgb`, `#rgba`, `#rrggbb` or `#rrggbbaa`, or a colour name such as `#tomato`")
            }
            ColourError::NotHex(i, c) => {
                let at = name.span.start + 1 + word.char_indices().nth(i).map_or(0, |(b, _)| b as u32);
                Diagnostic::error(
                    "E0410",
                    name.span,
                    format!("`{c}` is not a hex digit in colour value `{}`", name.text),
                )
                .with_secondary(Span::new(name.span.file, at, at + c.len_utf8() as u32), "not 0-9 or a-f")
                .with_note("`#rgb`, `#rgba`, `#rrggbb` or `#rrggbbaa`, or a colour name such as `#tomato`")
            }
            ColourError::UnknownName(near) => {
                let d = Diagnostic::error("E0410", name.span, format!("unknown colour name `{}`", name.text));
                match near {
                    Some(s) => d.with_suggestion(format!("did you mean `#{s}`?"), name.span, format!("#{s}")),
                    None => d
                        .with_label("not a colour name")
                        .with_note("colour names are CSS's named colours (`#tomato`, `#navy`, `#gold`, …)"),
                }
            }
        };
        self.diags.push(d);
    }

    /// E0412 for each `seed N` in `adj`, the adjustments of `what` (not a rule call).
    fn no_seed(&mut self, adj: &AdjList, what: &str) {
        for a in &adj.adjs {
            if self.sym.components.adj_kind(&a.name.text) == Some(AdjKind::Seed) {
                self.diags.push(
                    Diagnostic::error("E0412", a.name.span, format!("`seed` on {what}"))
                        .with_label("only a rule call can be seeded")
                        .with_note("`seed N` gives a rule call's sub-derivation its own random stream: write it on the call inside (`R {seed N}`)"),
                );
            }
        }
    }

    fn adj_list(&mut self, adj: &AdjList) {
        self.context_free_order(adj);
        for a in &adj.adjs {
            if a.name.text.is_empty() {
                continue; // A recovered syntax error, already reported.
            }
            let Some(kind) = self.sym.components.adj_kind(&a.name.text) else {
                let names = self.sym.components.all_names();
                let mut d = Diagnostic::error("E0303", a.name.span, format!("unknown adjustment `{}`", a.name.text));
                if let Some(s) = did_you_mean(&a.name.text, names) {
                    d = d.with_suggestion(format!("did you mean `{s}`?"), a.name.span, s.to_string());
                } else {
                    d = d.with_label("not an adjustment").with_note("adjustments: x y z r rx ry rz s f fx fy fz up down left right rollleft rollright fps, and the colour/weight components");
                }
                self.diags.push(d);
                continue;
            };
            if kind == AdjKind::Paint {
                self.colour_value(&a.name);
            }
            let (lo, hi) = kind.arity();
            if a.args.len() < lo || a.args.len() > hi {
                let want = if lo == hi { format!("{lo}") } else { format!("{lo} to {hi}") };
                let mut d = Diagnostic::error(
                    "E0401",
                    a.span,
                    format!("`{}` takes {want} argument(s) but {} were given", a.name.text, a.args.len()),
                )
                .with_label("wrong number of arguments");
                // Context Free's `f A` (`flip A`) reflects across the line at angle A:
                // MDG's `f X Y Z` takes the plane's normal, (−sin A, cos A, 0).
                if matches!(a.name.text.as_str(), "f" | "flip") && a.args.len() == 1 {
                    if let Some(Arg::Num(n) | Arg::Neg(n)) = a.args.first() {
                        let deg = if matches!(a.args.first(), Some(Arg::Neg(_))) { -n.value } else { n.value };
                        let (s, c) = deg.to_radians().sin_cos();
                        let r = |v: f64| {
                            let v = (v * 1e6).round() / 1e6;
                            if v == 0.0 {
                                "0".to_string()
                            } else {
                                format!("{v}")
                            }
                        };
                        let mdg = format!("{} {} {} 0", a.name.text, r(-s), r(c));
                        d = d
                            .with_note(format!(
                                "Context Free's `{} A` reflects across the line at angle A; MDG's takes the mirror's normal",
                                a.name.text
                            ))
                            .with_suggestion(format!("write `{mdg}`"), a.span, mdg);
                    }
                }
                self.diags.push(d);
            }
            for arg in &a.args {
                match arg {
                    Arg::Num(n) | Arg::Neg(n) => {
                        if n.unit.is_some() && !kind.is_angle() {
                            self.unit_error(n);
                        }
                    }
                    Arg::Expr(e) => {
                        let before = self.diags.len();
                        self.expr(e, false, true);
                        if self.diags.len() == before {
                            self.non_finite_argument(e);
                        }
                    }
                }
            }
        }
    }

    /// W0013: an adjustment argument whose compile-time value is NaN or infinite
    /// (`y (0/0)`, `s (1e308 * 10)`): the transform uses 0 for it, as evaluation does
    /// for such a value computed at run time.
    fn non_finite_argument(&mut self, e: &Expr) {
        let Some(v) = self.const_value(e).filter(|v| !v.is_finite()) else { return };
        let what = if v.is_nan() { "NaN (not a number)" } else { "infinite" };
        self.diags.push(
            Diagnostic::warning("W0013", e.span, format!("this adjustment argument is {what}"))
                .with_label(match v {
                    v if v.is_nan() => "this is NaN",
                    v if v > 0.0 => "this is infinity",
                    _ => "this is -infinity",
                })
                .with_note("an argument that is not a finite number is used as 0 (at run time too, with a warning)"),
        );
    }

    /// W0008: a `[ … ]` list that Context Free would reorder (CF3 applies single-bracket
    /// lists as translate, rotate, scale, flip; MDG applies every list as written), where
    /// the two orders give different frames: a rotation before a translation off its
    /// axis, or a scale or flip before a translation.
    fn context_free_order(&mut self, adj: &AdjList) {
        if !adj.square {
            return;
        }
        for a in &adj.adjs {
            if matches!(a.name.text.as_str(), "r" | "rotate") && a.args.len() == 1 {
                let arg = match &a.args[0] {
                    Arg::Num(n) => n.text.clone(),
                    Arg::Neg(n) => format!("-{}", n.text),
                    Arg::Expr(e) => crate::fmt::expr(e),
                };
                self.diags.push(
                    Diagnostic::warning("W0011", a.span, format!("`{} {arg}` turns about x", a.name.text))
                        .with_label("one angle is a rotation about the x axis")
                        .with_suggestion("turn about z, as Context Free's `r` does", a.span, format!("rz {arg}"))
                        .with_note("`r X Y Z` turns about x, then y, then z; write `rx`, `ry` or `rz` for one axis"),
                );
            }
        }
        let comps = &self.sym.components;
        let rank = |a: &Adj| match comps.adj_kind(&a.name.text) {
            Some(AdjKind::Translate(_)) => 0,
            Some(AdjKind::Rotate(_) | AdjKind::Turn(..)) => 1,
            Some(AdjKind::Scale) => 2,
            Some(AdjKind::Flip(_)) => 3,
            _ => 4,
        };
        // The translation axes (0..2, or all for `x X Y Z`) and the rotation axis.
        let axis = |a: &Adj| match comps.adj_kind(&a.name.text) {
            Some(AdjKind::Translate(0)) if a.args.len() > 1 => 3,
            Some(AdjKind::Translate(ax) | AdjKind::Rotate(ax) | AdjKind::Turn(ax, _)) => ax,
            _ => 3,
        };
        let mut differs = false;
        for (i, a) in adj.adjs.iter().enumerate() {
            if rank(a) != 0 {
                continue;
            }
            for b in &adj.adjs[..i] {
                let r = rank(b);
                let commutes = r == 1 && axis(b) != 3 && axis(b) == axis(a);
                if (1..=3).contains(&r) && !commutes {
                    differs = true;
                }
            }
        }
        if !differs {
            return;
        }
        let mut sorted: Vec<&Adj> = adj.adjs.iter().collect();
        sorted.sort_by_key(|a| rank(a));
        let text: Vec<String> = sorted.iter().map(|a| crate::fmt::adjustment(a)).collect();
        self.diags.push(
            Diagnostic::warning("W0008", adj.span, "Context Free would apply this list in another order")
                .with_label("MDG applies adjustments in the order written")
                .with_suggestion(
                    "reorder it as Context Free would (translate, rotate, scale, flip)",
                    adj.span,
                    format!("[{}]", text.join(" ")),
                )
                .with_note("in Context Free 3, `[ … ]` is reordered and `[[ … ]]` keeps the written order; in MDG both brackets keep it"),
        );
    }

    /// Checks an expression. `function_vars`: x y z depth scale g are in scope;
    /// `random`: rand/randn are allowed.
    /// `function F` names a function of x, y, z: one with parameters must be called.
    fn function_ref_arity(&mut self, f: &Name) {
        if let Some((_, decl, params, _)) = self.ex.user_function(&f.text) {
            self.diags.push(
                Diagnostic::error("E0401", f.span, format!("`{}` takes {} argument(s)", f.text, params.len()))
                    .with_secondary(decl.span, "declared here")
                    .with_note(format!("call it inside an expression: `function {{ {}(…) }}`", f.text)),
            );
        }
    }

    /// E0331 for a recursive function every evaluation of which calls itself again
    /// (directly or through the other functions of its cycle): no call returns.
    fn never_returns(&mut self, index: usize, name: &Name) {
        let graph = crate::functions::CallGraph::new(self.ex);
        if graph.recursive().contains(&index) && graph.never_returns(self.ex, index) {
            self.diags.push(
                Diagnostic::error("E0331", name.span, format!("function `{}` calls itself on every path", name.text))
                    .with_label("no call of it can return")
                    .with_note(
                        "give it a case without the recursive call, chosen with `if` or `select`: `if(n <= 1, 1, n * fact(n - 1))`",
                    ),
            );
        }
    }

    /// The parameters of `function NAME(a, b)`: plain names, each once.
    fn function_params(&mut self, params: &[Name]) {
        for (i, p) in params.iter().enumerate() {
            if let Some(prev) = params[..i].iter().find(|q| q.text == p.text) {
                self.diags.push(
                    Diagnostic::error("E0321", p.span, format!("parameter `{}` is declared twice", p.text))
                        .with_secondary(prev.span, "first declared here"),
                );
            } else if p.text.contains('.') || FUNCTION_VARS.contains(&p.text.as_str()) {
                self.diags.push(
                    Diagnostic::error("E0327", p.span, format!("`{}` cannot name a function parameter", p.text))
                        .with_note("x, y, z, depth, scale, g and dotted names are reserved; pass them as arguments"),
                );
            }
        }
    }

    /// A call of a name that is no math function: a function declared with
    /// parameters (`function NAME(a, b) { … }`), declared before the function being
    /// checked, with as many arguments as it has parameters.
    fn user_call(&mut self, e: &Expr, f: &Name, args: &[Expr]) {
        let Some((_, decl, params, _)) = self.ex.user_function(&f.text) else {
            let mut names: Vec<&str> = FUNCTIONS.iter().map(|(n, _)| *n).collect();
            let users: Vec<String> = self
                .ex
                .items
                .iter()
                .filter_map(|i| match &i.item.kind {
                    ItemKind::Function { name, params, .. } if !params.is_empty() => Some(name.text.clone()),
                    _ => None,
                })
                .collect();
            names.extend(users.iter().map(|s| s.as_str()));
            let mut d = Diagnostic::error("E0310", f.span, format!("unknown function `{}`", f.text));
            let printed: Vec<String> = args.iter().map(crate::fmt::expr).collect();
            if let Some((mdg, what)) = crate::cfdg::function(&f.text, &printed) {
                // Context Free's function: the MDG expression that does the same.
                d = d.with_label(what).with_suggestion(format!("write `{mdg}`"), e.span, mdg);
            } else if let Some(s) = did_you_mean(&f.text, names) {
                d = d.with_suggestion(format!("did you mean `{s}`?"), f.span, s.to_string());
            }
            self.diags.push(d);
            return;
        };
        if args.len() != params.len() {
            self.diags.push(
                Diagnostic::error(
                    "E0401",
                    e.span,
                    format!("`{}` takes {} argument(s) but {} were given", f.text, params.len(), args.len()),
                )
                .with_secondary(decl.span, "declared here"),
            );
        }
    }

    fn expr(&mut self, e: &Expr, function_vars: bool, random: bool) {
        match &e.kind {
            ExprKind::Num(_) | ExprKind::Error => {}
            // Not in a checked program: `crate::vectors` rewrote them into scalars.
            ExprKind::Tuple(xs) => {
                for x in xs {
                    self.expr(x, function_vars, random);
                }
            }
            ExprKind::Index(v, i) => {
                self.expr(v, function_vars, random);
                self.expr(i, function_vars, random);
            }
            ExprKind::Var(v) => {
                if self.lets.contains(&v.text) {
                    return;
                }
                if let Some(l) = self.scope.as_mut().and_then(|s| s.iter_mut().rev().find(|l| l.name == v.text)) {
                    l.used = true;
                    return;
                }
                if self.function.as_ref().is_some_and(|(_, ps)| ps.contains(&v.text)) {
                    return;
                }
                let in_body = self.scope.is_some();
                let known = self.ex.constant(&v.text).is_some()
                    || self.ex.params.iter().any(|p| p.name.text == v.text)
                    || (in_body && matches!(v.text.as_str(), "depth" | "scale"))
                    || (function_vars && FUNCTION_VARS.contains(&v.text.as_str()));
                if !known {
                    let mut cands: Vec<&str> = self.ex.params.iter().map(|p| p.name.text.as_str()).collect();
                    cands.extend(self.ex.defines.keys().map(|k| k.as_str()));
                    if function_vars {
                        cands.extend(FUNCTION_VARS);
                    }
                    let locals: Vec<String> = self.scope.iter().flatten().map(|l| l.name.clone()).collect();
                    cands.extend(locals.iter().map(|s| s.as_str()));
                    if in_body {
                        cands.extend(["depth", "scale"]);
                    }
                    let mut d = Diagnostic::error("E0311", v.span, format!("unknown variable `{}`", v.text));
                    if let Some(s) = did_you_mean(&v.text, cands) {
                        d = d.with_suggestion(format!("did you mean `{s}`?"), v.span, s.to_string());
                    } else if function_vars {
                        d = d.with_note("expressions may use x, y, z, depth, scale, g and @param names");
                    } else if in_body {
                        d = d.with_note(
                            "in a rule body expressions may use the rule's parameters, `let` bindings, loop variables, depth, scale and @param/@define names",
                        );
                    } else {
                        d = d.with_note("here expressions may use numbers and @param/@define names");
                    }
                    self.diags.push(d);
                }
            }
            ExprKind::Neg(x) | ExprKind::Paren(x) | ExprKind::Not(x) => self.expr(x, function_vars, random),
            ExprKind::Binary(_, a, b) => {
                self.expr(a, function_vars, random);
                self.expr(b, function_vars, random);
            }
            ExprKind::Let(bindings, body) => {
                let outer = self.lets.len();
                for (n, v) in bindings {
                    self.expr(v, function_vars, random);
                    if n.text.contains('.') || FUNCTION_VARS.contains(&n.text.as_str()) {
                        self.diags.push(
                            Diagnostic::error("E0329", n.span, format!("`{}` cannot name a `let(…)` binding", n.text))
                                .with_note(
                                    "x, y, z, depth, scale, g and dotted names are reserved; choose another name",
                                ),
                        );
                    }
                    self.lets.push(n.text.clone());
                }
                self.expr(body, function_vars, random);
                self.lets.truncate(outer);
            }
            ExprKind::Call(f, args) if SPECIAL_FORMS.iter().any(|(n, _)| *n == f.text) => {
                let least = SPECIAL_FORMS.iter().find(|(n, _)| *n == f.text).map_or(0, |(_, k)| *k);
                let wrong = if f.text == "if" { args.len() != least } else { args.len() < least };
                if wrong {
                    let want = if f.text == "if" {
                        "`if` takes 3 arguments: `if(condition, then, else)`"
                    } else {
                        "`select` takes an index and at least one choice: `select(i, a, b, …)`"
                    };
                    self.diags.push(Diagnostic::error("E0401", e.span, format!("{want}; {} were given", args.len())));
                }
                for a in args {
                    self.expr(a, function_vars, random);
                }
            }
            ExprKind::Call(f, args) => {
                match FUNCTIONS.iter().find(|(n, _)| *n == f.text) {
                    Some((_, arity)) => {
                        if (f.text == "rand" || f.text == "randn") && !random {
                            self.diags.push(
                                Diagnostic::error("E0409", f.span, format!("`{}` is not allowed here", f.text))
                                    .with_note("random draws are allowed in adjustment arguments only"),
                            );
                        }
                        if args.len() != *arity {
                            self.diags.push(Diagnostic::error(
                                "E0401",
                                e.span,
                                format!("`{}` takes {arity} argument(s) but {} were given", f.text, args.len()),
                            ));
                        }
                    }
                    None => self.user_call(e, f, args),
                }
                if matches!(f.text.as_str(), "sin" | "cos" | "tan") {
                    if let [a] = args.as_slice() {
                        if let ExprKind::Num(n) = &strip(a).kind {
                            let v = n.value;
                            if n.unit.is_none() && v.fract() == 0.0 && v.abs() > std::f64::consts::TAU {
                                self.diags.push(
                                    Diagnostic::warning(
                                        "W0009",
                                        a.span,
                                        format!("`{}` takes radians; `{}` looks like degrees", f.text, n.text),
                                    )
                                    .with_suggestion(
                                        "convert from degrees",
                                        a.span,
                                        format!("radians({})", n.text),
                                    )
                                    .with_note("math functions take radians; adjustments (`rz 90`) and Context Free's functions take degrees"),
                                );
                            }
                        }
                    }
                }
                for a in args {
                    self.expr(a, function_vars, random);
                }
            }
        }
    }

    fn selector(&mut self, rules: &[Name], mode: &SelectorMode, ns: &Option<String>) {
        for r in rules {
            let Some(full) = self.rule_ref(r, ns, "E0305", "selected rule") else { continue };
            if let Some((_, prev)) = self.sym.selectors.get(&full) {
                let prev = *prev;
                self.diags.push(
                    Diagnostic::error("E0312", r.span, format!("rule `{}` already has a selector", r.text))
                        .with_secondary(prev, "selector given here"),
                );
                continue;
            }
            self.sym.selectors.insert(full.clone(), (mode.clone(), r.span));
            if self.sym.rules.get(&full).is_some_and(|d| d.len() == 1) {
                self.diags.push(
                    Diagnostic::warning(
                        "W0005",
                        r.span,
                        format!("rule `{}` has one definition: the selector has no effect", r.text),
                    )
                    .with_label("only one definition to choose from"),
                );
            }
        }
        match mode {
            SelectorMode::Word(w) => {
                if !SELECTOR_MODES.contains(&w.text.as_str()) || w.text == "function" {
                    let mut d = Diagnostic::error("E0304", w.span, format!("unknown selector mode `{}`", w.text));
                    if let Some(s) = did_you_mean(&w.text, SELECTOR_MODES.iter().copied()) {
                        d = d.with_suggestion(format!("did you mean `{s}`?"), w.span, s.to_string());
                    } else {
                        d = d.with_note("modes: random, frequency, depth, scale, sequential, pattern, function F");
                    }
                    self.diags.push(d);
                }
            }
            SelectorMode::FunctionRef(f) => {
                self.function_ref_arity(f);
                if self.sym.resolve_function(&f.text, ns.as_deref()).is_none() {
                    let mut d = Diagnostic::error("E0310", f.span, format!("unknown function `{}`", f.text));
                    if let Some(s) = did_you_mean(&f.text, self.sym.functions.keys().map(|k| k.as_str())) {
                        d = d.with_suggestion(format!("did you mean `{s}`?"), f.span, s.to_string());
                    }
                    self.diags.push(d);
                }
            }
            SelectorMode::FunctionBody(e) => {
                // The expression sees the call's arguments: the (first) rule's parameters.
                let full = rules.first().and_then(|r| self.sym.resolve(&r.text, ns.as_deref()));
                let sig = full.as_ref().and_then(|f| self.sym.signatures.get(f)).cloned().unwrap_or_default();
                let scope = sig
                    .params
                    .iter()
                    .enumerate()
                    .map(|(i, p)| Local { name: p.name.clone(), ty: p.ty, span: p.span, used: false, param: Some(i) })
                    .collect();
                self.scope = Some(scope);
                self.expr(e, true, false);
                let scope = self.scope.take().unwrap_or_default();
                if let Some(full) = full {
                    for l in scope.iter().filter(|l| l.used) {
                        self.param_reads.insert((full.clone(), l.param.unwrap_or(0)));
                    }
                }
            }
        }
    }

    /// E0312 when directive `n` was given before; otherwise remembers where it is.
    fn given_once(&mut self, n: &str, span: Span, seen: &mut HashMap<String, Span>) {
        if let Some(prev) = seen.get(n) {
            self.diags.push(
                Diagnostic::error("E0312", span, format!("`{n}` is given twice"))
                    .with_secondary(*prev, "first given here"),
            );
        } else {
            seen.insert(n.to_string(), span);
        }
    }

    fn directive(&mut self, name: &Name, args: &[DirArg], ns: &Option<String>, seen: &mut HashMap<String, Span>) {
        let n = name.text.as_str();
        match n {
            "angle" => {
                if let Some(DirArg::Word(w)) = args.first() {
                    if !ANGLE_MODES.contains(&w.text.as_str()) {
                        let mut d = Diagnostic::error("E0407", w.span, format!("unknown angle mode `{}`", w.text));
                        if let Some(s) = did_you_mean(&w.text, ANGLE_MODES.iter().copied()) {
                            d = d.with_suggestion(format!("did you mean `{s}`?"), w.span, s.to_string());
                        } else {
                            d = d.with_note("modes: degrees, radians, orbits, arcdegrees, frequency");
                        }
                        self.diags.push(d);
                    }
                }
            }
            "color" | "weight" => {}
            // `background #rrggbb` or `background #name`: a colour value.
            "background" if matches!(args, [DirArg::Word(w)] if w.text.starts_with('#')) => {
                self.given_once(n, name.span, seen);
                if let [DirArg::Word(w)] = args {
                    self.colour_value(w);
                }
            }
            "uniform" => {
                let rest = &args[1..];
                if let [DirArg::Word(rule), DirArg::Word(prop)] = rest {
                    self.rule_ref(rule, ns, "E0308", "uniform rule");
                    const PROPS: &[&str] = &["pos", "dir", "conj", "color", "weight", "normal"];
                    if !PROPS.contains(&prop.text.as_str()) {
                        let mut d =
                            Diagnostic::error("E0407", prop.span, format!("unknown uniform property `{}`", prop.text));
                        if let Some(s) = did_you_mean(&prop.text, PROPS.iter().copied()) {
                            d = d.with_suggestion(format!("did you mean `{s}`?"), prop.span, s.to_string());
                        } else {
                            d = d.with_note("properties: pos, dir, conj, color, weight, normal");
                        }
                        self.diags.push(d);
                    }
                } else if rest.len() > 4 {
                    self.diags.push(Diagnostic::error(
                        "E0401",
                        name.span.to(dir_arg_span(&args[args.len() - 1])),
                        format!("`uniform` takes 1 to 4 values but {} were given", rest.len()),
                    ));
                } else {
                    for a in rest {
                        self.dir_value(a, false);
                    }
                }
            }
            _ => match NUMERIC_DIRECTIVES.iter().find(|d| d.0 == n) {
                Some(&(_, lo, hi, integer)) => {
                    self.given_once(n, name.span, seen);
                    if args.len() < lo || args.len() > hi {
                        let want = if lo == hi { format!("{lo}") } else { format!("{lo} to {hi}") };
                        let span = args.last().map(|a| name.span.to(dir_arg_span(a))).unwrap_or(name.span);
                        self.diags.push(
                            Diagnostic::error(
                                "E0401",
                                span,
                                format!("`{n}` takes {want} value(s) but {} were given", args.len()),
                            )
                            .with_label("wrong number of values"),
                        );
                        return;
                    }
                    for a in args {
                        self.dir_value(a, integer && !matches!(n, "randseed") || n == "randseed");
                        let value = match a {
                            DirArg::Expr(e) => self.const_value(e).map(|v| (v, e.span)),
                            // A literal beyond range already has E0109.
                            _ => num_of(a).filter(|(v, _)| v.is_finite()).map(|(v, num)| (v, num.span)),
                        };
                        if let Some((v, span)) = value {
                            let bad = !v.is_finite()
                                || match n {
                                    "maxdepth" | "maxiter" | "stacksize" | "maxobjects" => v < 0.0,
                                    "minsize" | "duration" => v < 0.0,
                                    "fps" => v <= 0.0,
                                    "camerafov" => v <= 0.0 || v >= 180.0,
                                    "cameranearplane" | "camerafarplane" => v <= 0.0,
                                    _ => false,
                                };
                            if bad {
                                self.diags.push(
                                    Diagnostic::error("E0407", span, format!("invalid value {v} for `{n}`"))
                                        .with_label(if v.is_finite() { "out of range" } else { "not a finite number" }),
                                );
                            }
                        }
                    }
                }
                None => {
                    let mut d = Diagnostic::error("E0302", name.span, format!("unknown directive `{n}`"));
                    if let Some(s) = did_you_mean(n, directive_names()) {
                        d = d.with_suggestion(format!("did you mean `{s}`?"), name.span, s.to_string());
                    } else {
                        d = d.with_label("not a directive");
                    }
                    self.diags.push(d);
                }
            },
        }
    }

    fn dir_value(&mut self, a: &DirArg, integer: bool) {
        match a {
            DirArg::Num(n) | DirArg::Neg(n) => {
                if n.unit.is_some() {
                    self.unit_error(n);
                } else if integer && n.value.fract() != 0.0 {
                    self.diags.push(
                        Diagnostic::error("E0407", n.span, format!("expected a whole number, found {}", n.text))
                            .with_label("not an integer"),
                    );
                }
            }
            DirArg::Word(w) => {
                self.diags.push(Diagnostic::error("E0407", w.span, format!("expected a number, found `{}`", w.text)));
            }
            DirArg::Expr(e) => {
                self.expr(e, false, false);
                if self.const_value(e).is_none() {
                    self.diags.push(Diagnostic::error("E0408", e.span, "this value must be a compile-time constant"));
                }
            }
        }
    }

    fn isosurface(&mut self, name: &Name, entries: &[IsoEntry]) {
        let mut has_function = false;
        let mut axes = [false; 3];
        for e in entries {
            match e {
                IsoEntry::Axis { axis, args, span } => {
                    let which: &[usize] = match axis.text.as_str() {
                        "x" => &[0],
                        "y" => &[1],
                        "z" => &[2],
                        "xyz" => &[0, 1, 2],
                        other => {
                            let mut d =
                                Diagnostic::error("E0407", axis.span, format!("unknown isosurface entry `{other}`"));
                            if let Some(s) = did_you_mean(other, ["x", "y", "z", "xyz", "function"]) {
                                d = d.with_suggestion(format!("did you mean `{s}`?"), axis.span, s.to_string());
                            }
                            self.diags.push(d);
                            continue;
                        }
                    };
                    for &w in which {
                        axes[w] = true;
                    }
                    if args.len() != 3 {
                        self.diags.push(Diagnostic::error(
                            "E0401",
                            *span,
                            format!(
                                "`{}` takes 3 values (MIN MAX RESOLUTION) but {} were given",
                                axis.text,
                                args.len()
                            ),
                        ));
                        continue;
                    }
                    for a in args {
                        self.dir_value(a, false);
                    }
                    let v: Vec<Option<f64>> = args
                        .iter()
                        .map(|a| match a {
                            DirArg::Expr(e) => self.const_value(e),
                            other => num_of(other).map(|x| x.0),
                        })
                        .collect();
                    // The grid stores f32: a bound beyond it would be infinite.
                    let finite = |x: f64| x.is_finite() && x.abs() <= f32::MAX as f64;
                    if let (Some(lo), Some(hi)) = (v[0], v[1]) {
                        if !(finite(lo) && finite(hi)) {
                            self.diags.push(
                                Diagnostic::error(
                                    "E0406",
                                    dir_arg_span(&args[0]).to(dir_arg_span(&args[1])),
                                    "the grid's minimum and maximum must be finite numbers",
                                )
                                .with_label(format!("this is {lo} to {hi}")),
                            );
                        } else if lo >= hi {
                            self.diags.push(Diagnostic::error(
                                "E0406",
                                dir_arg_span(&args[0]).to(dir_arg_span(&args[1])),
                                "the grid's minimum must be below its maximum",
                            ));
                        }
                    }
                    if let Some(res) = v[2] {
                        if res <= 0.0 || res.fract() != 0.0 {
                            self.diags.push(
                                Diagnostic::error(
                                    "E0406",
                                    dir_arg_span(&args[2]),
                                    "the grid resolution must be a whole number > 0",
                                )
                                .with_label(format!("this is {res}")),
                            );
                        }
                    }
                }
                IsoEntry::FunctionRef(f) => {
                    has_function = true;
                    self.function_ref_arity(f);
                    if self.sym.resolve_function(&f.text, None).is_none() {
                        let mut d = Diagnostic::error("E0310", f.span, format!("unknown function `{}`", f.text));
                        if let Some(s) = did_you_mean(&f.text, self.sym.functions.keys().map(|k| k.as_str())) {
                            d = d.with_suggestion(format!("did you mean `{s}`?"), f.span, s.to_string());
                        }
                        self.diags.push(d);
                    }
                }
                IsoEntry::FunctionBody(e) => {
                    has_function = true;
                    self.expr(e, true, false);
                }
            }
        }
        if !has_function {
            self.diags.push(
                Diagnostic::error("E0407", name.span, format!("isosurface `{}` has no function", name.text))
                    .with_note("add `function { EXPR }` or `function NAME`"),
            );
        } else if axes != [true; 3] {
            self.diags.push(
                Diagnostic::error(
                    "E0407",
                    name.span,
                    format!("isosurface `{}` does not give a grid for every axis", name.text),
                )
                .with_note("add `xyz MIN MAX RES`, or `x …`, `y …` and `z …`"),
            );
        }
    }

    fn program(&mut self, words: &[Name]) {
        let mut i = 0;
        while i < words.len() {
            let w = &words[i];
            match w.text.as_str() {
                "vertexshader" | "fragmentshader" => {
                    let vertex = w.text == "vertexshader";
                    match words.get(i + 1) {
                        Some(s) => {
                            if !self.ex.shaders.iter().any(|sh| sh.vertex == vertex && sh.name.text == s.text) {
                                let names = self
                                    .ex
                                    .shaders
                                    .iter()
                                    .filter(|sh| sh.vertex == vertex)
                                    .map(|sh| sh.name.text.as_str());
                                let kind = if vertex { "vertex" } else { "fragment" };
                                let mut d =
                                    Diagnostic::error("E0314", s.span, format!("unknown {kind} shader `{}`", s.text));
                                if let Some(x) = did_you_mean(&s.text, names) {
                                    d = d.with_suggestion(format!("did you mean `{x}`?"), s.span, x.to_string());
                                } else {
                                    d = d.with_note(format!("declare it with `@{kind}shader {} … @endshader`", s.text));
                                }
                                self.diags.push(d);
                            }
                        }
                        None => self.diags.push(Diagnostic::error(
                            "E0401",
                            w.span,
                            format!("`{}` needs a shader name", w.text),
                        )),
                    }
                    i += 2;
                }
                "target" => match words.get(i + 1).map(|s| s.text.as_str()) {
                    Some("screen") => i += 2,
                    Some("texture") => i += 3,
                    _ => {
                        self.diags.push(Diagnostic::error(
                            "E0407",
                            w.span,
                            "expected `target screen` or `target texture NAME`",
                        ));
                        i += 2;
                    }
                },
                "render" => i += 1,
                other => {
                    let mut d = Diagnostic::error("E0407", w.span, format!("unknown program command `{other}`"));
                    if let Some(s) = did_you_mean(other, ["vertexshader", "fragmentshader", "target", "render"]) {
                        d = d.with_suggestion(format!("did you mean `{s}`?"), w.span, s.to_string());
                    }
                    self.diags.push(d);
                    i += 1;
                }
            }
        }
    }

    fn whole_program(&mut self, opts: CheckOptions) {
        // Weights against selectors.
        for (full, defs) in &self.sym.rules {
            let mode = self.sym.selectors.get(full).map(|(m, _)| m.clone());
            for def in defs {
                let ItemKind::Rule(r) = &self.ex.items[def.item].item.kind else { continue };
                let Some(w) = &r.weight else { continue };
                let v = if w.negative { -w.number.value } else { w.number.value };
                let sequential =
                    matches!(&mode, Some(SelectorMode::Word(m)) if m.text == "sequential" || m.text == "pattern");
                let threshold = matches!(&mode, Some(SelectorMode::Word(m)) if m.text == "depth" || m.text == "scale")
                    || matches!(&mode, Some(SelectorMode::FunctionRef(_) | SelectorMode::FunctionBody(_)));
                let problem = if w.number.unit.is_some() {
                    Some("a weight takes no unit suffix".to_string())
                } else if sequential && (v < 0.0 || v.fract() != 0.0) {
                    Some(format!("a sequential rule's weight is a repeat count: a whole number ≥ 0, not {v}"))
                } else if !threshold && v < 0.0 {
                    Some(format!("a random rule's weight is a relative probability and cannot be negative ({v})"))
                } else {
                    None
                };
                if let Some(p) = problem {
                    self.diags.push(Diagnostic::error("E0405", w.number.span.to(r.name.span).to(w.number.span), p));
                }
            }
        }

        let program = self.sym.startshape.is_some();
        if !program {
            if opts.require_start {
                let file = self.ex.files.first().copied().unwrap_or_default();
                self.diags.push(
                    Diagnostic::error("E0306", Span::new(file, 0, 0), "this program has no `startshape`")
                        .with_note("add `startshape NAME` to say which rule to start from"),
                );
            }
            return;
        }

        // Rules used as transform, iterator, line, camera or uniform rules are roots too.
        let mut roots: Vec<String> = Vec::new();
        if let Some((s, _)) = &self.sym.startshape {
            roots.push(s.clone());
        }
        let mut special: BTreeSet<String> = BTreeSet::new();
        for ExpItem { item, namespace } in &self.ex.items {
            let mut add = |n: &Name| {
                if let Some(f) = self.sym.resolve(&n.text, namespace.as_deref()) {
                    special.insert(f);
                }
            };
            match &item.kind {
                ItemKind::Linerule(n) | ItemKind::Camerarule(n) => add(n),
                ItemKind::Rule(r) => {
                    r.iter.iter().for_each(&mut add);
                    r.transforms.iter().for_each(&mut add);
                }
                ItemKind::Directive { name, args } if name.text == "uniform" => {
                    if let [_, DirArg::Word(rule), DirArg::Word(_)] = args.as_slice() {
                        add(rule);
                    }
                }
                _ => {}
            }
        }
        let transform_rules = special.clone();
        roots.extend(special);
        // Rules named in extension sections (skeleton rules, creature part geometry, …)
        // are used by those sections.
        for ExpItem { item, namespace } in &self.ex.items {
            if let ItemKind::Section(sec) = &item.kind {
                for n in crate::ext::rule_refs(sec) {
                    if let Some(f) = self.sym.resolve(&n.text, namespace.as_deref()) {
                        roots.push(f);
                    }
                }
            }
        }
        let mut reachable: BTreeSet<String> = BTreeSet::new();
        let mut stack = roots;
        while let Some(r) = stack.pop() {
            if !reachable.insert(r.clone()) {
                continue;
            }
            for calls in self.call_graph.get(&r).into_iter().flatten() {
                stack.extend(calls.iter().cloned());
            }
        }
        let referenced: BTreeSet<&String> = self.sym.references.iter().map(|(_, r)| r).collect();
        let main_file = self.ex.files.first().copied();
        for (full, defs) in &self.sym.rules {
            if reachable.contains(full) {
                continue;
            }
            let def = &defs[0];
            // Rules from imported libraries are not the program's to use up.
            if Some(def.name_span.file) != main_file {
                continue;
            }
            if referenced.contains(full) {
                self.diags.push(
                    Diagnostic::warning(
                        "W0002",
                        def.name_span,
                        format!("rule `{full}` is unreachable from the start shape"),
                    )
                    .with_label("only unused rules call this rule"),
                );
            } else {
                self.diags.push(
                    Diagnostic::warning("W0001", def.name_span, format!("rule `{full}` is never used"))
                        .with_suggestion("remove the rule", self.ex.items[def.item].item.span, String::new()),
                );
            }
        }

        // Termination: a rule terminates if one of its definitions calls only rules that terminate.
        let has_limit = self.ex.items.iter().any(|ExpItem { item, .. }| {
            matches!(&item.kind, ItemKind::Directive { name, .. } if matches!(name.text.as_str(), "maxdepth" | "minsize" | "maxobjects"))
        });
        if has_limit {
            return;
        }
        let mut terminates: BTreeSet<String> = BTreeSet::new();
        for (full, (mode, _)) in &self.sym.selectors {
            if !matches!(mode, SelectorMode::Word(w) if w.text == "random" || w.text == "frequency") {
                terminates.insert(full.clone());
            }
        }
        // The fixpoint by a worklist over the reverse call graph: linear in its size
        // (repeated passes over every rule took quadratic time on a long call chain:
        // 90 s for 20,000 rules). For each definition, the callees not yet known to
        // terminate; a rule terminates when one of its definitions has none left.
        let mut callers: HashMap<&str, Vec<(&str, usize)>> = HashMap::new();
        let mut left: HashMap<(&str, usize), usize> = HashMap::new();
        let mut queue: Vec<&str> = Vec::new();
        for (full, defs) in &self.must_graph {
            for (i, calls) in defs.iter().enumerate() {
                let open: BTreeSet<&str> = calls
                    .iter()
                    .map(String::as_str)
                    .filter(|c| self.sym.rules.contains_key(*c) && !terminates.contains(*c))
                    .collect();
                if open.is_empty() {
                    queue.push(full);
                }
                for c in &open {
                    callers.entry(c).or_default().push((full, i));
                }
                left.insert((full, i), open.len());
            }
        }
        while let Some(r) = queue.pop() {
            if !terminates.insert(r.to_string()) {
                continue;
            }
            for &(caller, i) in callers.get(r).into_iter().flatten() {
                if let Some(n) = left.get_mut(&(caller, i)) {
                    *n -= 1;
                    if *n == 0 {
                        queue.push(caller);
                    }
                }
            }
        }
        for full in &reachable {
            if terminates.contains(full) || transform_rules.contains(full) {
                continue;
            }
            let Some(defs) = self.sym.rules.get(full) else { continue };
            if Some(defs[0].name_span.file) != main_file {
                continue;
            }
            self.diags.push(
                Diagnostic::warning(
                    "W0003",
                    defs[0].name_span,
                    format!("the recursion of `{full}` can never terminate"),
                )
                .with_label("every definition calls itself again")
                .with_note("add `maxdepth N` or `minsize S`, a non-recursive definition, or a depth/scale selector"),
            );
        }
    }
}
