//! `mdg-run`'s modes for the SPEC §11 extensions. A bundle with a `creature` or a
//! `grid` section runs that mode instead of plain evaluation; one with guided-search
//! sections runs the search, then the usual export.

pub mod creature;
pub mod grid;
pub mod guided;

use mdg_vm::bundle::Bundle;
use mdg_vm::output::Output;
use std::path::Path;
use std::sync::OnceLock;

/// The options every mode shares with plain evaluation.
pub struct Common<'a> {
    /// The grammar file as given on the command line.
    pub file: &'a Path,
    /// `-o`, if given.
    pub output: Option<&'a Path>,
    /// `--seed`, if given.
    pub seed: Option<u64>,
    /// `--stats`.
    pub stats: bool,
    /// `--png`, if given.
    pub png: Option<&'a Path>,
    /// `--size` (width, height).
    pub size: (u32, u32),
}

/// A picture renderer: a bundle's output at a size → PNG bytes. `Err("")` means
/// "not available, use the software renderer".
pub type Renderer = Box<dyn Fn(Option<&Bundle>, &Output, (u32, u32)) -> Result<Vec<u8>, String> + Send + Sync>;

static RENDERER: OnceLock<Renderer> = OnceLock::new();

/// Installs the renderer [`render_png`] uses (the viewer's Vulkan one, from the
/// `mdg-run` binary). The first call wins.
pub fn set_renderer(r: Renderer) {
    let _ = RENDERER.set(r);
}

/// Renders a model to PNG bytes at `size` (the picture every mode writes: `--png`,
/// contact sheets, galleries). One place, so every mode's pictures look alike:
/// the installed renderer (Vulkan offscreen in `mdg-run`), else the software one.
pub fn render_png(out: &Output, size: (u32, u32)) -> Result<Vec<u8>, String> {
    render_png_of(None, out, size)
}

/// Like [`render_png`], with the bundle the output came from (its background,
/// field of view, shaders and camera rule).
pub fn render_png_of(bundle: Option<&Bundle>, out: &Output, size: (u32, u32)) -> Result<Vec<u8>, String> {
    if let Some(r) = RENDERER.get() {
        match r(bundle, out, size) {
            Ok(png) => return Ok(png),
            Err(e) if e.is_empty() => {}
            Err(e) => return Err(e),
        }
    }
    let opts = mdg_vm::preview::PreviewOptions { width: size.0, height: size.1, ..Default::default() };
    let rgba = mdg_vm::preview::render(out, &opts);
    mdg_vm::preview::encode_png(&rgba, size.0, size.1).map_err(|e| format!("cannot encode PNG: {e}"))
}
