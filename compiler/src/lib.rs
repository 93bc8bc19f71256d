//! The MDG compiler: source text to checked program to bytecode bundle.
//!
//! Pipeline: [`lexer`] → [`parse`] (never fails) → [`expand`] (imports, macros,
//! conditionals) → [`check`] (names, values, reachability) → [`shaders`] (GLSL to
//! SPIR-V) → lowering. Diagnostics
//! are data ([`diag::Diagnostic`]) accumulated along the way.

pub mod ast;
pub mod diag;
pub mod dump;
pub mod lexer;
pub mod parse;
pub mod source;
pub mod span;
pub mod check;
pub mod consteval;
pub mod expand;
pub mod driver;
pub mod fmt;
pub mod lower;
pub mod shaders;
pub mod analysis;
