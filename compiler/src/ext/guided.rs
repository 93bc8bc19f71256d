//! `guide` and `search` sections: keys, checks and lowering (see [`super`]).

use super::{CheckCx, Key, Sec};
use crate::ast::{Name, Section};
use crate::diag::Diagnostic;
use crate::lower::LowerCx;

/// The keys accepted at `path` (see [`super::keys`]).
pub fn keys(_path: &[&str]) -> &'static [Key] {
    &[]
}

/// Checks the program's sections of this kind.
pub fn check(sections: &[Sec], _cx: &CheckCx, diags: &mut Vec<Diagnostic>) {
    for s in sections {
        super::known_entries(&s.section.entries, keys(&[s.section.kind.text.as_str()]), "this section", diags);
    }
}

/// Rule names the section refers to.
pub fn rule_refs(_sec: &Section) -> Vec<&Name> {
    Vec::new()
}

/// Lowers the sections into the bundle's table.
pub fn lower(_sections: &[Sec], _cx: &LowerCx) -> Option<mdg_vm::sosmc::GuidedTable> {
    None
}
