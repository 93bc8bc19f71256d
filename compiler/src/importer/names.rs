//! MDG spellings for the importers: names that MDG accepts (a source name that is
//! an MDG keyword, adjustment, function or drawable gets a trailing `_`) and
//! numbers written so that they read back as the same `f64`.

use std::collections::BTreeMap;

/// Words an imported name may not be beyond the compiler's own tables (keywords,
/// documented directives, adjustments, functions, variables and drawables; see
/// [`is_reserved`]): parameter types and literals, and std `primitives`' rules (an
/// ES program's rules live beside them).
const RESERVED_BESIDES_TABLES: &[&str] = &[
    "int",
    "float",
    "bool",
    "true",
    "false",
    "SPHERE",
    "cube",
    "square",
    "disc",
    "circle",
    "cylinder",
    "torus",
    "torus_section",
    "CIRCLE",
    "SQUARE",
    "TRIANGLE",
];

/// Whether `word` is MDG's: a keyword, a documented directive, adjustment,
/// function, variable or drawable, or one of [`RESERVED_BESIDES_TABLES`]. Read from
/// the compiler's tables, so a word MDG gains is never an imported rule's name.
fn is_reserved(word: &str) -> bool {
    use crate::analysis::docs::{DocKind, DOCS};
    crate::lexer::KEYWORDS.contains(&word)
        || crate::lexer::CONTROL_KEYWORDS.contains(&word)
        || crate::symbols::DRAWABLES.contains(&word)
        || RESERVED_BESIDES_TABLES.contains(&word)
        || DOCS.iter().any(|d| {
            d.name == word
                && matches!(
                    d.kind,
                    DocKind::Directive
                        | DocKind::Adjustment
                        | DocKind::Drawable
                        | DocKind::Function
                        | DocKind::Variable
                )
        })
}

/// Source names to MDG names, one MDG name per source name and no two alike.
#[derive(Default)]
pub(crate) struct Names {
    map: BTreeMap<String, String>,
}

impl Names {
    /// The MDG name of `src` (made on first use).
    pub(crate) fn get(&mut self, src: &str) -> String {
        if let Some(n) = self.map.get(src) {
            return n.clone();
        }
        let mut base: String =
            src.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
        if base.is_empty() || base.starts_with(|c: char| c.is_ascii_digit()) {
            base.insert(0, 'n');
        }
        if is_reserved(&base) {
            base.push('_');
        }
        let mut name = base.clone();
        let mut k = 2;
        while self.map.values().any(|v| *v == name) {
            name = format!("{base}_{k}");
            k += 1;
        }
        self.map.insert(src.to_string(), name.clone());
        name
    }

    /// The source names that were renamed, with their MDG names.
    pub(crate) fn renamed(&self) -> Vec<(String, String)> {
        self.map.iter().filter(|(k, v)| k != v).map(|(k, v)| (k.clone(), v.clone())).collect()
    }
}

/// A number as MDG reads it: the shortest decimal that is the same `f64`, no
/// exponent (MDG numbers may have one, but short decimals read better), and a
/// non-finite value as a finite stand-in (the caller reports it).
pub(crate) fn num(v: f64) -> String {
    if !v.is_finite() {
        return if v > 0.0 {
            "1e30".into()
        } else if v < 0.0 {
            "-1e30".into()
        } else {
            "0".into()
        };
    }
    let s = format!("{v}");
    if s.contains('e') || s.len() > 24 {
        format!("{v:e}")
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_mdg_gains_are_reserved_from_its_tables() {
        // `select` came with the expression forms after the importer was written; a
        // hand-kept list had missed it.
        let mut n = Names::default();
        for w in ["select", "rule", "if", "hue", "camerafarplane", "smoothstep", "VERTEX", "cube"] {
            assert_eq!(n.get(w), format!("{w}_"), "{w} is MDG's");
        }
        assert_eq!(n.get("selection"), "selection");
    }

    #[test]
    fn reserved_and_odd_names_are_renamed_once() {
        let mut n = Names::default();
        assert_eq!(n.get("Tree"), "Tree");
        assert_eq!(n.get("loop"), "loop_");
        assert_eq!(n.get("x"), "x_");
        assert_eq!(n.get("a::b"), "a__b");
        assert_eq!(n.get("a__b"), "a__b_2");
        assert_eq!(n.get("loop"), "loop_");
        assert_eq!(n.get("3d"), "n3d");
        assert_eq!(n.renamed().len(), 5);
    }

    #[test]
    fn numbers_read_back_exactly() {
        for v in [0.0, 1.0, -0.5, 0.1, 1.0 / 3.0, 1e-9, 123456.0] {
            assert_eq!(num(v).parse::<f64>().ok(), Some(v));
        }
        assert_eq!(num(2.0), "2");
    }
}
