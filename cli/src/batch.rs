//! Batch runs: many seeds of one grammar, split across machines by the scheduler
//! the user already has (GNU parallel, Slurm job arrays, Kubernetes Indexed Jobs;
//! recipes in docs/batch.md).
//!
//! `--seeds A..B` (or `A..=B`) runs each seed in the range in order; `-o` is a
//! template holding `{seed}`. `--shard K/N` keeps the seeds whose position in the
//! range is K modulo N, so N shards together make exactly the unsharded run. Each
//! output is written atomically, so a file that exists is complete: a run that was
//! killed resumes by skipping the seeds whose output and manifest line are both
//! there. The manifest is one JSON line per output (`seed`, `file`, `vertices`,
//! `triangles`, `bytes`, `sha256`), `manifest.jsonl` (or
//! `manifest-K-of-N.jsonl` for a shard) in the template's fixed directory.

use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// A range of seeds, `start..end` (end excluded).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Seeds {
    pub start: u64,
    pub end: u64,
}

/// The most seeds one batch run takes.
pub const MAX_SEEDS: u64 = 100_000_000;

impl std::str::FromStr for Seeds {
    type Err = String;
    /// `A..B` (B excluded) or `A..=B` (B included).
    fn from_str(s: &str) -> Result<Seeds, String> {
        let bad = || format!("--seeds {s}: expected A..B (B excluded) or A..=B, whole numbers with A < B");
        let (a, b, inclusive) = match s.split_once("..=") {
            Some((a, b)) => (a, b, true),
            None => {
                let (a, b) = s.split_once("..").ok_or_else(bad)?;
                (a, b, false)
            }
        };
        let start: u64 = a.trim().parse().map_err(|_| bad())?;
        let last: u64 = b.trim().parse().map_err(|_| bad())?;
        let end = if inclusive { last.checked_add(1).ok_or_else(bad)? } else { last };
        if end <= start {
            return Err(bad());
        }
        if end - start > MAX_SEEDS {
            return Err(format!("--seeds {s}: at most {MAX_SEEDS} seeds in one run (split it with --shard)"));
        }
        Ok(Seeds { start, end })
    }
}

/// Shard `index` of `count` (0-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

impl Default for Shard {
    fn default() -> Shard {
        Shard { index: 0, count: 1 }
    }
}

impl std::str::FromStr for Shard {
    type Err = String;
    /// `K/N` with 0 ≤ K < N.
    fn from_str(s: &str) -> Result<Shard, String> {
        let bad =
            || format!("--shard {s}: expected K/N with 0 ≤ K < N (K counts from 0, as JOB_COMPLETION_INDEX does)");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let index: u64 = k.trim().parse().map_err(|_| bad())?;
        let count: u64 = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index >= count || count > 1_000_000 {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// The seeds this shard runs, in order.
pub fn shard_seeds(seeds: Seeds, shard: Shard) -> impl Iterator<Item = u64> {
    (seeds.start..seeds.end).filter(move |s| (s - seeds.start) % shard.count == shard.index)
}

/// `template` with `{seed}` replaced; an error when it holds no `{seed}` (every seed
/// would overwrite the last).
pub fn output_for(template: &Path, seed: u64) -> Result<PathBuf, String> {
    let t = template.to_string_lossy();
    if !t.contains("{seed}") {
        return Err(format!(
            "-o {t}: a batch run (--seeds) needs `{{seed}}` in the output path, e.g. -o 'out/{{seed}}.glb'"
        ));
    }
    Ok(PathBuf::from(t.replace("{seed}", &seed.to_string())))
}

/// Where the manifest goes: the template's directory up to its first component
/// holding `{seed}`.
pub fn manifest_path(template: &Path, shard: Shard) -> PathBuf {
    let mut dir = PathBuf::new();
    let parent = template.parent().unwrap_or(Path::new(""));
    for c in parent.components() {
        if c.as_os_str().to_string_lossy().contains("{seed}") {
            break;
        }
        dir.push(c);
    }
    let name = if shard.count == 1 {
        "manifest.jsonl".to_string()
    } else {
        format!("manifest-{}-of-{}.jsonl", shard.index, shard.count)
    };
    dir.join(name)
}

/// One manifest line.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    pub seed: u64,
    pub file: PathBuf,
    /// Vertices and triangles of a mesh output; `None` for voxel outputs.
    pub counts: Option<(u64, u64)>,
}

impl Entry {
    /// The JSON line for this entry, hashing the file as written.
    pub fn line(&self) -> Result<String, String> {
        let bytes = std::fs::read(&self.file).map_err(|e| format!("cannot read {}: {e}", self.file.display()))?;
        let hash = Sha256::digest(&bytes);
        let hex: String = hash.iter().map(|b| format!("{b:02x}")).collect();
        let (v, t) = match self.counts {
            Some((v, t)) => (serde_json::json!(v), serde_json::json!(t)),
            None => (serde_json::Value::Null, serde_json::Value::Null),
        };
        let obj = serde_json::json!({
            "seed": self.seed,
            "file": self.file.to_string_lossy(),
            "vertices": v,
            "triangles": t,
            "bytes": bytes.len(),
            "sha256": hex,
        });
        Ok(obj.to_string())
    }
}

/// The manifest of a run in progress: the seeds it records, and appending.
pub struct Manifest {
    path: PathBuf,
    done: BTreeMap<u64, String>,
}

impl Manifest {
    /// Opens (or starts) the manifest at `path`. A last line cut short by a kill is
    /// dropped (the file is rewritten without it).
    pub fn open(path: &Path) -> Result<Manifest, String> {
        let mut done = BTreeMap::new();
        if let Ok(text) = std::fs::read_to_string(path) {
            let mut kept = String::new();
            let mut torn = false;
            for line in text.split_inclusive('\n') {
                let parsed =
                    line.ends_with('\n').then(|| serde_json::from_str::<serde_json::Value>(line).ok()).flatten();
                match parsed.as_ref().and_then(|v| v["seed"].as_u64()) {
                    Some(seed) => {
                        done.insert(seed, line.trim_end().to_string());
                        kept.push_str(line);
                    }
                    None => torn = true,
                }
            }
            if torn {
                mdg_vm::export::write_atomic(path, kept.as_bytes())
                    .map_err(|e| format!("cannot rewrite {}: {e}", path.display()))?;
            }
        }
        Ok(Manifest { path: path.to_path_buf(), done })
    }

    /// Whether `seed` is finished: recorded here and its output on disk.
    pub fn is_done(&self, seed: u64, output: &Path) -> bool {
        self.done.contains_key(&seed) && output.is_file()
    }

    /// Appends the line of a finished output.
    pub fn record(&mut self, entry: &Entry) -> Result<(), String> {
        let line = entry.line()?;
        if let Some(dir) = self.path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        }
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&self.path)
            .map_err(|e| format!("cannot open {}: {e}", self.path.display()))?;
        f.write_all(format!("{line}\n").as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", self.path.display()))?;
        self.done.insert(entry.seed, line);
        Ok(())
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_and_shards_parse() {
        assert_eq!("3..7".parse::<Seeds>(), Ok(Seeds { start: 3, end: 7 }));
        assert_eq!("3..=7".parse::<Seeds>(), Ok(Seeds { start: 3, end: 8 }));
        for bad in ["7..3", "3..3", "a..b", "5", "-1..4", "0..200000000"] {
            assert!(bad.parse::<Seeds>().is_err(), "{bad}");
        }
        assert_eq!("2/5".parse::<Shard>(), Ok(Shard { index: 2, count: 5 }));
        for bad in ["5/5", "1/0", "x/2", "3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    #[test]
    fn shards_partition_the_range() {
        let seeds = Seeds { start: 10, end: 33 };
        let mut all: Vec<u64> = (0..4).flat_map(|k| shard_seeds(seeds, Shard { index: k, count: 4 })).collect();
        all.sort();
        assert_eq!(all, (10..33).collect::<Vec<_>>());
    }

    #[test]
    fn templates_need_a_seed_and_the_manifest_sits_above_it() {
        assert_eq!(output_for(Path::new("out/{seed}.glb"), 7), Ok(PathBuf::from("out/7.glb")));
        assert!(output_for(Path::new("out/a.glb"), 7).is_err());
        assert_eq!(manifest_path(Path::new("out/{seed}.glb"), Shard::default()), PathBuf::from("out/manifest.jsonl"));
        assert_eq!(
            manifest_path(Path::new("runs/x/{seed}/m.glb"), Shard { index: 1, count: 3 }),
            PathBuf::from("runs/x/manifest-1-of-3.jsonl")
        );
    }
}
