//! Code lenses: where the editor offers to run the grammar (`startshape`), its
//! guided search (`search`), its creature evolution (`creature`), and where a rule's
//! reference count goes (each rule definition of the document). The counts come
//! from the language server, which sees the whole workspace.

use super::index::{Occ, Symbol};
use super::Document;
use crate::ast::{Item, ItemKind, Pre};
use crate::span::Span;

/// What a lens is over.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LensKind {
    /// `startshape R`: preview, render to `.glb`, statistics.
    Startshape,
    /// A `search { … }` section: run the guided search.
    Search,
    /// A `creature NAME { … }` section: evolve it.
    Creature,
    /// A rule definition (its full name): how many calls it has.
    Rule(String),
}

/// One lens: the span it sits over and what it is for.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LensTarget {
    pub span: Span,
    pub kind: LensKind,
}

impl Document {
    /// The lenses of the document, in source order (both branches of an `@ifdef`).
    pub fn lens_targets(&self) -> Vec<LensTarget> {
        let mut out = Vec::new();
        sections(&self.analysis.expanded.main_ast.items, &mut out);
        for o in &self.index().main {
            if let Occ::Def(Symbol::Rule(name)) = &o.occ {
                out.push(LensTarget { span: o.span, kind: LensKind::Rule(name.clone()) });
            }
        }
        out.sort_by_key(|l| (l.span.start, l.span.end));
        out.dedup();
        out
    }
}

fn sections(items: &[Item], out: &mut Vec<LensTarget>) {
    for item in items {
        match &item.kind {
            ItemKind::Startshape(_) => out.push(LensTarget { span: item.span, kind: LensKind::Startshape }),
            ItemKind::Section(s) if s.kind.text == "search" => {
                out.push(LensTarget { span: s.kind.span, kind: LensKind::Search })
            }
            ItemKind::Section(s) if s.kind.text == "creature" => {
                out.push(LensTarget { span: s.kind.span, kind: LensKind::Creature })
            }
            ItemKind::Namespace { items, .. } => sections(items, out),
            ItemKind::Pre(Pre::IfDef { then, otherwise, .. }) => {
                sections(then, out);
                if let Some(o) = otherwise {
                    sections(o, out);
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::doc;
    use super::LensKind;

    #[test]
    fn lenses_in_namespaces_and_both_ifdef_branches() {
        let src = "@ifdef BIG\nstartshape ns.a\n@else\nstartshape ns.b\n@endif\nnamespace ns {\n  rule a { b {} }\n  rule b { VERTEX {} }\n}\nsearch { skeleton ns.a; }\ncreature m { }\n";
        let (d, _) = doc(src);
        let kinds: Vec<(LensKind, &str)> =
            d.lens_targets().into_iter().map(|l| (l.kind, &src[l.span.start as usize..l.span.end as usize])).collect();
        assert_eq!(
            kinds,
            [
                (LensKind::Startshape, "startshape ns.a"),
                (LensKind::Startshape, "startshape ns.b"),
                (LensKind::Rule("ns.a".into()), "a"),
                (LensKind::Rule("ns.b".into()), "b"),
                (LensKind::Search, "search"),
                (LensKind::Creature, "creature"),
            ]
        );
    }
}
