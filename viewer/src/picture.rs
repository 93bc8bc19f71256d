//! Pictures for the command-line tools: a grammar's output rendered offscreen with
//! Vulkan (lavapipe without a GPU) to PNG bytes, reusing one device and one target
//! per size across calls (contact sheets render many models).
//!
//! `mdg-run --png` and every `mdg-run` mode (creature contact sheets, grid renders)
//! draw through [`install`]; where no Vulkan is available they fall back to the
//! software renderer (`mdg_vm::preview`) and say so once.

use crate::context::{Context, ContextOptions, Validation};
use crate::offscreen::Offscreen;
use crate::renderer::FrameParams;
use crate::Error;
use mdg_vm::bundle::Bundle;
use mdg_vm::output::Output;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// Renders outputs to PNG with one Vulkan device.
pub struct Pictures {
    ctx: Arc<Context>,
    target: Option<Offscreen>,
    std_dir: Option<PathBuf>,
}

impl Pictures {
    /// Opens a device (no validation unless `MDG_VALIDATION=1`).
    pub fn new(std_dir: Option<PathBuf>) -> Result<Pictures, Error> {
        let validation = match std::env::var("MDG_VALIDATION").as_deref() {
            Ok("1") => Validation::Required,
            _ => Validation::Off,
        };
        let ctx = Arc::new(Context::new(&ContextOptions { validation, surface_extensions: vec![] })?);
        Ok(Pictures { ctx, target: None, std_dir })
    }

    /// The device's name (for messages).
    pub fn device_name(&self) -> &str {
        &self.ctx.device_name
    }

    /// Renders `output` (of `bundle`: background, field of view, program, camera
    /// rule) at `time` seconds from the home view — or through the grammar's
    /// `camerarule` when it has one — and returns the PNG file's bytes.
    pub fn render(&mut self, bundle: &Bundle, output: &Output, size: (u32, u32), time: f32) -> Result<Vec<u8>, Error> {
        let reuse = self.target.as_ref().is_some_and(|t| (t.width, t.height) == size);
        if !reuse {
            self.target = None;
            self.target = Some(Offscreen::new(&self.ctx, size.0, size.1, 4)?);
        }
        let Some(off) = self.target.as_mut() else { return Err(Error::Other("no render target".into())) };
        let info = off.set_output(bundle, output, self.std_dir.as_deref())?;
        let frame =
            FrameParams { camera: off.home_camera(), time, wireframe: false, camera_rule: info.has_camera_rule };
        let px = off.render(&frame)?;
        mdg_vm::preview::encode_png(&px, size.0, size.1).map_err(Error::Other)
    }
}

/// Makes `mdg_compiler::modes::render_png` draw with Vulkan from now on, falling
/// back to the software renderer (with one note on stderr) where Vulkan cannot start.
pub fn install(std_dir: Option<PathBuf>) {
    let state: Mutex<Option<Result<Pictures, String>>> = Mutex::new(None);
    mdg_compiler::modes::set_renderer(Box::new(move |bundle, output, size| {
        let mut guard = state.lock().map_err(|_| "picture renderer poisoned".to_string())?;
        let pics = guard.get_or_insert_with(|| {
            Pictures::new(std_dir.clone()).map_err(|e| {
                eprintln!("note: {e}; pictures use the software renderer");
                e.to_string()
            })
        });
        match pics {
            Ok(p) => match bundle {
                Some(b) => p.render(b, output, size, 0.0),
                None => p.render(&Bundle::empty(), output, size, 0.0),
            }
            .map_err(|e| e.to_string()),
            Err(_) => Err(String::new()),
        }
    }));
}
