//! The MDG compiler: source text to checked program to bytecode bundle.
//!
//! Pipeline: [`lexer`] → [`parse`] (never fails) → [`expand`] (imports, macros,
//! conditionals) → [`check`] (names, values, reachability) → [`shaders`] (GLSL to
//! SPIR-V) → lowering. Diagnostics
//! are data ([`diag::Diagnostic`]) accumulated along the way.

pub mod adjust;
pub mod analysis;
pub mod ast;
pub mod benchmark;
pub mod cfdg;
pub mod check;
pub mod check_cache;
pub mod codes;
pub mod colour;
pub mod consteval;
pub mod diag;
pub mod driver;
pub mod dump;
pub mod embedded_std;
pub mod expand;
pub mod ext;
pub mod fmt;
pub mod functions;
pub mod importer;
pub mod induce;
pub mod lexer;
pub mod lower;
pub mod parse;
pub mod paths;
pub mod shader_limits;
pub mod shaders;
pub mod source;
pub mod span;
pub mod stdlib;
pub mod symbols;
pub mod text;
pub mod types;
pub mod vectors;
