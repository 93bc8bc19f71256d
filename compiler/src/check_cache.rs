//! The checker's per-rule cache (issue 39): while a user types into one rule of a
//! large file, every other rule's check gives what it gave for the previous version.
//!
//! What a rule's check contributes — its diagnostics, its resolved references, its
//! entries in the call graphs, the parameters it reads and those it leaves unread —
//! is recorded per rule ([`RuleResult`]) and kept with the [`crate::check::Checked`]
//! result. The next version's check replays it instead of checking the rule again
//! when
//!
//! - the rule is the same tree: the previous version's own `Arc` (an item before
//!   the edit, shared by the parse reuse), or a copy of it moved by the edit
//!   ([`crate::parse::Reused::moved`]; its spans then move by the edit's change in
//!   length), in the same namespace;
//! - the program's facts a rule's check reads are the same ([`same_facts`]): the
//!   rule names and signatures (without their spans), functions, isosurfaces,
//!   namespaces, colour/weight component names, the rules used as profiles, whether
//!   a `maxdepth`/`minsize`/`maxobjects` limit is given, the `@param`s and
//!   `@define`s, the functions with parameters;
//! - and its contributions lie inside the rule (every span of its diagnostics and
//!   references in the rule's own item): a diagnostic that points elsewhere (E0320's
//!   first definition, E0324's parameter, the `@import` fix at the top of the file)
//!   could move independently of the rule, so such a rule is not recorded and is
//!   checked again each time.
//!
//! Results are shared between versions (`Arc`), with the shift accumulated, so a
//! replay copies only what goes into the new symbol table. The random-edit test
//! (`analysis::incremental`) compares every version's diagnostics, symbols,
//! references and this cache's replayed contents with a whole check.

use crate::ast::{ItemKind, Rule};
use crate::diag::Diagnostic;
use crate::expand::Expanded;
use crate::span::Span;
use crate::symbols::Symbols;
use std::collections::{BTreeSet, HashMap};
use std::sync::Arc;

/// What one rule's check contributed (its spans as when it was recorded).
#[derive(Debug, PartialEq)]
pub struct RuleResult {
    pub diags: Vec<Diagnostic>,
    pub references: Vec<(Span, String)>,
    /// The rule's full name, the rules its definition calls and those every run of
    /// it calls (`None` for a rule without a name, an error's recovery).
    pub graph: Option<(String, Vec<String>, Vec<String>)>,
    /// The indices of the parameters its body reads.
    pub reads: Vec<usize>,
    /// Those it does not read: index, span, name.
    pub unread: Vec<(usize, Span, String)>,
}

impl RuleResult {
    /// The result with every span moved by `delta` bytes.
    pub fn shifted(&self, delta: i64) -> RuleResult {
        RuleResult {
            diags: self.diags.iter().map(|d| shift_diag(d.clone(), delta)).collect(),
            references: self.references.iter().map(|(s, n)| (shift(*s, delta), n.clone())).collect(),
            graph: self.graph.clone(),
            reads: self.reads.clone(),
            unread: self.unread.iter().map(|(i, s, n)| (*i, shift(*s, delta), n.clone())).collect(),
        }
    }
}

/// A recorded rule: the rule (kept alive, so its address stays its own), its
/// namespace, its result and how far the rule moved since the result was recorded.
#[derive(Clone)]
pub(crate) struct Entry {
    pub rule: Arc<Rule>,
    pub namespace: Option<String>,
    pub result: Arc<RuleResult>,
    pub delta: i64,
}

/// The per-rule cache of one check, for the next version's.
#[derive(Default)]
pub struct Cache {
    /// Whether the check recorded its rules (the editor's analyses do; `mdgc` and
    /// builds, which have no next version, do not).
    pub(crate) recorded: bool,
    pub(crate) profile_rules: BTreeSet<String>,
    pub(crate) has_limit: bool,
    /// By the rule's `Arc` address.
    pub(crate) rules: HashMap<usize, Entry>,
    /// Rules replayed from the previous check, and rules checked (for tests and
    /// measurements).
    pub replayed: usize,
    pub checked: usize,
}

impl Cache {
    /// The recorded result of `rule`, its spans where the rule is now; `None` where
    /// it was not recorded.
    pub fn result(&self, rule: &Arc<Rule>) -> Option<RuleResult> {
        let e = self.rules.get(&(Arc::as_ptr(rule) as usize))?;
        Arc::ptr_eq(&e.rule, rule).then(|| e.result.shifted(e.delta))
    }
}

/// `s` moved by `delta` bytes.
pub fn shift(s: Span, delta: i64) -> Span {
    let m = |x: u32| (i64::from(x) + delta) as u32;
    Span { file: s.file, start: m(s.start), end: m(s.end) }
}

/// `d` with every span moved by `delta` bytes.
pub fn shift_diag(mut d: Diagnostic, delta: i64) -> Diagnostic {
    if delta != 0 {
        d.span = shift(d.span, delta);
        for l in &mut d.secondary {
            l.span = shift(l.span, delta);
        }
        if let Some(s) = &mut d.suggestion {
            s.span = shift(s.span, delta);
        }
    }
    d
}

/// Whether every span of `d` lies in `within`.
pub fn diag_within(d: &Diagnostic, within: Span) -> bool {
    let inside = |s: Span| s.file == within.file && within.start <= s.start && s.end <= within.end;
    inside(d.span) && d.secondary.iter().all(|l| inside(l.span)) && d.suggestion.as_ref().is_none_or(|s| inside(s.span))
}

/// The functions with parameters (what a call `NAME(…)` in an expression reads):
/// namespace, name, number of parameters.
fn user_functions(ex: &Expanded) -> impl Iterator<Item = (Option<&str>, &str, usize)> {
    ex.items.iter().filter_map(|i| match &i.item.kind {
        ItemKind::Function { name, params, .. } if !params.is_empty() => {
            Some((i.namespace.as_deref(), name.text.as_str(), params.len()))
        }
        _ => None,
    })
}

/// Whether the facts a rule's check reads besides the rule itself are the same in
/// both programs (spans aside: a result that points outside its rule is not kept).
pub(crate) fn same_facts(
    (prev_ex, prev_sym, prev_cache): (&Expanded, &Symbols, &Cache),
    (ex, sym): (&Expanded, &Symbols),
    profile_rules: &BTreeSet<String>,
    has_limit: bool,
) -> bool {
    let sigs_same = prev_sym.signatures.len() == sym.signatures.len()
        && prev_sym.signatures.iter().zip(&sym.signatures).all(|((na, a), (nb, b))| {
            na == nb
                && a.params.len() == b.params.len()
                && a.params
                    .iter()
                    .zip(&b.params)
                    .all(|(p, q)| p.name == q.name && p.ty == q.ty && p.default == q.default)
        });
    let params_same = prev_ex.params.len() == ex.params.len()
        && prev_ex
            .params
            .iter()
            .zip(&ex.params)
            .all(|(a, b)| a.name.text == b.name.text && a.ty == b.ty && a.value == b.value);
    prev_cache.recorded
        && prev_cache.has_limit == has_limit
        && prev_cache.profile_rules == *profile_rules
        && prev_sym.rules.keys().eq(sym.rules.keys())
        && sigs_same
        && prev_sym.functions.keys().eq(sym.functions.keys())
        && prev_sym.isosurfaces.keys().eq(sym.isosurfaces.keys())
        && prev_sym.namespaces.keys().eq(sym.namespaces.keys())
        && prev_sym.components.color == sym.components.color
        && prev_sym.components.weight == sym.components.weight
        && params_same
        && prev_ex.defines == ex.defines
        && user_functions(prev_ex).eq(user_functions(ex))
}
