//! Colour literals for the editor's colour swatches and picker: the `background
//! r g b a` directive (an absolute colour) and a call's adjustment list with colour
//! deltas (`{R -1 G -0.5}`), shown as the colour the deltas give from white — the
//! colour every model starts with (docs/reference.md, "Colour and weight"), and
//! colour values (`#ff8000`, `#tomato`) in any adjustment list. A picked colour is
//! written back in the same form: the directive's numbers, deltas from white in the
//! file's colour component names (`color` renames them), or `#rrggbb[aa]`.

use super::Document;
use crate::ast::*;
use crate::check::{AdjKind, Components};
use crate::span::Span;

/// How a colour is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorForm {
    /// `background r g b [a]`: the numbers are the colour.
    Background,
    /// Colour adjustments of a call: deltas from white.
    Deltas,
    /// A colour value, `#rrggbb` or `#name` (reference §5, "Colour by value").
    Value,
}

/// One colour in the document: the span of its numbers (or adjustments), the
/// colour in 0…1, and how it is written.
#[derive(Clone, Debug, PartialEq)]
pub struct ColorLiteral {
    pub span: Span,
    pub rgba: [f64; 4],
    pub form: ColorForm,
}

impl Document {
    /// Every colour literal of the document, in source order.
    pub fn colors(&self) -> Vec<ColorLiteral> {
        let comps = &self.analysis.checked.symbols.components;
        let mut out = Vec::new();
        colors_in(&self.analysis.expanded.main_ast.items, comps, &mut out);
        out.sort_by_key(|c| c.span);
        out
    }

    /// The text that writes `rgba` (components in 0…1) over the colour literal at
    /// `span` (as [`Document::colors`] gave it), or `None` if there is none there.
    pub fn color_presentation(&self, span: Span, rgba: [f64; 4]) -> Option<String> {
        let lit = self.colors().into_iter().find(|c| c.span == span)?;
        let comps = &self.analysis.checked.symbols.components;
        let c = rgba.map(|v| v.clamp(0.0, 1.0));
        match lit.form {
            ColorForm::Background => Some(format!("{} {} {} {}", num(c[0]), num(c[1]), num(c[2]), num(c[3]))),
            ColorForm::Value => Some(hex(c)),
            ColorForm::Deltas => {
                let mut words: Vec<String> = Vec::new();
                for (i, v) in c.iter().enumerate() {
                    let d = v - 1.0;
                    if num(d) != "0" {
                        words.push(format!("{} {}", comps.color[i], num(d)));
                    }
                }
                if words.is_empty() {
                    words.push(format!("{} 0", comps.color[0]));
                }
                // The other adjustments written between the colour ones stay, after them.
                let adjs = self.adjustments_in(span);
                for a in adjs {
                    if !matches!(comps.adj_kind(&a.name.text), Some(AdjKind::Color(_))) {
                        words.push(self.span_text(a.span).to_string());
                    }
                }
                Some(words.join(" "))
            }
        }
    }

    /// The adjustments of the main file's adjustment lists that lie inside `span`.
    fn adjustments_in(&self, span: Span) -> Vec<Adj> {
        let mut out = Vec::new();
        let mut lists = Vec::new();
        adj_lists(&self.analysis.expanded.main_ast.items, &mut lists);
        for l in lists {
            for a in &l.adjs {
                if span.start <= a.span.start && a.span.end <= span.end {
                    out.push(a.clone());
                }
            }
        }
        out
    }
}

/// A number as the picker writes it: at most three decimals, no trailing zeros.
fn num(v: f64) -> String {
    let s = format!("{:.3}", v);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" || s.is_empty() {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// A colour value as the picker writes it: `#rrggbb`, or `#rrggbbaa` when not opaque.
pub fn hex(rgba: [f64; 4]) -> String {
    let [r, g, b, a] = rgba.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8);
    if a == 255 {
        format!("#{r:02x}{g:02x}{b:02x}")
    } else {
        format!("#{r:02x}{g:02x}{b:02x}{a:02x}")
    }
}

fn literal(a: &Arg) -> Option<f64> {
    match a {
        Arg::Num(n) => Some(n.value),
        Arg::Neg(n) => Some(-n.value),
        Arg::Expr(_) => None,
    }
}

fn dir_literal(a: &DirArg) -> Option<(f64, Span)> {
    match a {
        DirArg::Num(n) => Some((n.value, n.span)),
        DirArg::Neg(n) => Some((-n.value, n.span)),
        _ => None,
    }
}

/// The colour of an adjustment list, if it has literal colour deltas (of R, G or B)
/// and no HSB change (whose result depends on the colour it starts from).
fn list_color(l: &AdjList, comps: &Components) -> Option<ColorLiteral> {
    let mut delta = [0.0; 4];
    let mut span: Option<Span> = None;
    let mut rgb = false;
    for a in &l.adjs {
        match comps.adj_kind(&a.name.text) {
            Some(AdjKind::Color(i)) => {
                let [arg] = a.args.as_slice() else { return None };
                delta[i as usize] += literal(arg)?;
                rgb |= i < 3;
                span = Some(span.map_or(a.span, |s| s.to(a.span)));
            }
            Some(AdjKind::Hsb(_) | AdjKind::Paint) => return None,
            _ => {}
        }
    }
    let span = span.filter(|_| rgb)?;
    Some(ColorLiteral { span, rgba: delta.map(|d| (1.0 + d).clamp(0.0, 1.0)), form: ColorForm::Deltas })
}

fn colors_in(items: &[Item], comps: &Components, out: &mut Vec<ColorLiteral>) {
    for item in items {
        if let ItemKind::Directive { name, args } = &item.kind {
            if name.text == "background" && (3..=4).contains(&args.len()) {
                let nums: Option<Vec<(f64, Span)>> = args.iter().map(dir_literal).collect();
                if let Some(nums) = nums {
                    let mut rgba = [1.0; 4];
                    for (i, (v, _)) in nums.iter().enumerate() {
                        rgba[i] = v.clamp(0.0, 1.0);
                    }
                    let span = nums[0].1.to(nums[nums.len() - 1].1);
                    out.push(ColorLiteral { span, rgba, form: ColorForm::Background });
                }
            }
        }
    }
    let mut lists = Vec::new();
    adj_lists(items, &mut lists);
    out.extend(lists.into_iter().filter_map(|l| list_color(l, comps)));
    // Colour values, in every list (an iterator's step sets the same value).
    let mut all = Vec::new();
    all_adj_lists(items, &mut all);
    for l in all {
        for a in &l.adjs {
            if comps.adj_kind(&a.name.text) == Some(AdjKind::Paint) {
                if let Ok(rgba) = crate::colour::parse(&a.name.text) {
                    out.push(ColorLiteral { span: a.name.span, rgba: rgba.map(f64::from), form: ColorForm::Value });
                }
            }
        }
    }
}

/// Every adjustment list of the rules: calls', iterators' and loops' steps.
fn all_adj_lists<'a>(items: &'a [Item], out: &mut Vec<&'a AdjList>) {
    for item in items {
        match &item.kind {
            ItemKind::Rule(r) => walk_body(&r.body, &mut |b| match &b.kind {
                BodyKind::Call { adj, .. } | BodyKind::Iterate { adj, .. } | BodyKind::Loop { adj, .. } => {
                    out.push(adj)
                }
                _ => {}
            }),
            ItemKind::Namespace { items, .. } => all_adj_lists(items, out),
            ItemKind::Pre(Pre::IfDef { then, otherwise, .. }) => {
                all_adj_lists(then, out);
                if let Some(o) = otherwise {
                    all_adj_lists(o, out);
                }
            }
            _ => {}
        }
    }
}

/// The adjustment lists of calls (not of iterators or loops, whose lists are steps).
fn adj_lists<'a>(items: &'a [Item], out: &mut Vec<&'a AdjList>) {
    for item in items {
        match &item.kind {
            ItemKind::Rule(r) => walk_body(&r.body, &mut |b| {
                if let BodyKind::Call { adj, .. } = &b.kind {
                    out.push(adj);
                }
            }),
            ItemKind::Namespace { items, .. } => adj_lists(items, out),
            ItemKind::Pre(Pre::IfDef { then, otherwise, .. }) => {
                adj_lists(then, out);
                if let Some(o) = otherwise {
                    adj_lists(o, out);
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::doc;
    use super::ColorForm;

    #[test]
    fn renamed_components_and_lists_without_a_plain_colour() {
        let src = "color red green blue alpha\nstartshape A\nrule A {\n  t {red -0.5 x 1}\n  t {R -1}\n  t {blue (1/2)}\n  3 * {green -0.1} t {}\n}\nrule t { VERTEX {} }\n";
        let (d, _) = doc(src);
        let cs = d.colors();
        assert_eq!(cs.len(), 1, "{cs:?}");
        assert_eq!(&src[cs[0].span.range()], "red -0.5");
        assert_eq!(cs[0].form, ColorForm::Deltas);
        assert_eq!(cs[0].rgba, [0.5, 1.0, 1.0, 1.0]);
        assert_eq!(d.color_presentation(cs[0].span, [1.0, 1.0, 1.0, 1.0]).as_deref(), Some("red 0"));
        assert_eq!(
            d.color_presentation(cs[0].span, [0.25, 0.123456, 1.0, 1.0]).as_deref(),
            Some("red -0.75 green -0.877")
        );
        // Only where a literal is.
        assert_eq!(d.color_presentation(crate::span::Span::new(d.main_file(), 0, 3), [1.0; 4]), None);
    }

    #[test]
    fn colour_values_are_swatches_written_back_as_hex() {
        let src = "startshape A\nrule A {\n  t {#ff8000 x 1}\n  t {x 1 #tomato R -1}\n  4 * {#0000ff80} t {}\n  t {#nosuchname}\n}\nrule t { VERTEX {} }\n";
        let (d, _) = doc(src);
        let cs = d.colors();
        let texts: Vec<&str> = cs.iter().map(|c| &src[c.span.range()]).collect();
        assert_eq!(texts, ["#ff8000", "#tomato", "#0000ff80"], "{cs:?}");
        assert!(cs.iter().all(|c| c.form == ColorForm::Value));
        let bytes = |i: usize| cs[i].rgba.map(|v| (v * 255.0).round() as u8);
        assert_eq!(bytes(0), [255, 128, 0, 255]);
        assert_eq!(bytes(1), [255, 99, 71, 255]);
        assert_eq!(bytes(2), [0, 0, 255, 128]);
        // Picked colours come back as #rrggbb, with the alpha byte only when not opaque.
        assert_eq!(d.color_presentation(cs[0].span, [0.0, 0.5, 1.0, 1.0]).as_deref(), Some("#0080ff"));
        assert_eq!(d.color_presentation(cs[1].span, [1.0, 1.0, 1.0, 0.25]).as_deref(), Some("#ffffff40"));
        // A list with a colour value is not also read as deltas from white.
        assert!(cs.iter().all(|c| &src[c.span.range()] != "R -1"));
    }
}
