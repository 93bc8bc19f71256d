//! SPEC §11 extension sections: `guide` / `search` (guided search),
//! `creature` (creature grammar), `grid` (grid shape grammars).
//!
//! The parser knows one shape for all of them (`KIND [NAME] { KEY VALUE… ; … }`,
//! see [`crate::ast::Section`]); each extension's module checks its keys and values
//! here and lowers them into its table in [`mdg_vm::bundle::Extensions`].
//! Codes: E06xx for every section (unknown key, wrong values), E07xx guided
//! search, E08xx creatures, E09xx grid grammars.

pub mod creature;
pub mod grid;
pub mod guided;

use crate::ast::{Entry, Expr, ItemKind, Name, Section, Value};
use crate::diag::{did_you_mean, Diagnostic};
use crate::expand::{ExpItem, Expanded};
use crate::symbols::Symbols;
use mdg_vm::bundle::Section as _;
use mdg_vm::expr::ExprOp;
use std::collections::HashMap;

/// A section and the namespace it appears in.
#[derive(Clone, Copy)]
pub struct Sec<'a> {
    pub section: &'a Section,
    pub namespace: Option<&'a str>,
}

/// The program's sections of one kind, in source order.
pub fn sections<'a>(ex: &'a Expanded, kind: &str) -> Vec<Sec<'a>> {
    ex.items
        .iter()
        .filter_map(|ExpItem { item, namespace }| match &item.kind {
            ItemKind::Section(s) if s.kind.text == kind => Some(Sec { section: s, namespace: namespace.as_deref() }),
            _ => None,
        })
        .collect()
}

/// One key a section (or a nested block) accepts, with its documentation (shown
/// on hover and in completion).
#[derive(Clone, Copy, Debug)]
pub struct Key {
    pub name: &'static str,
    /// What the values are, e.g. `X Y Z` or `RULE…`.
    pub values: &'static str,
    pub doc: &'static str,
}

/// The keys accepted at `path`: `[kind]` for a section's entries, `[kind, key]` for
/// the entries of `key … { }` inside it, and so on.
pub fn keys(path: &[&str]) -> &'static [Key] {
    match path.first().copied() {
        Some("guide") | Some("search") => guided::keys(path),
        Some("creature") => creature::keys(path),
        Some("grid") => grid::keys(path),
        _ => &[],
    }
}

/// What checking a section needs: the program and the checker's symbols.
pub struct CheckCx<'a> {
    pub ex: &'a Expanded,
    pub sym: &'a Symbols,
}

impl CheckCx<'_> {
    /// Resolves a rule name as a call in namespace `ns` would; reports E0301 (with a
    /// suggestion) when there is no such rule.
    pub fn rule(&self, name: &Name, ns: Option<&str>, diags: &mut Vec<Diagnostic>) -> Option<String> {
        if let Some(full) = self.sym.resolve(&name.text, ns) {
            return Some(full);
        }
        let mut d = Diagnostic::error("E0301", name.span, format!("unknown rule `{}`", name.text));
        match did_you_mean(&name.text, self.sym.rules.keys().map(|s| s.as_str())) {
            Some(s) => d = d.with_label(format!("did you mean `{s}`?")),
            None => d = d.with_label("no rule has this name"),
        }
        diags.push(d);
        None
    }

    /// The value of a number, `-number`, or a constant expression over `@param`
    /// and `@define` values. `None` for words, strings and non-constant expressions.
    pub fn number(&self, v: &Value) -> Option<f64> {
        number(self.ex, v)
    }
}

/// See [`CheckCx::number`].
pub fn number(ex: &Expanded, v: &Value) -> Option<f64> {
    match v {
        Value::Num(n) => Some(n.value),
        Value::Neg(n) => Some(-n.value),
        Value::Expr(e) => const_expr(ex, e),
        Value::Word(w) => ex.constant(&w.text),
        Value::Str(..) => None,
    }
}

fn const_expr(ex: &Expanded, e: &Expr) -> Option<f64> {
    crate::consteval::eval(e, &|name| ex.constant(name))
}

/// Reports E0601 for every entry whose key is not in `allowed`; returns the known ones.
pub fn known_entries<'a>(
    entries: &'a [Entry],
    allowed: &[Key],
    what: &str,
    diags: &mut Vec<Diagnostic>,
) -> Vec<&'a Entry> {
    let mut out = Vec::new();
    for e in entries {
        if allowed.iter().any(|k| k.name == e.key.text) {
            out.push(e);
            continue;
        }
        let mut d = Diagnostic::error("E0601", e.key.span, format!("unknown key `{}` in {what}", e.key.text));
        match did_you_mean(&e.key.text, allowed.iter().map(|k| k.name)) {
            Some(s) => {
                d = d.with_label(format!("did you mean `{s}`?")).with_suggestion(
                    format!("replace with `{s}`"),
                    e.key.span,
                    s,
                )
            }
            None => {
                let names: Vec<&str> = allowed.iter().map(|k| k.name).collect();
                d = d.with_note(format!("expected one of: {}", names.join(", ")));
            }
        }
        diags.push(d);
    }
    out
}

/// E0602 unless `entry` has between `min` and `max` values; `form` describes them
/// (e.g. `X Y Z`).
pub fn expect_count(entry: &Entry, min: usize, max: usize, form: &str, diags: &mut Vec<Diagnostic>) -> bool {
    let n = entry.values.len();
    if n >= min && n <= max {
        return true;
    }
    let span = entry.values.get(max).map(|v| v.span()).unwrap_or(entry.span);
    diags.push(
        Diagnostic::error("E0602", span, format!("`{}` takes {form}", entry.key.text))
            .with_label(format!("{n} value{} given", if n == 1 { "" } else { "s" })),
    );
    false
}

/// The entry's values as numbers, or E0602 at the first one that is not a constant number.
pub fn numbers(ex: &Expanded, entry: &Entry, diags: &mut Vec<Diagnostic>) -> Option<Vec<f64>> {
    let mut out = Vec::with_capacity(entry.values.len());
    for v in &entry.values {
        match number(ex, v) {
            Some(x) if x.is_finite() => out.push(x),
            _ => {
                diags.push(
                    Diagnostic::error("E0602", v.span(), format!("`{}` takes numbers", entry.key.text))
                        .with_label("not a constant number"),
                );
                return None;
            }
        }
    }
    Some(out)
}

/// The entry's values as words (names), or E0602 at the first one that is not.
pub fn words<'a>(entry: &'a Entry, diags: &mut Vec<Diagnostic>) -> Option<Vec<&'a Name>> {
    let mut out = Vec::with_capacity(entry.values.len());
    for v in &entry.values {
        match v {
            Value::Word(w) => out.push(w),
            _ => {
                diags.push(
                    Diagnostic::error("E0602", v.span(), format!("`{}` takes names", entry.key.text))
                        .with_label("not a name"),
                );
                return None;
            }
        }
    }
    Some(out)
}

/// E0603 when `key` appears more than once among `entries` (reported at the second).
pub fn at_most_once(entries: &[&Entry], diags: &mut Vec<Diagnostic>) {
    for (i, e) in entries.iter().enumerate() {
        if let Some(prev) = entries[..i].iter().find(|p| p.key.text == e.key.text) {
            diags.push(
                Diagnostic::error("E0603", e.key.span, format!("`{}` is given twice", e.key.text))
                    .with_secondary(prev.key.span, "first given here"),
            );
        }
    }
}

/// Checks every section of the program (called by the checker once symbols are known).
pub fn check(ex: &Expanded, sym: &Symbols, diags: &mut Vec<Diagnostic>) {
    let cx = CheckCx { ex, sym };
    let mut guides = sections(ex, "guide");
    guides.extend(sections(ex, "search"));
    if !guides.is_empty() {
        guided::check(&guides, &cx, diags);
    }
    let creatures = sections(ex, "creature");
    if !creatures.is_empty() {
        creature::check(&creatures, &cx, diags);
    }
    let grids = sections(ex, "grid");
    if !grids.is_empty() {
        grid::check(&grids, &cx, diags);
    }
}

/// Rule names a section refers to (for go-to-definition, references and rename).
pub fn rule_refs(sec: &Section) -> Vec<&Name> {
    match sec.kind.text.as_str() {
        "guide" | "search" => guided::rule_refs(sec),
        "creature" => creature::rule_refs(sec),
        "grid" => grid::rule_refs(sec),
        _ => Vec::new(),
    }
}

/// What lowering an extension section needs: given by `crate::lower`, which calls
/// [`lower`] (so this module does not depend on the lowering of rules).
pub struct LowerCx<'a> {
    pub ex: &'a Expanded,
    pub sym: &'a Symbols,
    /// Rule full name → bundle rule index.
    pub rule_ids: &'a HashMap<String, u32>,
    /// Expression code in the program's geometric expression language.
    pub expr_code: &'a dyn Fn(&Expr) -> Vec<ExprOp>,
    /// Radians per plain angle number under the program's `angle` mode.
    pub angle_factor: f64,
}

impl LowerCx<'_> {
    /// The bundle index of a rule named as a call in namespace `ns` would name it.
    pub fn rule(&self, name: &str, ns: Option<&str>) -> Option<u32> {
        self.sym.resolve(name, ns).and_then(|f| self.rule_ids.get(&f).copied())
    }

    /// Expression code for `e` (variables are `mdg_vm::expr::VARIABLES`, e.g. `g`).
    pub fn expr(&self, e: &Expr) -> Vec<ExprOp> {
        (self.expr_code)(e)
    }

    /// A constant number value (see [`number`]).
    pub fn number(&self, v: &Value) -> Option<f64> {
        number(self.ex, v)
    }

    /// Radians for an angle written as a plain number under the program's `angle` mode.
    pub fn angle(&self, value: f64) -> f64 {
        value * self.angle_factor
    }
}

/// Lowers every section into the bundle's extension tables. Called after checking
/// found no errors.
pub fn lower(cx: &LowerCx, ext: &mut mdg_vm::bundle::Extensions) {
    let mut guides = sections(cx.ex, "guide");
    guides.extend(sections(cx.ex, "search"));
    if !guides.is_empty() {
        if let Some(table) = guided::lower(&guides, cx) {
            table.store(ext);
        }
    }
    let creatures = sections(cx.ex, "creature");
    if !creatures.is_empty() {
        if let Some(table) = creature::lower(&creatures, cx) {
            table.store(ext);
        }
    }
    let grids = sections(cx.ex, "grid");
    if !grids.is_empty() {
        if let Some(table) = grid::lower(&grids, cx) {
            table.store(ext);
        }
    }
}
