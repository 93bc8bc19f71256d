//! Stable in-process fuzzing for MDG (no nightly, no libFuzzer): mutators, a
//! generator of well-formed programs, and the targets — each a function from input
//! bytes to a coarse behaviour signature that panics on a bug.
//!
//! The `mdg-fuzz` binary (`src/main.rs`) drives them: it mutates corpus inputs (byte
//! flips, splices, token insert/delete/duplicate from the language's word lists),
//! catches panics per input, saves crashing inputs under `fuzz/crashes/TARGET/`, and
//! prints executions per second. `fuzz/README.md` lists the targets and the runs.

pub mod gen;
pub mod loader;
pub mod mutate;
pub mod rng;
pub mod targets;

pub use rng::Rng;
pub use targets::Target;
