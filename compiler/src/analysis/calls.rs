//! Call hierarchy: which rule definition a call stands in, and the calls a rule
//! definition's body makes, in any file of the analysis. The language server joins
//! the answers of several analyses (the workspace) for incoming calls.

use super::index::{qualify, Occ, Symbol};
use super::Document;
use crate::ast::{Item, ItemKind, Pre};
use crate::span::Span;

/// One rule definition: its full name, the span of its name and of the whole rule.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RuleDef {
    pub name: String,
    pub name_span: Span,
    pub span: Span,
}

/// One call a rule body makes: the callee's full name and the span of the call's name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutgoingCall {
    pub callee: String,
    pub span: Span,
}

impl Document {
    /// Every rule definition of the analysis (every file), in file and source order.
    pub fn rule_definitions(&self) -> Vec<RuleDef> {
        let mut out = Vec::new();
        for e in &self.analysis.expanded.items {
            rules(std::slice::from_ref(&e.item), e.namespace.as_deref(), &mut out);
        }
        out.sort_by_key(|r| (r.span, r.name_span));
        out.dedup();
        out
    }

    /// The innermost rule definition whose text holds `span` (a call's name).
    pub fn enclosing_rule(&self, span: Span) -> Option<RuleDef> {
        self.rule_definitions()
            .into_iter()
            .filter(|r| r.span.file == span.file && r.span.start <= span.start && span.end <= r.span.end)
            .min_by_key(|r| r.span.end - r.span.start)
    }

    /// The rule calls in the body of the definition `def` (as [`Document::rule_definitions`]
    /// gives it), in source order: each call of a rule that exists.
    pub fn outgoing_calls(&self, def: &RuleDef) -> Vec<OutgoingCall> {
        let mut out: Vec<OutgoingCall> = self
            .index()
            .symbols
            .iter()
            .filter(|o| o.span.file == def.span.file && def.span.start <= o.span.start && o.span.end <= def.span.end)
            .filter_map(|o| match &o.occ {
                Occ::Ref(Symbol::Rule(callee)) => Some(OutgoingCall { callee: callee.clone(), span: o.span }),
                _ => None,
            })
            .collect();
        out.sort_by_key(|c| c.span);
        out.dedup();
        out
    }
}

fn rules(items: &[Item], ns: Option<&str>, out: &mut Vec<RuleDef>) {
    for item in items {
        match &item.kind {
            ItemKind::Rule(r) if !r.name.text.is_empty() => {
                out.push(RuleDef { name: qualify(ns, &r.name.text), name_span: r.name.span, span: item.span })
            }
            ItemKind::Namespace { name, items } => {
                let inner = qualify(ns, &name.text);
                rules(items, Some(&inner), out)
            }
            ItemKind::Pre(Pre::IfDef { then, otherwise, .. }) => {
                rules(then, ns, out);
                if let Some(o) = otherwise {
                    rules(o, ns, out);
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::doc_with;

    #[test]
    fn callers_and_callees_across_files_and_namespaces() {
        let (d, _) = doc_with(
            "@import lib.mdg\nstartshape ns.top\nnamespace ns {\n  rule top { leaf {} 3 * {x 1} leaf {} twig {} }\n}\n",
            &[("lib.mdg", "rule leaf { VERTEX {} }\nrule twig { leaf {} }\n")],
        );
        let defs = d.rule_definitions();
        let names: Vec<&str> = defs.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(names, ["ns.top", "leaf", "twig"]);
        let top = &defs[0];
        let calls: Vec<String> = d.outgoing_calls(top).into_iter().map(|c| c.callee).collect();
        assert_eq!(calls, ["leaf", "leaf", "twig"]);
        // The call of `leaf` in the library is inside `twig`.
        let twig = &defs[2];
        let call = d.outgoing_calls(twig)[0].span;
        assert_eq!(d.enclosing_rule(call).map(|r| r.name), Some("twig".to_string()));
        // `startshape` is in no rule.
        let start = d.index().main.iter().find(|o| o.span.start == 27).map(|o| o.span);
        assert_eq!(start.and_then(|s| d.enclosing_rule(s)), None);
    }
}
