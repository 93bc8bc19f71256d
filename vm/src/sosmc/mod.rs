//! Guided search: sequential Monte Carlo over skeleton derivations, steered by
//! guiding curves (SPEC §11, `papers/guiding-curves-sosmc.txt`).

use serde::{Deserialize, Serialize};

/// What a program's `guide` and `search` sections compile to.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GuidedTable {}

impl GuidedTable {
    /// Checks every index against the bundle (called by the bundle verifier).
    pub fn verify(&self, _bundle: &crate::bundle::Bundle) -> Result<(), String> {
        Ok(())
    }
}
