//! Re-parsing only what an edit touched (issue 39): the language server parses a
//! document again at every keystroke, and most of a large file is unchanged.
//!
//! The whole new text is lexed and prepared as for a full parse (Context Free
//! rewriting, macros folded, brackets balanced, nesting limited: linear passes that
//! look across items). The prepared token stream is cut into **segments** before each
//! `rule` keyword outside any bracket, where the previous parse had a top-level item
//! boundary. A segment of the previous parse is reused when its text lies in the
//! part of the file the edit left alone (the common prefix, or the common suffix,
//! then shifted by the edit's change in length), its prepared tokens are the same
//! (kinds and relative positions: a comment opened elsewhere changes them), and its
//! parse had no error. The segments in between are parsed alone, as top-level items,
//! together with the first reused segment after them (the *guard*), which must come
//! out as it was: then nothing of the edited part reached into the rest of the file.
//!
//! Why this is the whole parse's tree: the grammar is LR(1) and `rule` cannot
//! continue a complete item (that would be a conflict), so items before a clean
//! segment boundary end there whatever follows; the parser's state after complete
//! items accepts the same tokens, and recovers from errors (`!` as a new item) the
//! same way, as at the start of a file; and once the guard has parsed as before, the
//! parser stands after complete items again. Everything the parser reads besides the
//! tokens is the whole file's (the adjustment names `color`/`weight` rename, compared
//! with the previous parse's; the folded macros; the bracket repairs). Whatever is not
//! covered — the colour names changed, nesting cut, no previous parse — is a whole
//! parse. `tests`: random edits, each compared with a whole parse.
//!
//! Reused items are not copied where they need not be: a rule (`ItemKind::Rule`, an
//! `Arc`) before the edit is the previous parse's own, shared; one after it is
//! copied to be shifted (its spans are absolute), unless the edit kept the length.

use super::{parse_prepared, Out, Prepared, Start};
use crate::ast::*;
use crate::diag::{Capped, Diagnostic};
use crate::lexer::{Tok, Token};
use crate::source::Sources;
use crate::span::{FileId, Span};
use std::ops::Range;

/// What a parse of a main file leaves for the next one: its segments.
#[derive(Clone, Debug, Default)]
pub struct Memo {
    /// The colour and weight component names the file renamed to (adjustment lists
    /// are grouped by them).
    components: ([String; 4], [String; 4]),
    /// The prepared tokens.
    pub(super) tokens: Vec<Token>,
    /// The text's lexing, as the lexer gave it (for the next version's
    /// [`crate::lexer::relex`]); `None` for a file too large to read.
    pub lexed: Option<crate::lexer::Lexed>,
    segments: Vec<Segment>,
}

/// A run of whole top-level items, from one `rule` at bracket depth 0 to the next.
#[derive(Clone, Debug)]
struct Segment {
    /// Byte range in the file.
    start: u32,
    end: u32,
    /// Its prepared tokens' indices.
    tokens: Range<usize>,
    /// The items' indices in the file's items.
    items: Range<usize>,
    /// Whether its parse gave no diagnostic (the parser's actions or syntax errors).
    clean: bool,
}

/// The previous parse of the same file, to reuse from.
#[derive(Clone, Copy)]
pub struct Previous<'p> {
    pub text: &'p str,
    pub items: &'p [Item],
    pub memo: &'p Memo,
}

/// How much a parse reused (for tests and measurements), and where the reused rules
/// after the edit came from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Reused {
    /// Items taken from the previous parse, and items parsed.
    pub items: usize,
    pub parsed: usize,
    /// The rules after the edit, copied to be shifted by [`Reused::delta`]: (the
    /// copy's `Arc` address, the previous parse's rule's). The checker's per-rule cache
    /// ([`crate::check`]) finds the previous results of a moved rule by it; the
    /// addresses are only compared while both parses are alive. (A rule before the
    /// edit is the previous parse's own `Arc`.)
    pub moved: Vec<(usize, usize)>,
    /// The edit's change in length: how far the moved rules' spans were shifted.
    pub delta: i64,
}

fn components(p: &Prepared) -> ([String; 4], [String; 4]) {
    (p.ctx.components.color.clone(), p.ctx.components.weight.clone())
}

/// The token indices where segments may start (a `rule` of `file` outside any
/// bracket), with their byte offsets; index 0 (offset 0) first.
fn boundaries(tokens: &[Token], file: FileId) -> Vec<(usize, u32)> {
    let mut out = vec![(0, 0)];
    let mut depth = 0usize;
    for (i, t) in tokens.iter().enumerate() {
        match t.kind {
            Tok::LBrace | Tok::LBracket | Tok::IndexOpen | Tok::LParen | Tok::CallOpen => depth += 1,
            Tok::RBrace | Tok::RBracket | Tok::RParen => depth = depth.saturating_sub(1),
            Tok::KwRule if depth == 0 && i > 0 && t.span.file == file => out.push((i, t.span.start)),
            _ => {}
        }
    }
    out
}

/// Whether `new` are the tokens `old` moved by `delta` bytes.
fn same_tokens(old: &[Token], new: &[Token], delta: i64) -> bool {
    old.len() == new.len()
        && old.iter().zip(new).all(|(o, n)| {
            o.kind == n.kind
                && o.span.file == n.span.file
                && i64::from(o.span.start) + delta == i64::from(n.span.start)
                && i64::from(o.span.end) + delta == i64::from(n.span.end)
        })
}

/// Whether a diagnostic lies in `start..=end`.
fn touches(d: &Diagnostic, file: FileId, start: u32, end: u32) -> bool {
    d.span.file != file || (d.span.start <= end && d.span.end >= start)
}

/// The segments of `tokens[range]` (byte range `bytes`), whose parse gave `items`
/// (numbered from `first_item`) and the diagnostics `diags`: cut at the boundaries
/// where an item starts and none runs across.
#[allow(clippy::too_many_arguments)]
fn segments_of(
    tokens: &[Token],
    bounds: &[(usize, u32)],
    bytes: Range<u32>,
    items: &[Item],
    first_item: usize,
    diags: &[&Diagnostic],
    all_unclean: bool,
    file: FileId,
) -> Vec<Segment> {
    // Item boundaries: each boundary offset must be an item's start, with no item
    // running across it.
    let mut cuts: Vec<(usize, u32, usize)> = Vec::new(); // (token index, offset, item index)
    let mut it = 0usize;
    for &(ti, off) in bounds.iter().filter(|(_, off)| *off >= bytes.start && *off < bytes.end) {
        if off == bytes.start {
            cuts.push((ti, off, 0));
            continue;
        }
        while it < items.len() && items[it].span.start < off {
            it += 1;
        }
        let starts_here = items.get(it).is_some_and(|i| i.span.start == off);
        let across = it > 0 && items[it - 1].span.end > off;
        if starts_here && !across {
            cuts.push((ti, off, it));
        }
    }
    if cuts.first().is_none_or(|c| c.1 != bytes.start) {
        return Vec::new();
    }
    let end_token = bounds.iter().find(|(_, off)| *off >= bytes.end).map_or(tokens.len(), |b| b.0);
    let mut out = Vec::with_capacity(cuts.len());
    for (k, &(ti, off, item)) in cuts.iter().enumerate() {
        let (next_ti, next_off, next_item) = cuts.get(k + 1).copied().unwrap_or((end_token, bytes.end, items.len()));
        let clean = !all_unclean && !diags.iter().any(|d| touches(d, file, off, next_off));
        out.push(Segment {
            start: off,
            end: next_off,
            tokens: ti..next_ti,
            items: first_item + item..first_item + next_item,
            clean,
        });
    }
    out
}

/// The memo of a whole parse.
pub(super) fn memo_of(p: &Prepared, items: &[Item], syntax: &Capped, file: FileId, len: u32) -> Memo {
    let own = p.ctx.diags.borrow();
    let actions: Vec<&Diagnostic> =
        own.list[p.prepass_diags.min(own.list.len())..].iter().chain(&syntax.list).collect();
    let all_unclean = own.suppressed.count > 0 || syntax.suppressed.count > 0;
    let bounds = boundaries(&p.tokens, file);
    let segments = segments_of(&p.tokens, &bounds, 0..len, items, 0, &actions, all_unclean, file);
    Memo { components: components(p), tokens: Vec::new(), lexed: None, segments }
}

/// Byte length of the common prefix and suffix of `a` and `b` (not overlapping).
fn common(a: &[u8], b: &[u8]) -> (usize, usize) {
    let pre = a.iter().zip(b).take_while(|(x, y)| x == y).count();
    let max_suf = a.len().min(b.len()) - pre;
    let suf = a.iter().rev().zip(b.iter().rev()).take(max_suf).take_while(|(x, y)| x == y).count();
    (pre, suf)
}

/// Parses the prepared tokens of `file` (text `text`) reusing `prev` where it can;
/// `None` where the whole file must be parsed (nothing is consumed then).
pub(super) fn reparse(
    p: &mut Prepared,
    sources: &Sources,
    file: FileId,
    prev: Previous,
) -> Option<(Vec<Item>, Capped, Memo, Reused)> {
    let text = sources.file(file).text.as_str();
    if p.cut.is_some() || components(p) != prev.memo.components || prev.memo.segments.is_empty() {
        return None;
    }
    let (old_len, new_len) = (prev.text.len() as u32, text.len() as u32);
    let delta = i64::from(new_len) - i64::from(old_len);
    let (pre, suf) = common(prev.text.as_bytes(), text.as_bytes());
    let bounds = boundaries(&p.tokens, file);
    // The token index of a segment boundary at `off` in the new text.
    let token_at = |off: u32| -> Option<usize> {
        if off == new_len {
            return Some(p.tokens.len());
        }
        bounds.binary_search_by_key(&off, |b| b.1).ok().map(|i| bounds[i].0)
    };
    let same = |seg: &Segment, start: u32, end: u32| -> bool {
        match (token_at(start), token_at(end)) {
            (Some(a), Some(b)) if a <= b => same_tokens(
                &prev.memo.tokens[seg.tokens.clone()],
                &p.tokens[a..b],
                i64::from(start) - i64::from(seg.start),
            ),
            _ => false,
        }
    };
    let segs = &prev.memo.segments;
    let mut n_pre = 0;
    while let Some(s) = segs.get(n_pre) {
        if !(s.clean && s.start < s.end && s.end as usize <= pre && same(s, s.start, s.end)) {
            break;
        }
        n_pre += 1;
    }
    let shift = |x: u32| (i64::from(x) + delta) as u32;
    let region_start = n_pre.checked_sub(1).map_or(0, |k| segs[k].end);
    let mut n_suf = 0;
    while n_suf + n_pre < segs.len() {
        let s = &segs[segs.len() - 1 - n_suf];
        let in_suffix =
            (s.start as usize) >= old_len as usize - suf && i64::from(s.start) + delta >= i64::from(region_start);
        if !(s.clean && s.start < s.end && in_suffix && same(s, shift(s.start), shift(s.end))) {
            break;
        }
        n_suf += 1;
    }
    // The first reused segment after the edit is parsed again, as the guard.
    let guard = (n_suf > 0).then(|| &segs[segs.len() - n_suf]);
    let n_suf = n_suf.saturating_sub(1);
    let suffix = &segs[segs.len() - n_suf..];
    let region_end = guard.map_or(new_len, |g| shift(g.end));
    let (a, b) = (token_at(region_start)?, token_at(region_end)?);
    // What the region's parse changes in the shared context, to undo on failure.
    let saved = (
        p.ctx.macros.borrow().clone(),
        p.ctx.expands.borrow().clone(),
        p.ctx.diags.borrow().list.clone(),
        p.ctx.diags.borrow().suppressed,
    );
    let (out, syntax) = parse_prepared(p, sources, &p.tokens[a..b], Start::Items);
    let region = match out {
        Out::Items(items) => items,
        _ => Vec::new(),
    };
    let ok = match guard {
        None => true,
        Some(g) => guard_holds(p, &region, &syntax, g, prev.items, shift(g.start), delta, file),
    };
    let restore = |p: &mut Prepared| {
        *p.ctx.macros.borrow_mut() = saved.0;
        *p.ctx.expands.borrow_mut() = saved.1;
        *p.ctx.diags.borrow_mut() = Capped { list: saved.2, suppressed: saved.3 };
    };
    if !ok {
        restore(p);
        return None;
    }
    // The new file's items and segments.
    let mut items: Vec<Item> = Vec::new();
    let mut segments: Vec<Segment> = Vec::new();
    for s in &segs[..n_pre] {
        let at = items.len();
        items.extend_from_slice(&prev.items[s.items.clone()]);
        let tokens = token_at(s.start)?..token_at(s.end)?;
        segments.push(Segment { items: at..items.len(), tokens, ..s.clone() });
    }
    let first_region_item = items.len();
    let parsed = region.len();
    {
        let own = p.ctx.diags.borrow();
        let actions: Vec<&Diagnostic> =
            own.list[p.prepass_diags.min(own.list.len())..].iter().chain(&syntax.list).collect();
        let all_unclean = own.suppressed.count > 0 || syntax.suppressed.count > 0;
        let region_segments = segments_of(
            &p.tokens,
            &bounds,
            region_start..region_end,
            &region,
            first_region_item,
            &actions,
            all_unclean,
            file,
        );
        if region_segments.is_empty() && !region.is_empty() {
            drop(own);
            restore(p);
            return None;
        }
        segments.extend(region_segments);
    }
    items.extend(region);
    let mut moved = Vec::new();
    for s in suffix {
        let at = items.len();
        // Items before the edit are shared with the previous parse (their rules are
        // `Arc`s); those after it are copied to be shifted, unless the edit kept the
        // length.
        items.extend(prev.items[s.items.clone()].iter().map(|old| {
            let mut i = old.clone();
            if delta != 0 {
                i.shift(delta);
                moved_rules(old, &i, &mut moved);
            }
            i
        }));
        let tokens = token_at(shift(s.start))?..token_at(shift(s.end))?;
        segments.push(Segment {
            start: shift(s.start),
            end: shift(s.end),
            items: at..items.len(),
            tokens,
            ..s.clone()
        });
    }
    let reused = Reused { items: items.len() - parsed, parsed, moved, delta };
    Some((items, syntax, Memo { components: components(p), tokens: Vec::new(), lexed: None, segments }, reused))
}

/// Pairs the rules of `new`, a shifted copy of `old`, with `old`'s (their `Arc`
/// addresses, for [`Reused::moved`]), in namespaces too.
fn moved_rules(old: &Item, new: &Item, out: &mut Vec<(usize, usize)>) {
    match (&old.kind, &new.kind) {
        (ItemKind::Rule(o), ItemKind::Rule(n)) => {
            out.push((std::sync::Arc::as_ptr(n) as usize, std::sync::Arc::as_ptr(o) as usize))
        }
        (ItemKind::Namespace { items: o, .. }, ItemKind::Namespace { items: n, .. }) => {
            o.iter().zip(n).for_each(|(o, n)| moved_rules(o, n, out))
        }
        _ => {}
    }
}

/// Whether the guard segment (`g` of the previous parse, at `start` now) came out of
/// the region's parse as it was: the same items, shifted, starting at its start, and
/// no diagnostic of the region's parse in it.
#[allow(clippy::too_many_arguments)]
fn guard_holds(
    p: &Prepared,
    region: &[Item],
    syntax: &Capped,
    g: &Segment,
    old: &[Item],
    start: u32,
    delta: i64,
    file: FileId,
) -> bool {
    let own = p.ctx.diags.borrow();
    let actions = own.list[p.prepass_diags.min(own.list.len())..].iter().chain(&syntax.list);
    if own.suppressed.count > 0 || syntax.suppressed.count > 0 {
        return false;
    }
    if actions.into_iter().any(|d| d.span.file != file || d.span.end >= start) {
        return false;
    }
    let Some(k) = region.iter().position(|i| i.span.start >= start) else { return false };
    if region[k].span.start != start || (k > 0 && region[k - 1].span.end > start) {
        return false;
    }
    let old = &old[g.items.clone()];
    region.len() - k == old.len()
        && region[k..].iter().zip(old).all(|(new, old)| {
            let mut o = old.clone();
            o.shift(delta);
            *new == o
        })
}

/// Parses the prepared tokens of a whole file.
pub(super) fn whole(p: &mut Prepared, sources: &Sources, file: FileId) -> (Vec<Item>, Capped, Memo) {
    let tokens = std::mem::take(&mut p.tokens);
    let (out, syntax) = parse_prepared(p, sources, &tokens, Start::File);
    p.tokens = tokens;
    let items = match out {
        Out::File(f) => f.items,
        _ => Vec::new(),
    };
    let memo = memo_of(p, &items, &syntax, file, sources.file(file).text.len() as u32);
    (items, syntax, memo)
}

/// Moves every span of a tree by `delta` bytes (the text before it grew or shrank).
pub trait Shift {
    fn shift(&mut self, delta: i64);
}

impl Shift for Span {
    fn shift(&mut self, delta: i64) {
        self.start = (i64::from(self.start) + delta) as u32;
        self.end = (i64::from(self.end) + delta) as u32;
    }
}

impl<T: Shift> Shift for Vec<T> {
    fn shift(&mut self, delta: i64) {
        self.iter_mut().for_each(|x| x.shift(delta));
    }
}

impl<T: Shift> Shift for Option<T> {
    fn shift(&mut self, delta: i64) {
        if let Some(x) = self {
            x.shift(delta);
        }
    }
}

impl<T: Shift> Shift for Box<T> {
    fn shift(&mut self, delta: i64) {
        (**self).shift(delta);
    }
}

impl Shift for Name {
    fn shift(&mut self, delta: i64) {
        self.span.shift(delta);
    }
}

impl Shift for Number {
    fn shift(&mut self, delta: i64) {
        self.span.shift(delta);
    }
}

impl Shift for Token {
    fn shift(&mut self, delta: i64) {
        self.span.shift(delta);
    }
}

impl Shift for Item {
    fn shift(&mut self, delta: i64) {
        self.span.shift(delta);
        match &mut self.kind {
            ItemKind::Startshape(n) | ItemKind::Linerule(n) | ItemKind::Camerarule(n) => n.shift(delta),
            ItemKind::Rule(r) => std::sync::Arc::make_mut(r).shift(delta),
            ItemKind::Selector { rules, mode } => {
                rules.shift(delta);
                match mode {
                    SelectorMode::Word(n) | SelectorMode::FunctionRef(n) => n.shift(delta),
                    SelectorMode::FunctionBody(e) => e.shift(delta),
                }
            }
            ItemKind::Namespace { name, items } => {
                name.shift(delta);
                items.shift(delta);
            }
            ItemKind::Directive { name, args } => {
                name.shift(delta);
                args.shift(delta);
            }
            ItemKind::Function { name, params, types, body } => {
                name.shift(delta);
                params.shift(delta);
                for t in types.iter_mut().flatten() {
                    t.shift(delta);
                }
                body.shift(delta);
            }
            ItemKind::Isosurface { name, entries } => {
                name.shift(delta);
                entries.shift(delta);
            }
            ItemKind::Program { words } => words.shift(delta),
            ItemKind::Section(s) => {
                s.kind.shift(delta);
                s.name.shift(delta);
                s.entries.shift(delta);
                s.body_span.shift(delta);
            }
            ItemKind::Pre(pre) => pre.shift(delta),
            ItemKind::Error => {}
        }
    }
}

impl Shift for Rule {
    fn shift(&mut self, delta: i64) {
        self.name.shift(delta);
        if let Some(p) = &mut self.params {
            p.span.shift(delta);
            for d in &mut p.params {
                d.ty.shift(delta);
                d.name.shift(delta);
                d.default.shift(delta);
                d.span.shift(delta);
            }
        }
        self.iter.shift(delta);
        self.transforms.shift(delta);
        self.adds.shift(delta);
        if let Some(w) = &mut self.weight {
            w.number.shift(delta);
        }
        self.weight_expr.shift(delta);
        if let Some(t) = &mut self.retire {
            t.keyword.shift(delta);
            t.depth.shift(delta);
            t.other.shift(delta);
            t.span.shift(delta);
        }
        self.body.shift(delta);
        self.body_span.shift(delta);
    }
}

impl Shift for Entry {
    fn shift(&mut self, delta: i64) {
        self.key.shift(delta);
        self.values.shift(delta);
        if let Some((entries, span)) = &mut self.block {
            entries.shift(delta);
            span.shift(delta);
        }
        self.span.shift(delta);
    }
}

impl Shift for Value {
    fn shift(&mut self, delta: i64) {
        match self {
            Value::Num(n) | Value::Neg(n) => n.shift(delta),
            Value::Expr(e) => e.shift(delta),
            Value::Word(w) => w.shift(delta),
            Value::Str(_, s) => s.shift(delta),
        }
    }
}

impl Shift for DirArg {
    fn shift(&mut self, delta: i64) {
        match self {
            DirArg::Num(n) | DirArg::Neg(n) => n.shift(delta),
            DirArg::Word(w) => w.shift(delta),
            DirArg::Expr(e) => e.shift(delta),
        }
    }
}

impl Shift for IsoEntry {
    fn shift(&mut self, delta: i64) {
        match self {
            IsoEntry::Axis { axis, args, span } => {
                axis.shift(delta);
                args.shift(delta);
                span.shift(delta);
            }
            IsoEntry::FunctionRef(n) => n.shift(delta),
            IsoEntry::FunctionBody(e) => e.shift(delta),
        }
    }
}

impl Shift for BodyItem {
    fn shift(&mut self, delta: i64) {
        self.span.shift(delta);
        match &mut self.kind {
            BodyKind::Call { name, args, profile, adj } => {
                name.shift(delta);
                if let Some(a) = args {
                    a.args.shift(delta);
                    a.span.shift(delta);
                }
                profile.shift(delta);
                adj.shift(delta);
            }
            BodyKind::If { cond, then, then_span, otherwise } => {
                cond.shift(delta);
                then.shift(delta);
                then_span.shift(delta);
                otherwise.shift(delta);
            }
            BodyKind::Let { name, value } => {
                name.shift(delta);
                value.shift(delta);
            }
            BodyKind::Loop { var, range, adj, item } => {
                var.shift(delta);
                range.start.shift(delta);
                range.end.shift(delta);
                range.step.shift(delta);
                adj.shift(delta);
                item.shift(delta);
            }
            BodyKind::Iterate { count, divisor, adj, item, .. } => {
                count.shift(delta);
                divisor.shift(delta);
                adj.shift(delta);
                item.shift(delta);
            }
            BodyKind::Block(items) => items.shift(delta),
            BodyKind::Switch(s) => {
                s.keyword.shift(delta);
                s.value.shift(delta);
                for arm in &mut s.arms {
                    for l in &mut arm.labels {
                        l.lo.shift(delta);
                        l.hi.shift(delta);
                    }
                    arm.body.shift(delta);
                    arm.span.shift(delta);
                }
                if let Some((items, span)) = &mut s.otherwise {
                    items.shift(delta);
                    span.shift(delta);
                }
                s.body_span.shift(delta);
                s.lowered.shift(delta);
            }
            BodyKind::Pre(pre) => pre.shift(delta),
            BodyKind::Error => {}
        }
    }
}

impl Shift for Count {
    fn shift(&mut self, delta: i64) {
        match self {
            Count::Num(n) | Count::Neg(n) => n.shift(delta),
            Count::Expr(e) => e.shift(delta),
        }
    }
}

impl Shift for AdjList {
    fn shift(&mut self, delta: i64) {
        self.span.shift(delta);
        for a in &mut self.adjs {
            a.name.shift(delta);
            a.args.shift(delta);
            a.span.shift(delta);
        }
    }
}

impl Shift for Arg {
    fn shift(&mut self, delta: i64) {
        match self {
            Arg::Num(n) | Arg::Neg(n) => n.shift(delta),
            Arg::Expr(e) => e.shift(delta),
        }
    }
}

impl Shift for Expr {
    fn shift(&mut self, delta: i64) {
        self.span.shift(delta);
        match &mut self.kind {
            ExprKind::Num(n) => n.shift(delta),
            ExprKind::Var(n) => n.shift(delta),
            ExprKind::Neg(e) | ExprKind::Paren(e) | ExprKind::Not(e) => e.shift(delta),
            ExprKind::Binary(_, a, b) => {
                a.shift(delta);
                b.shift(delta);
            }
            ExprKind::Call(n, args) => {
                n.shift(delta);
                args.shift(delta);
            }
            ExprKind::Let(bindings, body) => {
                for (name, value) in bindings {
                    name.shift(delta);
                    value.shift(delta);
                }
                body.shift(delta);
            }
            ExprKind::Tuple(xs) => xs.shift(delta),
            ExprKind::Index(v, i) => {
                v.shift(delta);
                i.shift(delta);
            }
            ExprKind::Error => {}
        }
    }
}

impl<T: Shift> Shift for Pre<T> {
    fn shift(&mut self, delta: i64) {
        match self {
            Pre::Import(v) | Pre::Param(v) | Pre::Presets(v) => v.shift(delta),
            Pre::Define { name, value } => {
                name.shift(delta);
                value.shift(delta);
            }
            Pre::Shader { name, code_span, .. } => {
                name.shift(delta);
                code_span.shift(delta);
            }
            Pre::Macro(m) => {
                m.name.shift(delta);
                m.params.shift(delta);
                m.body.shift(delta);
                m.body_span.shift(delta);
            }
            Pre::Expand { name, args } => {
                name.shift(delta);
                for a in args {
                    a.tokens.shift(delta);
                    a.span.shift(delta);
                }
            }
            Pre::IfDef { name, then, otherwise } => {
                name.shift(delta);
                then.shift(delta);
                otherwise.shift(delta);
            }
            Pre::Bad => {}
        }
    }
}
