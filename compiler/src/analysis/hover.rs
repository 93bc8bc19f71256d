//! Hover: Markdown for the word under the cursor — the docs of a built-in word, a
//! rule's definitions with weights and selector, an iterator's per-step transform,
//! the value of a number with a unit.

use super::docs::{self, DocKind};
use super::index::{IterInfo, Occ, Symbol};
use super::iterator::{self, angle_degrees, fmt_num, AngleUnit, StepContext};
use super::{location_text, Document};
use crate::ast::*;
use crate::check::AdjKind;
use crate::span::Span;

/// A hover: the span it describes and Markdown text.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Hover {
    pub span: Span,
    pub markdown: String,
}

/// A colour value's hover: its RGBA and its palette name (or the nearest one).
fn colour_value_hover(text: &str) -> Option<String> {
    let rgba = crate::colour::parse(text).ok()?;
    let bytes = rgba.map(|v| (v * 255.0).round() as u8);
    let hex = |b: [u8; 3]| format!("#{:02x}{:02x}{:02x}", b[0], b[1], b[2]);
    let rgb = [bytes[0], bytes[1], bytes[2]];
    let (name, named, exact) = crate::colour::nearest_palette_colour(rgb);
    let num = |v: f32| {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    };
    let name_part = if exact {
        let aside = if bytes[3] == 255 { "" } else { " (alpha aside)" };
        format!("palette name `{name}`{aside}")
    } else {
        format!("nearest palette name `{name}` (`{}`)", hex(named))
    };
    let shown = if bytes[3] == 255 { hex(rgb) } else { format!("{}{:02x}", hex(rgb), bytes[3]) };
    Some(format!(
        "**colour `{text}`** = `{shown}` (R {}, G {}, B {}, A {}), {name_part}\n\nSets the colour absolutely (reference §5, \"Colour by value\").",
        num(rgba[0]),
        num(rgba[1]),
        num(rgba[2]),
        num(rgba[3])
    ))
}

impl Document {
    /// The hover at `offset` in the document, if there is anything to say.
    pub fn hover(&self, offset: u32) -> Option<Hover> {
        let o = self.index().at(offset)?;
        let doc = |kind: DocKind, name: &str| docs::lookup(kind, name).map(|d| d.markdown());
        let markdown = match &o.occ {
            Occ::Def(sym) | Occ::Ref(sym) => self.symbol_hover(sym),
            Occ::UnknownRule(n) => Some(format!("unknown rule `{n}`")),
            Occ::Import(file) => file.map(|f| self.import_hover(f)),
            Occ::Drawable(n) => doc(DocKind::Drawable, n),
            Occ::Adjustment(n) => {
                let comps = &self.analysis.checked.symbols.components;
                if comps.adj_kind(n) == Some(AdjKind::Paint) {
                    return Some(Hover { span: o.span, markdown: colour_value_hover(n)? });
                }
                let canonical = match comps.adj_kind(n) {
                    Some(AdjKind::Color(i)) => ["R", "G", "B", "A"][i as usize],
                    Some(AdjKind::Weight(i)) => ["u", "v", "w", "q"][i as usize],
                    _ => n.as_str(),
                };
                doc(DocKind::Adjustment, canonical)
            }
            Occ::Directive(n) => doc(DocKind::Directive, n).map(|d| section_kind_hover(n, d)),
            Occ::SelectorMode(n) => doc(DocKind::SelectorMode, n),
            Occ::AngleMode(n) => doc(DocKind::AngleMode, n),
            Occ::Preprocessor(n) => doc(DocKind::Preprocessor, n),
            Occ::IsoEntry(n) => doc(DocKind::IsoEntry, n),
            Occ::ProgramCommand(n) => doc(DocKind::ProgramCommand, n),
            Occ::MathFunction(n) => doc(DocKind::Function, n),
            Occ::Variable(n) => doc(DocKind::Variable, n),
            Occ::Define(n) => Some(self.define_hover(n)),
            Occ::Iterator(info) => Some(self.iterator_hover(info, o.span)),
            Occ::Number { value, unit } => Some(number_hover(self.span_text(o.span), *value, *unit)),
            Occ::SectionKey(path) => section_key_hover(path),
        }?;
        Some(Hover { span: o.span, markdown })
    }

    fn symbol_hover(&self, sym: &Symbol) -> Option<String> {
        match sym {
            Symbol::Rule(full) => self.rule_hover(full),
            Symbol::Namespace(n) => {
                let rules: Vec<&str> = self
                    .analysis
                    .checked
                    .symbols
                    .rules
                    .keys()
                    .filter(|k| k.rsplit_once('.').is_some_and(|(ns, _)| ns == n))
                    .map(|k| k.as_str())
                    .collect();
                let shown: Vec<String> = rules.iter().take(12).map(|r| format!("`{r}`")).collect();
                let more = if rules.len() > 12 { ", …" } else { "" };
                Some(format!("**namespace `{n}`** — {} rule(s): {}{more}", rules.len(), shown.join(", ")))
            }
            Symbol::Function(f) => {
                let def = self.index().definitions(sym).next()?;
                let body = self.analysis.expanded.items.iter().find_map(|e| match &e.item.kind {
                    ItemKind::Function { name, body, .. } if name.span == def => Some(crate::fmt::expr(body)),
                    _ => None,
                })?;
                Some(format!("```mdg\nfunction {f} {{ {body} }}\n```\n{}", location_text(self, def)))
            }
            Symbol::Isosurface(n) => {
                let def = self.index().definitions(sym).next()?;
                let entries = self.analysis.expanded.items.iter().find_map(|e| match &e.item.kind {
                    ItemKind::Isosurface { name, entries } if name.span == def => Some(entries),
                    _ => None,
                })?;
                let parts: Vec<String> = entries
                    .iter()
                    .map(|e| match e {
                        IsoEntry::Axis { span, .. } => {
                            self.span_text(*span).split_whitespace().collect::<Vec<_>>().join(" ")
                        }
                        IsoEntry::FunctionRef(f) => format!("function {}", f.text),
                        IsoEntry::FunctionBody(b) => format!("function {{ {} }}", crate::fmt::expr(b)),
                    })
                    .collect();
                Some(format!(
                    "```mdg\nisosurface {n} {{ {} }}\n```\nAn isosurface drawable: `{n} {{…}}` instances it. {}",
                    parts.join(" ; "),
                    location_text(self, def)
                ))
            }
            Symbol::Macro(m) => {
                let def = self.index().definitions(sym).next();
                match def {
                    Some(d) => {
                        Some(format!("```mdg\n{}\n```\nmacro, {}", self.line_of(d).trim(), location_text(self, d)))
                    }
                    None => Some(format!("macro `{m}` (not defined)")),
                }
            }
            Symbol::Local { name, decl, what } => {
                let (kind, ty) = match what.split_once(' ') {
                    Some(("parameter", ty)) => ("parameter", Some(ty)),
                    _ => (what.as_str(), None),
                };
                let ty = ty.map(|t| format!(": `{t}`")).unwrap_or_default();
                Some(format!("**{kind} `{name}`**{ty}\n\n```mdg\n{}\n```", self.line_of(*decl).trim()))
            }
            Symbol::Shader { vertex, name } => {
                let def = self.index().definitions(sym).next();
                let kind = if *vertex { "vertex" } else { "fragment" };
                Some(match def {
                    Some(d) => format!("**{kind} shader `{name}`** (GLSL), {}", location_text(self, d)),
                    None => format!("{kind} shader `{name}` (not defined)"),
                })
            }
        }
    }

    /// The text of the line containing the start of `span`.
    fn line_of(&self, span: Span) -> &str {
        let text = self.file_text(span.file);
        let start = (span.start as usize).min(text.len());
        let begin = text[..start].rfind('\n').map(|i| i + 1).unwrap_or(0);
        let end = text[start..].find('\n').map(|i| start + i).unwrap_or(text.len());
        &text[begin..end]
    }

    fn rule_hover(&self, full: &str) -> Option<String> {
        let sym = &self.analysis.checked.symbols;
        let defs = sym.rules.get(full)?;
        let mode = sym.selectors.get(full).map(|(m, _)| match m {
            SelectorMode::Word(w) => w.text.clone(),
            SelectorMode::FunctionRef(f) => format!("function {}", f.text),
            SelectorMode::FunctionBody(e) => format!("function {{ {} }}", crate::fmt::expr(e)),
        });
        let mode_word = mode.clone().unwrap_or_else(|| "random".to_string());
        let weight = |item: usize| -> f64 {
            match &self.analysis.expanded.items.get(item).map(|e| &e.item.kind) {
                Some(ItemKind::Rule(r)) => match &r.weight {
                    Some(w) if w.negative => -w.number.value,
                    Some(w) => w.number.value,
                    None => 1.0,
                },
                _ => 1.0,
            }
        };
        let total: f64 = defs.iter().map(|d| weight(d.item).max(0.0)).sum();
        let mut out = String::new();
        let n = defs.len();
        if n == 1 {
            out.push_str(&format!("**rule `{full}`** — one definition, {}", location_text(self, defs[0].name_span)));
        } else {
            out.push_str(&format!("**rule `{full}`** — {n} definitions, selector `{mode_word}`"));
            if mode.is_none() {
                out.push_str(" (default)");
            }
        }
        out.push_str("\n\n```mdg\n");
        for d in defs {
            out.push_str(&self.rule_header(d.item));
            out.push('\n');
        }
        out.push_str("```\n");
        if n > 1 {
            for d in defs {
                let w = weight(d.item);
                let meaning = match mode_word.as_str() {
                    "random" | "frequency" if total > 0.0 => {
                        format!("weight {} ({}%)", fmt_num(w), fmt_num(100.0 * w.max(0.0) / total))
                    }
                    "depth" => format!("used up to depth {}", fmt_num(w)),
                    "scale" => format!("used from scale {}", fmt_num(w)),
                    "sequential" => format!("used {} time(s) in turn", fmt_num(w)),
                    "pattern" => "used once in turn".to_string(),
                    m if m.starts_with("function") => format!("used while the function is ≤ {}", fmt_num(w)),
                    _ => format!("weight {}", fmt_num(w)),
                };
                out.push_str(&format!("- {meaning} — {}\n", location_text(self, d.name_span)));
            }
        }
        if let Some(first) = defs.first() {
            let comment = self.doc_comment(first.item);
            if !comment.is_empty() {
                out.push('\n');
                out.push_str(&comment);
                out.push('\n');
            }
        }
        Some(out.trim_end().to_string())
    }

    /// `rule NAME [* I] [: X] [W]` as written, on one line.
    fn rule_header(&self, item: usize) -> String {
        let Some(e) = self.analysis.expanded.items.get(item) else { return String::new() };
        let ItemKind::Rule(r) = &e.item.kind else { return String::new() };
        let head = if e.item.span.file == r.body_span.file && e.item.span.start <= r.body_span.start {
            self.span_text(Span::new(r.body_span.file, e.item.span.start, r.body_span.start)).to_string()
        } else {
            String::new()
        };
        let head = head.split_whitespace().collect::<Vec<_>>().join(" ");
        // A rule from a macro expansion is written with the macro's parameter names.
        if head.starts_with("rule") && head.contains(&r.name.text) {
            head
        } else {
            let mut h = format!("rule {}", r.name.text);
            if let Some(w) = &r.weight {
                h.push(' ');
                if w.negative {
                    h.push('-');
                }
                h.push_str(&w.number.text);
            }
            h
        }
    }

    /// The `//` comment lines directly above an item.
    fn doc_comment(&self, item: usize) -> String {
        let Some(e) = self.analysis.expanded.items.get(item) else { return String::new() };
        let text = self.file_text(e.item.span.file);
        let start = (e.item.span.start as usize).min(text.len());
        let before = &text[..start];
        // The item must start its line.
        let line_start = before.rfind('\n').map(|i| i + 1).unwrap_or(0);
        if !before[line_start..].trim().is_empty() {
            return String::new();
        }
        let mut lines: Vec<&str> = Vec::new();
        for line in before[..line_start].lines().rev() {
            let t = line.trim();
            match t.strip_prefix("//") {
                Some(c) => lines.push(c.strip_prefix(' ').unwrap_or(c)),
                None => break,
            }
        }
        lines.reverse();
        lines.join("\n")
    }

    fn import_hover(&self, file: crate::span::FileId) -> String {
        let f = self.analysis.sources.file(file);
        let header: Vec<&str> = f
            .text
            .lines()
            .take_while(|l| l.trim_start().starts_with("//"))
            .map(|l| {
                let c = l.trim_start().trim_start_matches("//");
                c.strip_prefix(' ').unwrap_or(c)
            })
            .collect();
        let n_rules = self
            .analysis
            .checked
            .symbols
            .rules
            .values()
            .filter(|d| d.first().is_some_and(|d| d.name_span.file == file))
            .count();
        let mut out = format!("**{}** — {} rule(s)\n\n`{}`", f.name, n_rules, f.path.display());
        if !header.is_empty() {
            out.push_str("\n\n");
            out.push_str(&header.join("\n"));
        }
        out
    }

    fn define_hover(&self, name: &str) -> String {
        let ex = &self.analysis.expanded;
        if let Some(p) = ex.params.iter().find(|p| p.name.text == name) {
            let range = match (p.min, p.max) {
                (Some(lo), Some(hi)) => format!(", range {}–{}", fmt_num(lo), fmt_num(hi)),
                _ => String::new(),
            };
            return format!(
                "**@param {} `{name}`** = {} (default {}{range})",
                p.ty,
                fmt_num(p.value),
                fmt_num(p.default)
            );
        }
        match ex.defines.get(name) {
            Some(Some(v)) => format!("**@define `{name}`** = {}", fmt_num(*v)),
            Some(None) => format!("**@define `{name}`** (defined)"),
            None => format!("`{name}` is not defined"),
        }
    }

    fn iterator_hover(&self, info: &IterInfo, span: Span) -> String {
        let header = self.span_text(span).split_whitespace().collect::<Vec<_>>().join(" ");
        let step = self.step(info);
        let runs = match step.count {
            Some(c) => format!("{} step(s)", fmt_num(c)),
            None => "steps".to_string(),
        };
        let chained = if info.chain {
            "; chained: run 1 starts from the iterator's frame, each later run from the end state of the run \
             before it (its last drawable or MOVETO), composed with the step"
        } else {
            ""
        };
        if step.transform.is_empty() {
            format!("`{header}` → {runs} in place{chained}")
        } else {
            format!("`{header}` → {runs} of `{}`{chained}", step.transform)
        }
    }

    /// The per-step transform of an iterator.
    pub(crate) fn step(&self, info: &IterInfo) -> iterator::Step {
        let ex = &self.analysis.expanded;
        let constant = |n: &str| ex.constant(n);
        let cx = StepContext {
            angle: AngleUnit::of(ex),
            components: &self.analysis.checked.symbols.components,
            constant: &constant,
        };
        iterator::describe(info, &cx)
    }
}

/// A section keyword's doc with the keys its sections take (other directives as they are).
fn section_kind_hover(kind: &str, doc: String) -> String {
    if !crate::lexer::SECTION_KINDS.contains(&kind) {
        return doc;
    }
    let keys = crate::ext::keys(&[kind]);
    if keys.is_empty() {
        return doc;
    }
    format!("{doc}\n\nKeys: {}", key_list(keys))
}

/// `` `a`, `b`, `c` ``.
fn key_list(keys: &[crate::ext::Key]) -> String {
    keys.iter().map(|k| format!("`{}`", k.name)).collect::<Vec<_>>().join(", ")
}

/// A section key: how it is written and what it does, from [`crate::ext::keys`];
/// nothing for a key the section does not take (its diagnostic says so).
fn section_key_hover(path: &[String]) -> Option<String> {
    let (key, outer) = path.split_last()?;
    let outer: Vec<&str> = outer.iter().map(String::as_str).collect();
    let k = crate::ext::keys(&outer).iter().find(|k| k.name == key.as_str())?;
    let head = if k.values.is_empty() { k.name.to_string() } else { format!("{} {}", k.name, k.values) };
    let mut out = format!("```mdg\n{head}\n```\n{}", k.doc);
    let mut inner_path = outer;
    inner_path.push(k.name);
    let inner = crate::ext::keys(&inner_path);
    if !inner.is_empty() {
        out.push_str(&format!("\n\nIn its block: {}", key_list(inner)));
    }
    Some(out)
}

fn number_hover(text: &str, value: f64, unit: char) -> String {
    let deg = fmt_num(angle_degrees(value, Some(unit), AngleUnit::Degrees));
    let v = fmt_num(value);
    match unit {
        'd' => format!("`{text}`: {v} degrees"),
        'r' => format!("`{text}`: {v} radians = {deg}°"),
        'o' => format!("`{text}`: {v} orbit(s) = {deg}°"),
        't' => format!("`{text}`: atan({v}) = {deg}°"),
        _ => format!("`{text}`"),
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::{doc, doc_with};
    use super::super::index::Occ;
    use crate::span::Span;

    fn hover(src: &str) -> String {
        let (d, at) = doc(src);
        d.hover(at).map(|h| h.markdown).unwrap_or_else(|| "<none>".to_string())
    }

    #[test]
    fn adjustment_drawable_directive_and_selector_docs() {
        assert_eq!(hover("rule A { VERTEX {r$0x 30} }"), "```mdg\nrx A\n```\nRotate about the x axis by A.");
        assert!(hover("rule A { VER$0TEX {} }").starts_with("```mdg\nVERTEX {ADJ}\n```\nEmit a vertex"));
        assert!(hover("max$0depth 10\nrule A { VERTEX {} }").contains("A call deeper than N is not made"));
        assert!(hover("sta$0rtshape A\nrule A { VERTEX {} }").contains("The rule evaluated first"));
        assert!(hover("selector A dep$0th\nrule A 1 { VERTEX {} }\nrule A 2 { VERTEX {} }").contains("depth threshold"));
        assert!(hover("angle rad$0ians\nrule A { VERTEX {} }").contains("radians"));
        assert!(hover("@im$0port primitives\n").contains("@import NAME|PATH"));
        assert!(hover("@define X\n@ifdef X\n@end$0if\n").contains("Ends an `@ifdef`"));
        assert!(hover("rule A { VERTEX {x (s$0in(1))} }").contains("Sine"));
        assert!(hover("rule A { VERTEX {x i$0f(depth > 1, 1, 2)} }").contains("Only the chosen branch"));
        assert!(hover("rule A { VERTEX {x sel$0ect(depth, 1, 2)} }").contains("floored and clamped"));
        // A `let(…)` name is a local: its hover names the binding.
        assert!(
            hover("rule A { VERTEX {x let(k = 2; k$0 * k)} }").contains("let(…) binding"),
            "{}",
            hover("rule A { VERTEX {x let(k = 2; k$0 * k)} }")
        );
    }

    #[test]
    fn colour_values_are_named() {
        let h = hover("rule A { VERTEX {#tom$0ato} }");
        assert_eq!(h, "**colour `#tomato`** = `#ff6347` (R 1, G 0.388, B 0.278, A 1), palette name `tomato`\n\nSets the colour absolutely (reference §5, \"Colour by value\").");
        let h = hover("rule A { VERTEX {#ff6$0347} }");
        assert!(
            h.starts_with("**colour `#ff6347`** = `#ff6347` (R 1, G 0.388, B 0.278, A 1), palette name `tomato`"),
            "{h}"
        );
        let h = hover("rule A { VERTEX {#f$0f6348} }");
        assert!(h.contains("nearest palette name `tomato` (`#ff6347`)"), "{h}");
        let h = hover("rule A { VERTEX {#0$0000ff80} }");
        assert!(h.contains("(R 0, G 0, B 1, A 0.502), palette name `blue` (alpha aside)"), "{h}");
    }

    #[test]
    fn a_vector_parameter_shows_its_type() {
        let h = hover("rule circ(vector2 size) { CIRCLE [s s$0ize] }");
        assert!(h.starts_with("**parameter `size`**: `vector2`"), "{h}");
        let h = hover("rule circ(vec$0tor2 size) { CIRCLE [s size] }");
        assert!(h.contains("A vector parameter"), "{h}");
    }

    #[test]
    fn renamed_colour_components_show_the_colour_doc() {
        assert!(hover("color red green blue alpha\nrule A { VERTEX {gr$0een -1} }").contains("green colour component"));
    }

    #[test]
    fn rule_with_weights_and_selector() {
        let src = "startshape plant\nrule plant { le$0af {} }\n// A leaf.\n// Drawn small.\nrule leaf 3 { VERTEX {} }\nrule leaf { VERTEX {} }\nrule leaf 1 { VERTEX {} }\n";
        let expected = "**rule `leaf`** — 3 definitions, selector `random` (default)\n\n```mdg\nrule leaf 3\nrule leaf\nrule leaf 1\n```\n- weight 3 (60%) — line 5\n- weight 1 (20%) — line 6\n- weight 1 (20%) — line 7\n\nA leaf.\nDrawn small.";
        assert_eq!(hover(src), expected);
    }

    #[test]
    fn rule_with_depth_selector() {
        let src = "selector stack depth\nrule st$0ack 4 { stack {} }\nrule stack 5 { VERTEX {} }\n";
        let h = hover(src);
        assert!(h.contains("selector `depth`"), "{h}");
        assert!(h.contains("- used up to depth 4 — line 2"), "{h}");
    }

    #[test]
    fn imported_rule_shows_its_file_and_comment() {
        let h = hover("@import primitives\nstartshape A\nrule A { cu$0be {} }");
        assert!(h.starts_with("**rule `cube`** — one definition, std/primitives.mdg:"), "{h}");
        assert!(h.contains("A unit cube (side 1)"), "{h}");
    }

    #[test]
    fn divisor_iterator_step() {
        assert_eq!(
            hover("rule A { 30/3$00 * [ry 360] B {} }\nrule B { VERTEX {} }"),
            "`30/30 * [ry 360]` → 30 step(s) of `ry 12°`"
        );
        assert_eq!(
            hover("rule A { 10/10 * {z 5 s 0.5 R -1$0} B {} }\nrule B { VERTEX {} }"),
            "`10/10 * {z 5 s 0.5 R -1}` → 10 step(s) of `z 0.5 s 0.933 R -0.1`"
        );
        assert_eq!(
            hover("angle orbits\nrule A { 8/8 $0* {rz 1} B {} }\nrule B { VERTEX {} }"),
            "`8/8 * {rz 1}` → 8 step(s) of `rz 45°`"
        );
        assert_eq!(
            hover("@param int n 6 3 12\nrule A { (n)$0 * {rz (360 / n)} B {} }\nrule B { VERTEX {} }"),
            "`(n) * {rz (360 / n)}` → 6 step(s) of `rz 60°`"
        );
        assert_eq!(hover("rule A { 4 * {$0} B {} }\nrule B { VERTEX {} }"), "`4 * {}` → 4 step(s) in place");
    }

    #[test]
    fn chained_iterator_says_its_runs_chain() {
        let chained =
            "; chained: run 1 starts from the iterator's frame, each later run from the end state of the run \
                       before it (its last drawable or MOVETO), composed with the step";
        assert_eq!(
            hover("rule A { 2 $0* {} \\ B {} }\nrule B { VERTEX {} }"),
            format!("`2 * {{}}` → 2 step(s) in place{chained}")
        );
        assert_eq!(
            hover("rule A { 4/4 * {rz 36$00} \\ B {} }\nrule B { VERTEX {} }"),
            format!("`4/4 * {{rz 360}}` → 4 step(s) of `rz 90°`{chained}")
        );
    }

    #[test]
    fn numbers_with_units() {
        assert_eq!(hover("rule A { B {rz 0.25$0o} }\nrule B { VERTEX {} }"), "`0.25o`: 0.25 orbit(s) = 90°");
        assert_eq!(hover("rule A { B {ry 2$0t} }\nrule B { VERTEX {} }"), "`2t`: atan(2) = 63.4349°");
    }

    #[test]
    fn namespace_function_isosurface_and_params() {
        let h = hover("namespace port { rule arm { VERTEX {} } }\nrule A { po$0rt.arm {} }");
        assert_eq!(h, "**namespace `port`** — 1 rule(s): `port.arm`");
        let h =
            hover("function band { z }\nselector b function ba$0nd\nrule b 1 { VERTEX {} }\nrule b 2 { VERTEX {} }");
        assert_eq!(h, "```mdg\nfunction band { z }\n```\nline 1");
        let h = hover("isosurface BALL { xyz -1 1 8 ; function { x*x - 1 } }\nrule A { BA$0LL {} }");
        assert!(h.starts_with("```mdg\nisosurface BALL { xyz -1 1 8 ; function { x * x - 1 } }\n```"), "{h}");
        assert_eq!(
            hover("@param int count 5 1 20\nrule A { (co$0unt) * {} B {} }\nrule B { VERTEX {} }"),
            "**@param int `count`** = 5 (default 5, range 1–20)"
        );
    }

    #[test]
    fn imports_and_macros() {
        let h = hover("@import primi$0tives\n");
        assert!(h.starts_with("**std/primitives.mdg** — "), "{h}");
        let (d, at) = doc_with(
            "@import lib.mdg\n@expand TR$0I(1)\n",
            &[("lib.mdg", "@macro TRI(s)\nrule tri { VERTEX {x s} }\n@endmacro\n")],
        );
        let h = d.hover(at).map(|h| h.markdown).unwrap_or_default();
        assert_eq!(h, "```mdg\n@macro TRI(s)\n```\nmacro, lib.mdg:1");
    }

    #[test]
    fn section_keywords_say_what_the_section_is_for() {
        for (kind, page) in [
            ("guide", "docs/guided.md"),
            ("search", "docs/guided.md"),
            ("creature", "docs/creatures.md"),
            ("grid", "docs/grid.md"),
        ] {
            let h = hover(&format!("{}$0{} x {{\n}}\n", &kind[..1], &kind[1..]));
            assert!(h.starts_with(&format!("```mdg\n{kind} [NAME] {{")), "{h}");
            assert!(h.contains(page), "{h}");
            for k in crate::ext::keys(&[kind]) {
                assert!(h.contains(&format!("`{}`", k.name)), "{kind} hover lacks key {}: {h}", k.name);
            }
        }
        // A section word used as a rule name is the rule.
        assert!(hover("startshape grid\nrule gr$0id { VERTEX {} }").starts_with("**rule `grid`**"));
    }

    #[test]
    fn every_key_of_every_section_shows_its_doc() {
        let mut seen = 0;
        for kind in crate::lexer::SECTION_KINDS {
            let src = super::super::fixture::section_sample(kind);
            let (d, _) = doc(&src);
            let keys: Vec<(Span, Vec<String>)> = d
                .index()
                .main
                .iter()
                .filter_map(|o| match &o.occ {
                    Occ::SectionKey(p) => Some((o.span, p.clone())),
                    _ => None,
                })
                .collect();
            assert_eq!(keys.len(), src.lines().filter(|l| l.ends_with(';') || l.ends_with('{')).count() - 1, "{src}");
            for (span, path) in keys {
                let (name, outer) = path.split_last().expect("a path has a key");
                let outer: Vec<&str> = outer.iter().map(String::as_str).collect();
                let key = crate::ext::keys(&outer).iter().find(|k| k.name == name).expect("the sample uses table keys");
                let h = d.hover(span.start + 1).expect("a key has a hover");
                assert_eq!(h.span, span);
                let head = format!("{} {}", key.name, key.values);
                assert!(h.markdown.starts_with(&format!("```mdg\n{}\n```\n{}", head.trim_end(), key.doc)), "{h:?}");
                seen += 1;
            }
        }
        let total: usize = crate::lexer::SECTION_KINDS.iter().map(|k| crate::ext::keys(&[k]).len()).sum();
        assert!(seen >= total, "{seen} keys hovered, {total} at the top level of the tables");
    }

    #[test]
    fn section_keys_know_their_path_and_unknown_keys_say_nothing() {
        let src = "creature m {\n  part torso_h { type torso; rule h_torso; slot neck { at 0 0 1.4; } }\n  zz_no_such_key 1;\n}\nrule h_torso { VERTEX {} }\n";
        let (d, _) = doc(src);
        let path_at = |needle: &str| match src.find(needle).and_then(|i| d.index().at(i as u32 + 1)).map(|o| &o.occ) {
            Some(Occ::SectionKey(p)) => p.join(" "),
            other => format!("{other:?}"),
        };
        assert_eq!(path_at("part"), "creature part");
        assert_eq!(path_at("type"), "creature part type");
        assert_eq!(path_at("rule h_torso;"), "creature part rule");
        assert_eq!(path_at("slot"), "creature part slot");
        assert_eq!(path_at("at 0"), "creature part slot at");
        assert_eq!(path_at("zz_no"), "creature zz_no_such_key");
        assert_eq!(hover(&src.replace("zz_no", "zz_n$0o")), "<none>");
        // A keyword used as a key is not the keyword.
        assert!(!hover(&src.replace("rule h_torso;", "ru$0le h_torso;")).contains("A rule definition"));
        assert!(!hover("grid g { weight$0 2; }").contains("Renames the weight"));
    }

    #[test]
    fn section_values_hover_like_elsewhere() {
        assert_eq!(hover("@define W 3\nguide g { zz_width W$0; }"), "**@define `W`** = 3");
        assert_eq!(hover("guide g { zz_turn 0.25$0o; }"), "`0.25o`: 0.25 orbit(s) = 90°");
        assert!(hover("guide g { zz_size (s$0in(1)); }").contains("Sine"));
        assert_eq!(hover("guide g { zz_file \"a$0.obj\"; }"), "<none>");
    }

    #[test]
    fn nothing_on_whitespace_and_unknown_rules_are_named() {
        assert_eq!(hover("rule A {$0 }"), "<none>");
        assert_eq!(hover("rule A { nope$0 {} }"), "unknown rule `nope`");
    }
}
