//! Selection ranges ("expand selection"): the nested syntax around a position —
//! the word, then each enclosing node of the tree as written (an argument, an
//! adjustment, the adjustment list, the call, the block, the rule), then the file.

use super::Document;
use crate::ast::*;
use crate::span::Span;

impl Document {
    /// The spans around `offset` in the document, innermost first, each inside the
    /// next; the last is the whole file.
    pub fn selection_ranges(&self, offset: u32) -> Vec<Span> {
        let main = self.main_file();
        let mut spans = Vec::new();
        if let Some(t) = self.index().tokens.iter().find(|t| t.span.contains(offset) && t.span.start < t.span.end) {
            spans.push(t.span);
        }
        let mut c = Collect { offset, out: &mut spans };
        c.items(&self.analysis.expanded.main_ast.items);
        spans.retain(|s| s.file == main && s.contains(offset));
        spans.push(Span::new(main, 0, self.text().len() as u32));
        // Outermost first, then keep each span that lies inside the last one kept.
        spans.sort_by_key(|s| (std::cmp::Reverse(s.end - s.start), s.start));
        let mut chain: Vec<Span> = Vec::new();
        for s in spans {
            match chain.last() {
                Some(l) if *l == s || !(l.start <= s.start && s.end <= l.end) => {}
                _ => chain.push(s),
            }
        }
        chain.reverse();
        chain
    }
}

/// Pushes every span of the tree that holds the offset, descending only into nodes
/// that hold it.
struct Collect<'a> {
    offset: u32,
    out: &'a mut Vec<Span>,
}

impl Collect<'_> {
    fn hit(&mut self, s: Span) -> bool {
        let hit = s.contains(self.offset);
        if hit {
            self.out.push(s);
        }
        hit
    }

    fn name(&mut self, n: &Name) {
        self.hit(n.span);
    }

    fn items(&mut self, items: &[Item]) {
        for item in items {
            if self.hit(item.span) {
                self.item(item);
            }
        }
    }

    fn item(&mut self, item: &Item) {
        match &item.kind {
            ItemKind::Startshape(n) | ItemKind::Linerule(n) | ItemKind::Camerarule(n) => self.name(n),
            ItemKind::Rule(r) => {
                self.name(&r.name);
                if let Some(p) = &r.params {
                    if self.hit(p.span) {
                        for d in &p.params {
                            if self.hit(d.span) {
                                self.name(&d.ty);
                                self.name(&d.name);
                                if let Some(e) = &d.default {
                                    self.expr(e);
                                }
                            }
                        }
                    }
                }
                if let Some(e) = &r.weight_expr {
                    self.expr(e);
                }
                if self.hit(r.body_span) {
                    self.inner(r.body_span);
                    self.body(&r.body);
                }
            }
            ItemKind::Selector { rules, mode } => {
                for r in rules {
                    self.name(r);
                }
                match mode {
                    SelectorMode::Word(n) | SelectorMode::FunctionRef(n) => self.name(n),
                    SelectorMode::FunctionBody(e) => self.expr(e),
                }
            }
            ItemKind::Namespace { name, items } => {
                self.name(name);
                self.items(items);
            }
            ItemKind::Directive { name, args } => {
                self.name(name);
                for a in args {
                    self.dir_arg(a);
                }
            }
            ItemKind::Function { name, body, .. } => {
                self.name(name);
                self.expr(body);
            }
            ItemKind::Isosurface { name, entries } => {
                self.name(name);
                for e in entries {
                    match e {
                        IsoEntry::Axis { axis, args, span } => {
                            if self.hit(*span) {
                                self.name(axis);
                                for a in args {
                                    self.dir_arg(a);
                                }
                            }
                        }
                        IsoEntry::FunctionRef(n) => self.name(n),
                        IsoEntry::FunctionBody(e) => self.expr(e),
                    }
                }
            }
            ItemKind::Program { words } => {
                for w in words {
                    self.name(w);
                }
            }
            ItemKind::Section(s) => {
                self.name(&s.kind);
                if let Some(n) = &s.name {
                    self.name(n);
                }
                if self.hit(s.body_span) {
                    self.inner(s.body_span);
                    self.entries(&s.entries);
                }
            }
            ItemKind::Pre(p) => self.pre(p, &mut |c, items| c.items(items)),
            ItemKind::Error => {}
        }
    }

    /// The inside of braces `{ … }`, without them.
    fn inner(&mut self, braces: Span) {
        if braces.end >= braces.start + 2 {
            self.hit(Span::new(braces.file, braces.start + 1, braces.end - 1));
        }
    }

    fn pre<T>(&mut self, p: &Pre<T>, nested: &mut dyn FnMut(&mut Self, &[T])) {
        match p {
            Pre::Import(ns) | Pre::Param(ns) | Pre::Presets(ns) => {
                for n in ns {
                    self.name(n);
                }
            }
            Pre::Define { name, .. } => self.name(name),
            Pre::Shader { name, code_span, .. } => {
                self.name(name);
                self.hit(*code_span);
            }
            Pre::Macro(m) => {
                self.name(&m.name);
                self.hit(m.body_span);
            }
            Pre::Expand { name, args } => {
                self.name(name);
                for a in args {
                    self.hit(a.span);
                }
            }
            Pre::IfDef { name, then, otherwise } => {
                self.name(name);
                nested(self, then);
                if let Some(o) = otherwise {
                    nested(self, o);
                }
            }
            Pre::Bad => {}
        }
    }

    fn entries(&mut self, entries: &[Entry]) {
        for e in entries {
            if !self.hit(e.span) {
                continue;
            }
            self.name(&e.key);
            for v in &e.values {
                match v {
                    Value::Expr(x) => self.expr(x),
                    v => {
                        self.hit(v.span());
                    }
                }
            }
            if let Some((inner, span)) = &e.block {
                if self.hit(*span) {
                    self.inner(*span);
                    self.entries(inner);
                }
            }
        }
    }

    fn body(&mut self, items: &[BodyItem]) {
        for item in items {
            if self.hit(item.span) {
                self.body_item(item);
            }
        }
    }

    fn body_item(&mut self, item: &BodyItem) {
        match &item.kind {
            BodyKind::Call { name, args, profile, adj } => {
                self.name(name);
                if let Some(a) = args {
                    if self.hit(a.span) {
                        for e in &a.args {
                            self.expr(e);
                        }
                    }
                }
                if let Some(p) = profile {
                    self.name(p);
                }
                self.adj_list(adj);
            }
            BodyKind::If { cond, then, then_span, otherwise } => {
                self.expr(cond);
                if self.hit(*then_span) {
                    self.inner(*then_span);
                    self.body(then);
                }
                if let Some(o) = otherwise {
                    self.body(std::slice::from_ref(o));
                }
            }
            BodyKind::Let { name, value } => {
                self.name(name);
                self.expr(value);
            }
            BodyKind::Loop { var, range, adj, item } => {
                self.name(var);
                self.expr(&range.start);
                self.expr(&range.end);
                if let Some(s) = &range.step {
                    self.expr(s);
                }
                self.adj_list(adj);
                self.body(std::slice::from_ref(item));
            }
            BodyKind::Iterate { count, divisor, adj, item, .. } => {
                self.count(count);
                if let Some(d) = divisor {
                    self.count(d);
                }
                self.adj_list(adj);
                self.body(std::slice::from_ref(item));
            }
            BodyKind::Block(inner) => {
                self.inner(item.span);
                self.body(inner);
            }
            BodyKind::Switch(s) => {
                self.expr(&s.value);
                if self.hit(s.body_span) {
                    self.inner(s.body_span);
                    for arm in &s.arms {
                        if self.hit(arm.span) {
                            self.inner(arm.span);
                            for e in arm.labels.iter().flat_map(CaseLabel::exprs) {
                                self.expr(e);
                            }
                            self.body(&arm.body);
                        }
                    }
                    if let Some((items, span)) = &s.otherwise {
                        if self.hit(*span) {
                            self.inner(*span);
                            self.body(items);
                        }
                    }
                }
            }
            BodyKind::Pre(p) => self.pre(p, &mut |c, items| c.body(items)),
            BodyKind::Error => {}
        }
    }

    fn count(&mut self, c: &Count) {
        match c {
            Count::Expr(e) => self.expr(e),
            c => {
                self.hit(c.span());
            }
        }
    }

    fn adj_list(&mut self, l: &AdjList) {
        if !self.hit(l.span) {
            return;
        }
        self.inner(l.span);
        for a in &l.adjs {
            if self.hit(a.span) {
                self.name(&a.name);
                for arg in &a.args {
                    match arg {
                        Arg::Expr(e) => self.expr(e),
                        a => {
                            self.hit(a.span());
                        }
                    }
                }
            }
        }
    }

    fn dir_arg(&mut self, a: &DirArg) {
        match a {
            DirArg::Num(n) | DirArg::Neg(n) => {
                self.hit(n.span);
            }
            DirArg::Word(n) => self.name(n),
            DirArg::Expr(e) => self.expr(e),
        }
    }

    fn expr(&mut self, e: &Expr) {
        if !self.hit(e.span) {
            return;
        }
        match &e.kind {
            ExprKind::Num(_) | ExprKind::Var(_) | ExprKind::Error => {}
            ExprKind::Neg(x) | ExprKind::Paren(x) | ExprKind::Not(x) => self.expr(x),
            ExprKind::Binary(_, a, b) => {
                self.expr(a);
                self.expr(b);
            }
            ExprKind::Call(n, args) => {
                self.name(n);
                for a in args {
                    self.expr(a);
                }
            }
            ExprKind::Let(bindings, body) => {
                for (n, v) in bindings {
                    self.name(n);
                    self.expr(v);
                }
                self.expr(body);
            }
            ExprKind::Tuple(xs) => {
                for x in xs {
                    self.expr(x);
                }
            }
            ExprKind::Index(v, i) => {
                self.expr(v);
                self.expr(i);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::doc;

    #[test]
    fn every_offset_gets_a_chain_of_nested_spans_ending_with_the_file() {
        let src = "@define N 3\nnamespace ns {\n  rule r(int n) { if (n > 0) { loop i = 0, N {x 1} r(n - 1) {s 0.5 rz (i * 10)} } else { VERTEX {} } }\n}\nguide g { points 0 0 0  1 1 1; }\nstartshape ns.r\n";
        let (d, _) = doc(src);
        for offset in 0..=src.len() as u32 {
            let chain = d.selection_ranges(offset);
            let last = chain.last().copied().unwrap_or_default();
            assert_eq!((last.start, last.end), (0, src.len() as u32), "offset {offset}");
            for w in chain.windows(2) {
                let (inner, outer) = (w[0], w[1]);
                assert!(inner.contains(offset), "offset {offset}: {inner:?}");
                assert!(
                    outer.start <= inner.start && inner.end <= outer.end && inner != outer,
                    "offset {offset}: {chain:?}"
                );
            }
        }
        // Inside `(i * 10)`: the variable, the product, the parentheses, the adjustment, the list…
        let at = src.find("i * 10").unwrap_or(0) as u32;
        let texts: Vec<&str> = d.selection_ranges(at).iter().map(|s| &src[s.range()]).collect();
        assert_eq!(&texts[..5], ["i", "i * 10", "(i * 10)", "rz (i * 10)", "s 0.5 rz (i * 10)"]);
    }
}
