//! Folding ranges: rule bodies, blocks, namespaces, functions, isosurfaces,
//! programs, extension sections and their nested blocks, `@ifdef` regions, macro and shader blocks, block comments, runs of
//! line comments and runs of `@import` lines. Only ranges over several lines.

use super::Document;
use crate::ast::*;
use crate::lexer::Tok;
use crate::span::Span;

/// What a fold is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FoldKind {
    Region,
    Comment,
    Imports,
}

/// A foldable span of the document.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fold {
    pub span: Span,
    pub kind: FoldKind,
}

impl Document {
    /// The folding ranges of the document, by start.
    pub fn folding_ranges(&self) -> Vec<Fold> {
        let mut out = Vec::new();
        items(&self.analysis.expanded.main_ast.items, &mut out);
        let idx = self.index();
        let file = self.analysis.sources.file(self.main_file());
        let line = |o: u32| file.line_col(o.min(file.text.len() as u32)).0;
        // Line comments alone on consecutive lines fold together.
        let mut run: Option<(Span, u32)> = None;
        let flush = |run: &mut Option<(Span, u32)>, out: &mut Vec<Fold>| {
            if let Some((span, _)) = run.take() {
                out.push(Fold { span, kind: FoldKind::Comment });
            }
        };
        for c in &idx.comments {
            if c.block {
                out.push(Fold { span: c.span, kind: FoldKind::Comment });
                continue;
            }
            let l = line(c.span.start);
            let alone = file.text[file.line_start(l) as usize..c.span.start as usize].trim().is_empty();
            match &mut run {
                Some((span, last)) if alone && *last + 1 == l => {
                    span.end = c.span.end;
                    *last = l;
                }
                _ => {
                    flush(&mut run, &mut out);
                    if alone {
                        run = Some((c.span, l));
                    }
                }
            }
        }
        flush(&mut run, &mut out);
        let mut imports: Option<Span> = None;
        for t in &idx.tokens {
            if t.kind == Tok::AtImport {
                imports = Some(match imports {
                    Some(s) if line(s.end) + 1 == line(t.span.start) => s.to(t.span),
                    Some(s) => {
                        out.push(Fold { span: s, kind: FoldKind::Imports });
                        t.span
                    }
                    None => t.span,
                });
            }
        }
        if let Some(s) = imports {
            out.push(Fold { span: s, kind: FoldKind::Imports });
        }
        let main = self.main_file();
        out.retain(|f| f.span.file == main && line(f.span.start) < line(f.span.end));
        out.sort_by_key(|f| (f.span.start, f.span.end));
        out.dedup();
        out
    }
}

fn items(list: &[Item], out: &mut Vec<Fold>) {
    for item in list {
        let region = |s: Span| Fold { span: s, kind: FoldKind::Region };
        match &item.kind {
            ItemKind::Rule(r) => {
                out.push(region(r.body_span));
                body(&r.body, out);
            }
            ItemKind::Namespace { items: inner, .. } => {
                out.push(region(item.span));
                items(inner, out);
            }
            ItemKind::Function { .. } | ItemKind::Isosurface { .. } | ItemKind::Program { .. } => {
                out.push(region(item.span))
            }
            ItemKind::Section(sec) => {
                out.push(region(item.span));
                entries(&sec.entries, out);
            }
            ItemKind::Pre(p) => pre(p, item.span, out, &mut |v: &[Item], out: &mut Vec<Fold>| items(v, out)),
            _ => {}
        }
    }
}

/// The nested blocks of a section's entries.
fn entries(list: &[Entry], out: &mut Vec<Fold>) {
    for e in list {
        if let Some((inner, _)) = &e.block {
            out.push(Fold { span: e.span, kind: FoldKind::Region });
            entries(inner, out);
        }
    }
}

fn pre<T>(p: &Pre<T>, span: Span, out: &mut Vec<Fold>, nested: &mut dyn FnMut(&[T], &mut Vec<Fold>)) {
    match p {
        Pre::Macro(_) | Pre::Shader { .. } => out.push(Fold { span, kind: FoldKind::Region }),
        Pre::IfDef { then, otherwise, .. } => {
            out.push(Fold { span, kind: FoldKind::Region });
            nested(then, out);
            if let Some(o) = otherwise {
                nested(o, out);
            }
        }
        _ => {}
    }
}

fn body(items: &[BodyItem], out: &mut Vec<Fold>) {
    for item in items {
        match &item.kind {
            BodyKind::Block(inner) => {
                out.push(Fold { span: item.span, kind: FoldKind::Region });
                body(inner, out);
            }
            BodyKind::Iterate { item: inner, .. } => body(std::slice::from_ref(inner), out),
            BodyKind::Switch(s) => {
                out.push(Fold { span: item.span, kind: FoldKind::Region });
                for arm in &s.arms {
                    out.push(Fold { span: arm.span, kind: FoldKind::Region });
                    body(&arm.body, out);
                }
                if let Some((items, span)) = &s.otherwise {
                    out.push(Fold { span: *span, kind: FoldKind::Region });
                    body(items, out);
                }
            }
            BodyKind::Pre(p) => pre(p, item.span, out, &mut |v: &[BodyItem], out: &mut Vec<Fold>| body(v, out)),
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::doc;

    #[test]
    fn folds_bodies_blocks_comments_and_preprocessor_regions() {
        let src = "\
@import primitives
@import lines
// one
// two
/* a
   b */
rule A {
  4 * {rz 90} {
    cube {}
  }
}
namespace n {
  rule B { VERTEX {} }
}
@ifdef X
rule C {
}
@endif
@vertexshader vs
void main() {}
@endshader
rule D { VERTEX {} }
";
        let (d, _) = doc(src);
        let file = d.analysis().sources.file(d.main_file());
        let got: Vec<String> = d
            .folding_ranges()
            .iter()
            .map(|f| format!("{:?} {}-{}", f.kind, file.line_col(f.span.start).0 + 1, file.line_col(f.span.end).0 + 1))
            .collect();
        assert_eq!(
            got,
            [
                "Imports 1-2",
                "Comment 3-4",
                "Comment 5-6",
                "Region 7-11",
                "Region 8-10",
                "Region 12-14",
                "Region 15-18",
                "Region 16-17",
                "Region 19-21"
            ]
        );
    }

    #[test]
    fn sections_and_nested_blocks_fold() {
        let src = "\
creature m {
  part p {
    slot s {
      at 0 0 1;
    }
    type t;
  }
  part q { type t; }
}
guide g { points 0 0 0 0 0 1 0 0 2 0 0 3; }
search {
  skeleton A;
}
rule A { VERTEX {} }
";
        let (d, _) = doc(src);
        let file = d.analysis().sources.file(d.main_file());
        let got: Vec<String> = d
            .folding_ranges()
            .iter()
            .map(|f| format!("{:?} {}-{}", f.kind, file.line_col(f.span.start).0 + 1, file.line_col(f.span.end).0 + 1))
            .collect();
        assert_eq!(got, ["Region 1-9", "Region 2-7", "Region 3-5", "Region 11-13"]);
    }
}
