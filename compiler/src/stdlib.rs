//! What the std library defines, for the hint on an unknown name: a call of a rule
//! or isosurface that a std library file defines (`SPHERE {}` without `@import
//! primitives`, as thesis Listing 4.1 is printed) gets E0301 with a suggestion that
//! adds the right `@import` (a quick fix in the editor). See docs/decisions.md
//! (issue 17) for why this is a fix and not an implicit prelude.
//!
//! The std files are compiled in, so the hint does not depend on where the std
//! directory is installed; `tests/tests/check.rs` checks that every file of `std/`
//! is listed.

use crate::lexer::{self, Tok};
use crate::span::FileId;
use std::collections::HashMap;
use std::sync::OnceLock;

/// Every std library: its `@import` name and its text.
pub const LIBRARIES: &[(&str, &str)] = &[
    ("creatures", include_str!("../../std/creatures.mdg")),
    ("lines", include_str!("../../std/lines.mdg")),
    ("lsystems", include_str!("../../std/lsystems.mdg")),
    ("molecules", include_str!("../../std/molecules.mdg")),
    ("plants", include_str!("../../std/plants.mdg")),
    ("polyhedra", include_str!("../../std/polyhedra.mdg")),
    ("primitives", include_str!("../../std/primitives.mdg")),
    ("shaders", include_str!("../../std/shaders.mdg")),
    ("sphereflake", include_str!("../../std/sphereflake.mdg")),
];

/// The names each library declares at its top level (`rule NAME`, `isosurface NAME`),
/// mapped to the first library (in [`LIBRARIES`] order) that declares them.
fn index() -> &'static HashMap<String, &'static str> {
    static INDEX: OnceLock<HashMap<String, &'static str>> = OnceLock::new();
    INDEX.get_or_init(|| {
        let mut map = HashMap::new();
        for (lib, text) in LIBRARIES {
            let lexed = lexer::lex(text, FileId(0));
            let mut depth = 0usize;
            let toks = &lexed.tokens;
            for (i, t) in toks.iter().enumerate() {
                match t.kind {
                    Tok::LBrace | Tok::LBracket | Tok::LParen | Tok::CallOpen => depth += 1,
                    Tok::RBrace | Tok::RBracket | Tok::RParen => depth = depth.saturating_sub(1),
                    Tok::KwRule | Tok::KwIsosurface if depth == 0 => {
                        if let Some(n) = toks.get(i + 1).filter(|n| n.kind == Tok::Ident) {
                            let name = &text[n.span.start as usize..n.span.end as usize];
                            map.entry(name.to_string()).or_insert(*lib);
                        }
                    }
                    _ => {}
                }
            }
        }
        map
    })
}

/// The std library that defines rule or isosurface `name`, if any.
pub fn library_defining(name: &str) -> Option<&'static str> {
    index().get(name).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn std_names_map_to_their_library() {
        assert_eq!(library_defining("SPHERE"), Some("primitives"));
        assert_eq!(library_defining("cube"), Some("primitives"));
        assert_eq!(library_defining("sic_lattice"), Some("molecules"));
        assert_eq!(library_defining("no_such_rule_anywhere"), None);
    }
}
