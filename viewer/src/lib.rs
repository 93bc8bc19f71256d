//! MDG viewer: a Vulkan (ash) renderer for evaluated grammars, offscreen to PNG and
//! in a window (winit) with an orbit camera and hot reload.
//!
//! One module per Vulkan concept, each resource freeing itself in `Drop` and holding
//! an `Arc<Context>` so the device outlives it: [`context`] (instance, validation
//! messenger, device), [`buffer`], [`image`], [`sync`], [`pipeline`] (shader modules,
//! descriptor and pipeline layouts, pipelines), [`swapchain`], and [`renderer`] (the
//! render pass, attachments, uniforms and draw recording shared by [`offscreen`] and
//! [`window`]). CPU-side preparation has no Vulkan in it: [`model`] is a compiled and
//! evaluated grammar (compiled by the caller's [`model::Loader`]), [`scene`] packs the output into vertex buffers, [`camera`]
//! frames and orbits, [`uniforms`] lays out the blocks of docs/reference.md §13, and
//! [`program`] picks the SPIR-V (the bundle's `program` or std's Phong program).
//! [`cpu`] draws offscreen pictures without Vulkan for the programs it implements
//! exactly (std's Phong program, flat art), with lavapipe's rules.
//! [`guided`] is the guide editor of grammars with a `search` section (the search
//! in the background, editing guides, the overlay that shows them), plain Rust
//! that the window drives; [`input`] is the window's input from winit or from a
//! [`script`].
//!
//! The viewer compiles nothing and prints nothing: the program that drives it (the
//! `mdg-view` and `mdg-run` commands in `cli/`) passes in a [`model::Loader`] and
//! reads the messages it returns.

// Vulkan through ash is an FFI boundary: every call is `unsafe`. The workspace
// denies `unsafe_code`; this crate is the one allowed it (README, Boundary), and
// every unsafe block carries a `// SAFETY:` comment.
#![allow(unsafe_code)]

pub mod buffer;
pub mod camera;
pub mod context;
pub mod cpu;
pub mod guided;
pub mod image;
pub mod input;
pub mod model;
pub mod offscreen;
pub mod pipeline;
pub mod points;
pub mod program;
pub mod reload;
pub mod renderer;
pub mod scene;
pub mod script;
pub mod smooth;
pub mod swapchain;
pub mod sync;
pub mod uniforms;
pub mod window;

/// What can go wrong in the viewer.
#[derive(Debug)]
pub enum Error {
    /// No Vulkan loader, driver, device or validation layer: the message says what
    /// is missing; [`context::INSTALL_HINT`] says how to install it.
    NoVulkan(String),
    /// A Vulkan call failed.
    Vulkan(String),
    /// The grammar did not compile: rendered diagnostics.
    Compile(String),
    /// Reading or writing a file failed.
    Io(String),
    /// Anything else (bad arguments, a window system error).
    Other(String),
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Error::NoVulkan(m) => write!(f, "no usable Vulkan: {m}; {}", context::INSTALL_HINT),
            Error::Vulkan(m) => write!(f, "Vulkan error: {m}"),
            Error::Compile(m) => write!(f, "{m}"),
            Error::Io(m) => write!(f, "{m}"),
            Error::Other(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for Error {}

/// A background thread (the reload watcher, the guide watcher, the search worker)
/// that the system would not start.
#[derive(Debug)]
pub struct ThreadError {
    /// Which thread (`the reload thread`, `the mdg-search thread`, …).
    pub what: String,
    pub error: std::io::Error,
}

impl std::fmt::Display for ThreadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "cannot start {}: {}", self.what, self.error)
    }
}

impl std::error::Error for ThreadError {}
