//! The guide editor (docs/guided.md, "The editor in mdg-view"): for a grammar with a
//! `search` section, the viewer runs the guided search in the background whenever
//! the guides change, and lets the guides be edited in the window.
//!
//! Everything here is plain Rust, tested without a window or a GPU: [`edit`] holds
//! the guides being edited (picking, dragging in the view plane, strokes, deleting,
//! parameters, undo, JSON, the overlay lines), [`fit`] fits a stroke with a C1
//! Bézier chain, [`project`] maps between pixels and the world, [`search`] is one
//! search as the viewer runs it, [`worker`] the newest-wins background thread that
//! runs them, [`watch`] re-reads a `--guides` file when it changes, and [`session`]
//! ties them together for the window.

pub mod edit;
pub mod fit;
pub mod project;
pub mod search;
pub mod session;
pub mod watch;
pub mod worker;
