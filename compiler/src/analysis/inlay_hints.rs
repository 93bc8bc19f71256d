//! Inlay hints: the per-step transform of iterators with a divisor, shown after
//! the adjustment list: `30/30 * [ry 360]` → `30 × ry 12°`; and the parameter
//! names before the arguments of rule calls: `tree(n: 3, len: 0.8)`.

use super::index::Occ;
use super::iterator::fmt_num;
use super::Document;

/// A hint to show at a byte offset of the document.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InlayHint {
    pub offset: u32,
    pub label: String,
    pub tooltip: String,
    /// A parameter name before an argument (shown before the text, not after).
    pub parameter: bool,
}

impl Document {
    /// The hints for iterators with a divisor whose header lies in `start..=end`.
    pub fn inlay_hints(&self, start: u32, end: u32) -> Vec<InlayHint> {
        let mut out = Vec::new();
        for o in &self.index().main {
            let Occ::Iterator(info) = &o.occ else { continue };
            if info.divisor.is_none() || o.span.end < start || o.span.start > end {
                continue;
            }
            let step = self.step(info);
            if step.transform.is_empty() {
                continue;
            }
            let count = step.count.map(fmt_num).unwrap_or_else(|| "?".to_string());
            out.push(InlayHint {
                offset: o.span.end,
                label: format!("{count} × {}", step.transform),
                tooltip: format!("each of the {count} steps applies `{}`", step.transform),
                parameter: false,
            });
        }
        let sigs = &self.analysis.checked.symbols.signatures;
        for c in &self.index().calls {
            let Some(sig) = sigs.get(&c.rule) else { continue };
            // (A vector parameter is one argument: its components grouped back.)
            for (arg, p) in c.args.iter().zip(crate::types::param_groups(&sig.params)) {
                // An argument that is the parameter's own name needs no hint.
                if arg.start < start || arg.start > end || self.span_text(*arg) == p.name {
                    continue;
                }
                out.push(InlayHint {
                    offset: arg.start,
                    label: format!("{}:", p.name),
                    tooltip: format!("parameter `{} {}` of `{}`", p.ty, p.name, c.rule),
                    parameter: true,
                });
            }
        }
        out.sort_by_key(|h| h.offset);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::doc;

    #[test]
    fn hints_for_divisor_iterators_only() {
        let src = "rule A {\n  30/30 * [ry 360] B {x 3}\n  12 * {rz 30} B {}\n  1998/400 * [ry 360 y 0.002] VERTEX {x 4}\n}\nrule B { VERTEX {} }";
        let (d, _) = doc(src);
        let hints: Vec<(String, String)> = d
            .inlay_hints(0, d.text().len() as u32)
            .into_iter()
            .map(|h| (d.text()[..h.offset as usize].lines().last().unwrap_or("").trim().to_string(), h.label))
            .collect();
        assert_eq!(
            hints,
            [
                ("30/30 * [ry 360]".to_string(), "30 × ry 12°".to_string()),
                ("1998/400 * [ry 360 y 0.002]".to_string(), "1998 × ry 0.9° y 5.000e-6".to_string())
            ]
        );
        assert!(d.inlay_hints(0, 5).is_empty());
    }

    #[test]
    fn parameter_names_before_arguments() {
        let src = "rule A { tree(3, n) {} tree(2) {} }\nrule tree(int n, float len = 1) { VERTEX {x len} VERTEX {y n} VERTEX {} }";
        let (d, _) = doc(src);
        let hints: Vec<(u32, String, bool)> =
            d.inlay_hints(0, d.text().len() as u32).into_iter().map(|h| (h.offset, h.label, h.parameter)).collect();
        let at = |needle: &str| d.text().find(needle).expect("needle in the text") as u32;
        // `n` passed as `len` is labelled; `3` and `2` as `n`.
        assert_eq!(
            hints,
            [
                (at("3, n"), "n:".to_string(), true),
                (at("n) {}"), "len:".to_string(), true),
                (at("2)"), "n:".to_string(), true)
            ]
        );
    }

    /// A vector parameter takes one argument, labelled with its name.
    #[test]
    fn a_vector_parameter_is_one_argument() {
        let src = "rule A { dot((1, 2), 3) {} }\nrule dot(vector2 at, float r) { CIRCLE [x at s r] }";
        let (d, _) = doc(src);
        let hints: Vec<(u32, String, String)> =
            d.inlay_hints(0, d.text().len() as u32).into_iter().map(|h| (h.offset, h.label, h.tooltip)).collect();
        let at = |needle: &str| d.text().find(needle).expect("needle in the text") as u32;
        assert_eq!(
            hints,
            [
                (at("(1, 2)"), "at:".to_string(), "parameter `vector2 at` of `dot`".to_string()),
                (at("3)"), "r:".to_string(), "parameter `float r` of `dot`".to_string())
            ]
        );
    }
}
