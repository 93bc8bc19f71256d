//! The set-up that the creature benchmark (`benches/creature.rs`) and the
//! evaluation (`examples/creature_eval.rs`) share: the compiled monsters grammar,
//! its creature table and its part library. The VM does not depend on the
//! compiler, so the grammar is compiled by `mdgc` first (`cargo run --release --bin
//! mdgc -- build std/examples/monsters.mdg`, into `target/monsters.mdgb`) unless
//! `MDG_CREATURE_BUNDLE` names a compiled `.mdgb`.

use mdg_creature::geometry::Library;
use mdg_creature::CreatureTable;
use mdg_vm::bundle::{Bundle, Section as _};
use std::path::{Path, PathBuf};

/// The compiled grammar's path: `$MDG_CREATURE_BUNDLE`, else the monsters grammar
/// built by `mdgc`.
fn bundle_path() -> Result<PathBuf, String> {
    if let Some(p) = std::env::var_os("MDG_CREATURE_BUNDLE") {
        return Ok(PathBuf::from(p));
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = root.join("target/monsters.mdgb");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = std::process::Command::new(cargo)
        .current_dir(&root)
        .args(["run", "-q", "--release", "--bin", "mdgc", "--", "build", "std/examples/monsters.mdg", "-o"])
        .arg(&out)
        .status()
        .map_err(|e| format!("cannot run mdgc: {e}"))?;
    if !status.success() {
        return Err("mdgc could not build std/examples/monsters.mdg".into());
    }
    Ok(out)
}

/// The compiled grammar and where it was read from.
pub fn load() -> Result<(PathBuf, Bundle), String> {
    let path = bundle_path()?;
    let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let bundle = mdg_vm::bundle::load(&bytes).map_err(|e| e.to_string())?;
    Ok((path, bundle))
}

/// The grammar's creature table and its part library (default limits).
pub fn library(bundle: &Bundle) -> Result<(CreatureTable, Library), String> {
    let table = CreatureTable::from_bundle(bundle).map_err(|e| e.to_string())?.ok_or("no creature table")?;
    let lib = Library::build(bundle, &table).map_err(|e| e.to_string())?;
    Ok((table, lib))
}
