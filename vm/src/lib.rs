//! The MDG virtual machine: loads verified bundles, evaluates them depth-first with
//! an explicit stack, and produces flat geometry buffers for the exporters.
//!
//! This crate does not depend on the compiler; the compiler depends on it for the
//! bundle definitions.

pub mod anim;
pub mod bundle;
pub mod eval;
pub mod expr;
pub mod geom;
pub mod input;
pub mod output;
pub mod preview;
pub mod rng;
