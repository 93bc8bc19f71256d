//! Pictures for the commands: a grammar's output rendered to PNG bytes.
//!
//! [`Pictures`] is what every command and mode draws with (`mdg-run --png`, the
//! creature contact sheets, grid renders). [`Vulkan`] renders offscreen with the
//! viewer (lavapipe without a GPU), reusing one device and one target per size;
//! where no Vulkan can start it falls back to the software renderer
//! (`mdg_vm::preview`) and says so once. [`Software`] is the software renderer alone.

use crate::toolchain::Toolchain;
use mdg_viewer::context::{Context, ContextOptions, Validation};
use mdg_viewer::model::Loader as _;
use mdg_viewer::offscreen::Offscreen;
use mdg_viewer::program::Programs;
use mdg_viewer::renderer::FrameParams;
use mdg_viewer::Error;
use mdg_vm::bundle::Bundle;
use mdg_vm::output::Output;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// Renders a model (with the bundle it came from, for its background, field of view,
/// shaders and camera rule) to the bytes of a PNG file.
pub trait Pictures: Sync {
    fn render(&self, bundle: Option<&Bundle>, output: &Output, size: (u32, u32)) -> Result<Vec<u8>, String>;
}

/// The software renderer.
pub struct Software;

impl Pictures for Software {
    fn render(&self, _bundle: Option<&Bundle>, output: &Output, size: (u32, u32)) -> Result<Vec<u8>, String> {
        software(output, size)
    }
}

fn software(output: &Output, size: (u32, u32)) -> Result<Vec<u8>, String> {
    let opts = mdg_vm::preview::PreviewOptions { width: size.0, height: size.1, ..Default::default() };
    let rgba = mdg_vm::preview::render(output, &opts);
    mdg_vm::preview::encode_png(&rgba, size.0, size.1).map_err(|e| format!("cannot encode PNG: {e}"))
}

/// One Vulkan device and render target.
struct Device {
    ctx: Arc<Context>,
    target: Option<Offscreen>,
    programs: Programs,
}

impl Device {
    fn open(std_dir: Option<&std::path::Path>) -> Result<Device, Error> {
        let validation = match std::env::var("MDG_VALIDATION").as_deref() {
            Ok("1") => Validation::Required,
            _ => Validation::Off,
        };
        let programs = Toolchain.programs(std_dir)?;
        let ctx = Arc::new(Context::new(&ContextOptions {
            validation,
            surface_extensions: vec![],
            on_message: Some(crate::say),
        })?);
        Ok(Device { ctx, target: None, programs })
    }

    fn render(&mut self, bundle: &Bundle, output: &Output, size: (u32, u32)) -> Result<Vec<u8>, Error> {
        let reuse = self.target.as_ref().is_some_and(|t| (t.width, t.height) == size);
        if !reuse {
            self.target = None;
            self.target = Some(Offscreen::new(&self.ctx, size.0, size.1, 4)?);
        }
        let Some(off) = self.target.as_mut() else { return Err(Error::Other("no render target".into())) };
        let info = off.set_output(bundle, output, &self.programs)?;
        let frame =
            FrameParams { camera: off.home_camera(), time: 0.0, wireframe: false, camera_rule: info.has_camera_rule };
        let px = off.render(&frame)?;
        mdg_vm::preview::encode_png(&px, size.0, size.1).map_err(Error::Other)
    }
}

/// Vulkan offscreen pictures, opened on first use; the software renderer where
/// Vulkan cannot start (one note on stderr says so).
pub struct Vulkan {
    std_dir: Option<PathBuf>,
    device: Mutex<Option<Result<Device, String>>>,
}

impl Vulkan {
    pub fn new(std_dir: Option<PathBuf>) -> Vulkan {
        Vulkan { std_dir, device: Mutex::new(None) }
    }
}

impl Pictures for Vulkan {
    fn render(&self, bundle: Option<&Bundle>, output: &Output, size: (u32, u32)) -> Result<Vec<u8>, String> {
        let mut guard = self.device.lock().map_err(|_| "picture renderer poisoned".to_string())?;
        let device = guard.get_or_insert_with(|| {
            Device::open(self.std_dir.as_deref()).map_err(|e| {
                eprintln!("note: pictures are drawn by the software renderer, because Vulkan cannot start here ({e})");
                e.to_string()
            })
        });
        match device {
            Ok(d) => match bundle {
                Some(b) => d.render(b, output, size),
                None => d.render(&Bundle::empty(), output, size),
            }
            .map_err(|e| e.to_string()),
            Err(_) => software(output, size),
        }
    }
}
