//! Grid shape grammars of voxel buildings (SPEC §11,
//! `papers/sigi-grammar-induction.txt`): generation, and the voxel formats.

use serde::{Deserialize, Serialize};

/// What a program's `grid` section compiles to.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GridGrammar {}

impl GridGrammar {
    /// Checks every index against the bundle (called by the bundle verifier).
    pub fn verify(&self, _bundle: &crate::bundle::Bundle) -> Result<(), String> {
        Ok(())
    }
}
