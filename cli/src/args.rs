//! Command-line options shared by `mdgc`, `mdg-run` and `mdg-view`: the ones that
//! change what a grammar compiles to (`--param`, `--preset`, `--std`).

use mdg_compiler::driver;
use mdg_compiler::expand::Options;
use std::path::PathBuf;

/// `--param NAME=VALUE…`, `--preset P…`, `--std DIR`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct CompileArgs {
    /// Override a `@param`: NAME=VALUE (repeatable).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Choose a preset (defines its name for `@ifdef`).
    #[arg(long = "preset")]
    pub presets: Vec<String>,
    /// Where `@import NAME` looks (default: $MDG_STD or the bundled std/).
    #[arg(long)]
    pub std: Option<PathBuf>,
}

impl CompileArgs {
    /// The preprocessor options these arguments ask for; an error names a malformed `--param`.
    pub fn options(&self) -> Result<Options, String> {
        let mut params = Vec::new();
        for p in &self.params {
            let (n, v) = p.split_once('=').ok_or_else(|| format!("--param {p}: expected NAME=VALUE"))?;
            params.push((n.to_string(), v.to_string()));
        }
        Ok(Options {
            defines: self.presets.clone(),
            params,
            std_dir: self.std.clone().or_else(driver::default_std_dir),
        })
    }
}
