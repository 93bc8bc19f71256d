//! Inlay hints: the per-step transform of iterators with a divisor, shown after
//! the adjustment list: `30/30 * [ry 360]` → `30 × ry 12°`.

use super::index::Occ;
use super::iterator::fmt_num;
use super::Document;

/// A hint to show at a byte offset of the document.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InlayHint {
    pub offset: u32,
    pub label: String,
    pub tooltip: String,
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
            });
        }
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
}
