//! Creature grammar: sets of monsters evolved from regular creatures (SPEC §11,
//! `papers/creature-grammar.txt`).

use serde::{Deserialize, Serialize};

/// What a program's `creature` sections compile to.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CreatureTable {}

impl CreatureTable {
    /// Checks every index against the bundle (called by the bundle verifier).
    pub fn verify(&self, _bundle: &crate::bundle::Bundle) -> Result<(), String> {
        Ok(())
    }
}
