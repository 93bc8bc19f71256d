//! What the checker learns about a program: its rules, functions, isosurfaces,
//! namespaces, selectors and signatures ([`Symbols`]), read by lowering and the
//! extension sections.

use crate::adjust::Components;
use crate::ast::SelectorMode;
use crate::span::Span;
use crate::types::Signature;
use std::collections::BTreeMap;

/// Built-in drawables (SPEC §3, §7). This is the VM's `DRAW` kind table itself: lowering
/// emits a drawable's position in this list as its kind, so the two cannot drift.
pub const DRAWABLES: &[&str] = mdg_vm::bundle::ops::DRAWABLE_KINDS;

/// Drawables that act on a namespace's pen and may be written `ns.NAME`.
pub const PEN_DRAWABLES: &[&str] = &["MOVETO", "LINETO", "BLENDTO", "SLINETO", "ALINETO", "NEWLINE", "RESET", "DEBUG"];

/// Drawables that take a profile rule name: `LINETO circle {…}`.
pub const PROFILE_DRAWABLES: &[&str] = &["MOVETO", "LINETO", "BLENDTO", "SLINETO", "ALINETO"];

/// A rule definition's location in the expanded program.
#[derive(Clone, Debug)]
pub struct RuleDef {
    /// Index into [`Expanded::items`].
    pub item: usize,
    pub name_span: Span,
    pub namespace: Option<String>,
}

/// What the checker learned about the program.
#[derive(Default)]
pub struct Symbols {
    /// Rule full name → definitions in source order.
    pub rules: BTreeMap<String, Vec<RuleDef>>,
    pub functions: BTreeMap<String, Span>,
    pub isosurfaces: BTreeMap<String, Span>,
    pub namespaces: BTreeMap<String, Span>,
    pub selectors: BTreeMap<String, (SelectorMode, Span)>,
    pub startshape: Option<(String, Span)>,
    pub components: Components,
    /// Resolved rule references: (span of the use, full rule name).
    pub references: Vec<(Span, String)>,
    /// Rule full name → its parameters (rules without a parameter list have none).
    pub signatures: BTreeMap<String, Signature>,
}

impl Symbols {
    /// Resolves a rule name used inside namespace `ns`.
    pub fn resolve(&self, name: &str, ns: Option<&str>) -> Option<String> {
        if let Some(ns) = ns {
            let q = format!("{ns}.{name}");
            if self.rules.contains_key(&q) {
                return Some(q);
            }
        }
        self.rules.contains_key(name).then(|| name.to_string())
    }

    /// Whether `name` is a drawable (built-in, a flat path's relative drawable,
    /// namespaced pen drawable, or isosurface).
    pub fn is_drawable(&self, name: &str) -> bool {
        if DRAWABLES.contains(&name)
            || self.isosurfaces.contains_key(name)
            || crate::paths::RELATIVE.iter().any(|(r, _)| *r == name)
        {
            return true;
        }
        match name.rsplit_once('.') {
            Some((_, last)) => PEN_DRAWABLES.contains(&last),
            None => false,
        }
    }
}

impl Symbols {
    /// Resolves a function name used inside namespace `ns`.
    pub fn resolve_function(&self, name: &str, ns: Option<&str>) -> Option<String> {
        if let Some(ns) = ns {
            let q = format!("{ns}.{name}");
            if self.functions.contains_key(&q) {
                return Some(q);
            }
        }
        self.functions.contains_key(name).then(|| name.to_string())
    }
}
