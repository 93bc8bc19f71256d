//! The set-up that the guided-search benchmark (`benches/sosmc.rs`) and the
//! evaluation (`examples/sosmc_eval.rs`) share: the compiled std tree grammar,
//! `std/examples/guided_tree.mdg`. The VM does not depend on the compiler, so the
//! grammar is compiled with `mdgc build`: from `$MDG_SOSMC_BUNDLE` if set (relative to
//! the workspace root), else built into `target/sosmc/guided_tree.mdgb` with
//! `cargo run --release -p mdg-cli --bin mdgc`.

use mdg_vm::bundle::Bundle;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The workspace root.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The compiled std tree grammar (see the module docs).
pub fn bundle() -> Result<Bundle, String> {
    let path = match std::env::var_os("MDG_SOSMC_BUNDLE") {
        // A relative path is taken from the workspace root (cargo runs benches in guided/).
        Some(p) => root().join(p),
        None => {
            let out = root().join("target/sosmc/guided_tree.mdgb");
            std::fs::create_dir_all(root().join("target/sosmc")).map_err(|e| e.to_string())?;
            let status = Command::new(env!("CARGO"))
                .current_dir(root())
                .args(["run", "--release", "-q", "-p", "mdg-cli", "--bin", "mdgc", "--", "build"])
                .arg("std/examples/guided_tree.mdg")
                .arg("-o")
                .arg(&out)
                .status()
                .map_err(|e| format!("cannot run cargo: {e}"))?;
            if !status.success() {
                return Err("mdgc build std/examples/guided_tree.mdg failed".into());
            }
            out
        }
    };
    let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    mdg_vm::bundle::load(&bytes).map_err(|e| format!("{}: {e}", path.display()))
}
