//! Document symbols (the outline) and workspace symbols.
//!
//! The outline follows the file as written: rules grouped by name with one child
//! per definition, namespaces with their items, functions, isosurfaces, macros and
//! shaders; items under `@ifdef` appear in place, both branches. Rules and
//! isosurfaces made by `@expand` in this file are listed at the expansion. Each §11
//! extension section is listed (`creature monsters`) with its named blocks nested
//! under it (`part torso_h` → `slot neck`).

use super::index::{qualify, Occ, Symbol};
use super::Document;
use crate::ast::*;
use crate::span::Span;

/// What a symbol is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SymbolKind {
    Rule,
    /// One definition of a rule with several.
    RuleDefinition,
    Namespace,
    Function,
    Isosurface,
    Macro,
    Shader,
    /// A §11 extension section (`guide left`).
    Section,
    /// A named block inside a section (`part torso_h { … }`).
    SectionBlock,
}

/// One entry of the outline.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DocumentSymbol {
    pub name: String,
    pub detail: Option<String>,
    pub kind: SymbolKind,
    /// The whole item.
    pub span: Span,
    /// The name.
    pub selection: Span,
    pub children: Vec<DocumentSymbol>,
}

/// A symbol anywhere in the analysis.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WorkspaceSymbol {
    /// The full name (`ns.rule`).
    pub name: String,
    pub kind: SymbolKind,
    /// The name's span (in any file).
    pub span: Span,
    /// The enclosing namespace.
    pub container: Option<String>,
}

impl Document {
    /// The outline of the document.
    pub fn document_symbols(&self) -> Vec<DocumentSymbol> {
        let mut out = self.level(&self.analysis.expanded.main_ast.items, None);
        // Definitions made by macro expansions written in this file.
        let mut covered: Vec<Span> = Vec::new();
        collect_selections(&out, &mut covered);
        for o in &self.index().main {
            let Occ::Def(sym) = &o.occ else { continue };
            let kind = match sym {
                Symbol::Rule(_) => SymbolKind::Rule,
                Symbol::Isosurface(_) => SymbolKind::Isosurface,
                Symbol::Function(_) => SymbolKind::Function,
                _ => continue,
            };
            if !covered.contains(&o.span) {
                covered.push(o.span);
                out.push(DocumentSymbol {
                    name: sym.name().to_string(),
                    detail: Some("from a macro expansion".to_string()),
                    kind,
                    span: o.span,
                    selection: o.span,
                    children: vec![],
                });
            }
        }
        out.sort_by_key(|s| s.span.start);
        out
    }

    fn level(&self, items: &[Item], ns: Option<&str>) -> Vec<DocumentSymbol> {
        let mut flat: Vec<&Item> = Vec::new();
        flatten(items, &mut flat);
        let mut out: Vec<DocumentSymbol> = Vec::new();
        let mut rule_groups: Vec<(String, Vec<DocumentSymbol>)> = Vec::new();
        for item in flat {
            match &item.kind {
                ItemKind::Rule(r) if !r.name.text.is_empty() => {
                    let header = self.header_text(item.span, r);
                    let def = DocumentSymbol {
                        name: r.name.text.clone(),
                        detail: header,
                        kind: SymbolKind::RuleDefinition,
                        span: item.span,
                        selection: r.name.span,
                        children: vec![],
                    };
                    match rule_groups.iter_mut().find(|(n, _)| *n == r.name.text) {
                        Some((_, defs)) => defs.push(def),
                        None => rule_groups.push((r.name.text.clone(), vec![def])),
                    }
                }
                ItemKind::Namespace { name, items } => {
                    let full = qualify(ns, &name.text);
                    out.push(DocumentSymbol {
                        name: name.text.clone(),
                        detail: None,
                        kind: SymbolKind::Namespace,
                        span: item.span,
                        selection: name.span,
                        children: self.level(items, Some(&full)),
                    });
                }
                ItemKind::Function { name, body, .. } => out.push(DocumentSymbol {
                    name: name.text.clone(),
                    detail: Some(crate::fmt::expr(body)),
                    kind: SymbolKind::Function,
                    span: item.span,
                    selection: name.span,
                    children: vec![],
                }),
                ItemKind::Isosurface { name, .. } => out.push(DocumentSymbol {
                    name: name.text.clone(),
                    detail: Some("isosurface".to_string()),
                    kind: SymbolKind::Isosurface,
                    span: item.span,
                    selection: name.span,
                    children: vec![],
                }),
                ItemKind::Pre(Pre::Macro(m)) => out.push(DocumentSymbol {
                    name: m.name.text.clone(),
                    detail: Some(format!(
                        "({})",
                        m.params.iter().map(|p| p.text.as_str()).collect::<Vec<_>>().join(", ")
                    )),
                    kind: SymbolKind::Macro,
                    span: item.span,
                    selection: m.name.span,
                    children: vec![],
                }),
                ItemKind::Section(sec) => {
                    let (name, selection) = match &sec.name {
                        Some(n) => (format!("{} {}", sec.kind.text, n.text), n.span),
                        None => (sec.kind.text.clone(), sec.kind.span),
                    };
                    out.push(DocumentSymbol {
                        name,
                        detail: None,
                        kind: SymbolKind::Section,
                        span: item.span,
                        selection,
                        children: section_blocks(&sec.entries),
                    });
                }
                ItemKind::Pre(Pre::Shader { vertex, name, .. }) => out.push(DocumentSymbol {
                    name: name.text.clone(),
                    detail: Some(if *vertex { "vertex shader" } else { "fragment shader" }.to_string()),
                    kind: SymbolKind::Shader,
                    span: item.span,
                    selection: name.span,
                    children: vec![],
                }),
                _ => {}
            }
        }
        for (name, mut defs) in rule_groups {
            if defs.len() == 1 {
                let mut only = defs.remove(0);
                only.kind = SymbolKind::Rule;
                out.push(only);
            } else {
                let first = &defs[0];
                let last = &defs[defs.len() - 1];
                let span = Span::new(first.span.file, first.span.start, last.span.end.max(first.span.end));
                out.push(DocumentSymbol {
                    name,
                    detail: Some(format!("{} definitions", defs.len())),
                    kind: SymbolKind::Rule,
                    span,
                    selection: first.selection,
                    children: defs,
                });
            }
        }
        out.sort_by_key(|s| s.span.start);
        out
    }

    /// `weight 3`, `: xf`, … — what follows the rule's name in its header.
    fn header_text(&self, item: Span, r: &Rule) -> Option<String> {
        if item.file != r.body_span.file || r.name.span.end > r.body_span.start {
            return None;
        }
        let rest = self.span_text(Span::new(item.file, r.name.span.end, r.body_span.start));
        let rest = rest.split_whitespace().collect::<Vec<_>>().join(" ");
        (!rest.is_empty()).then_some(rest)
    }

    /// Symbols of every file in the analysis whose name matches `query` (case-insensitive,
    /// letters in order).
    pub fn workspace_symbols(&self, query: &str) -> Vec<WorkspaceSymbol> {
        let query = query.to_lowercase();
        let mut out: Vec<WorkspaceSymbol> = self
            .index()
            .symbols
            .iter()
            .filter_map(|o| {
                let Occ::Def(sym) = &o.occ else { return None };
                let kind = match sym {
                    Symbol::Rule(_) => SymbolKind::Rule,
                    Symbol::Namespace(_) => SymbolKind::Namespace,
                    Symbol::Function(_) => SymbolKind::Function,
                    Symbol::Isosurface(_) => SymbolKind::Isosurface,
                    Symbol::Macro(_) => SymbolKind::Macro,
                    Symbol::Shader { .. } => SymbolKind::Shader,
                    // Locals are not workspace symbols.
                    Symbol::Local { .. } => return None,
                };
                let name = sym.name().to_string();
                if !fuzzy(&name.to_lowercase(), &query) {
                    return None;
                }
                let container = name.rsplit_once('.').map(|(ns, _)| ns.to_string());
                Some(WorkspaceSymbol { name, kind, span: o.span, container })
            })
            .collect();
        out.sort_by_key(|s| (s.span.file, s.span.start));
        out.dedup();
        out
    }
}

/// The named blocks among a section's entries (`KEY NAME … { … }`), each with its
/// own named blocks; the named blocks of an unnamed block are lifted to its level.
fn section_blocks(entries: &[Entry]) -> Vec<DocumentSymbol> {
    let mut out = Vec::new();
    for e in entries {
        let Some((inner, _)) = &e.block else { continue };
        let children = section_blocks(inner);
        match e.values.first() {
            Some(Value::Word(w)) => out.push(DocumentSymbol {
                name: format!("{} {}", e.key.text, w.text),
                detail: None,
                kind: SymbolKind::SectionBlock,
                span: e.span,
                selection: w.span,
                children,
            }),
            _ => out.extend(children),
        }
    }
    out
}

fn collect_selections(syms: &[DocumentSymbol], out: &mut Vec<Span>) {
    for s in syms {
        out.push(s.selection);
        collect_selections(&s.children, out);
    }
}

/// Items with `@ifdef` branches spliced in.
fn flatten<'a>(items: &'a [Item], out: &mut Vec<&'a Item>) {
    for item in items {
        match &item.kind {
            ItemKind::Pre(Pre::IfDef { then, otherwise, .. }) => {
                flatten(then, out);
                if let Some(o) = otherwise {
                    flatten(o, out);
                }
            }
            _ => out.push(item),
        }
    }
}

/// Whether the letters of `query` appear in `name` in order.
fn fuzzy(name: &str, query: &str) -> bool {
    let mut chars = name.chars();
    query.chars().all(|q| chars.any(|c| c == q))
}

#[cfg(test)]
mod tests {
    use super::super::fixture::{doc, doc_with};
    use super::*;

    fn outline(syms: &[DocumentSymbol], depth: usize, out: &mut String) {
        for s in syms {
            let detail = s.detail.as_deref().map(|d| format!(" ({d})")).unwrap_or_default();
            out.push_str(&format!("{}{:?} {}{detail}\n", "  ".repeat(depth), s.kind, s.name));
            outline(&s.children, depth + 1, out);
        }
    }

    #[test]
    fn outline_groups_rules_and_nests_namespaces() {
        let src = "\
@macro TRI(n)
rule n { VERTEX {} }
@endmacro
startshape A
rule A { leaf {} }
rule leaf 3 { VERTEX {} }
rule leaf : spin { VERTEX {} }
namespace port {
  rule arm { VERTEX {} }
}
function band { z }
isosurface BALL { xyz -1 1 8 ; function band }
@ifdef DETAIL
rule extra { VERTEX {} }
@endif
@expand TRI(made)
@vertexshader vs
void main() {}
@endshader
rule spin { FRAME {} }
";
        let (d, _) = doc(src);
        let mut out = String::new();
        outline(&d.document_symbols(), 0, &mut out);
        assert_eq!(
            out,
            "\
Macro TRI ((n))
Rule A
Rule leaf (2 definitions)
  RuleDefinition leaf (3)
  RuleDefinition leaf (: spin)
Namespace port
  Rule arm
Function band (z)
Isosurface BALL (isosurface)
Rule extra
Rule made (from a macro expansion)
Shader vs (vertex shader)
Rule spin
"
        );
    }

    #[test]
    fn sections_and_their_named_blocks() {
        let src = "\
guide left {
  points 0 0 0  0 0 1  0.5 0 2  1.5 0 2.5;
  delta_a 0.6;
}
namespace n {
  creature monsters {
    part torso_h { type torso; rule h_torso; slot neck { at 0 0 1.4; normal 0 0 1; } }
    zz_group {
      rule grow_arms { zz 1; }
    }
    zz_numbered 3 { zz_inner x { } }
  }
}
search {
  skeleton h_torso;
}
rule h_torso { VERTEX {} }
grid g {
";
        let (d, _) = doc(src);
        let mut out = String::new();
        outline(&d.document_symbols(), 0, &mut out);
        assert_eq!(
            out,
            "\
Section guide left
Namespace n
  Section creature monsters
    SectionBlock part torso_h
      SectionBlock slot neck
    SectionBlock rule grow_arms
    SectionBlock zz_inner x
Section search
Rule h_torso
Section grid g
"
        );
        let syms = d.document_symbols();
        let guide = &syms[0];
        assert_eq!(d.span_text(guide.selection), "left");
        assert!(d.span_text(guide.span).starts_with("guide left {") && d.span_text(guide.span).ends_with('}'));
        let search = &syms[2];
        assert_eq!(d.span_text(search.selection), "search");
        let part = &syms[1].children[0].children[0];
        assert_eq!(d.span_text(part.selection), "torso_h");
        assert!(d.span_text(part.span).starts_with("part torso_h {"));
    }

    #[test]
    fn workspace_symbols_cover_imports() {
        let (d, _) = doc_with(
            "@import lib.mdg primitives\nstartshape A\nrule A { VERTEX {} }",
            &[("lib.mdg", "namespace n { rule shape { VERTEX {} } }\n")],
        );
        let names: Vec<String> = d
            .workspace_symbols("shp")
            .into_iter()
            .map(|s| format!("{:?} {} {:?}", s.kind, s.name, s.container))
            .collect();
        assert_eq!(names, ["Rule n.shape Some(\"n\")"]);
        let all = d.workspace_symbols("");
        assert!(all.iter().any(|s| s.name == "cube"), "std symbols are included");
        assert!(all.iter().any(|s| s.name == "SPHERE" && s.kind == SymbolKind::Isosurface));
    }
}
