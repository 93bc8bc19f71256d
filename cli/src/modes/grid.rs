//! `mdg-run` on a grammar with a `grid` section: generate a building and write it as
//! voxels (`.vox`, `.schem`, `.nbt`, `.txt`) or as a greedy-meshed model (`.glb`,
//! `.obj`, `.stl`, `.ply`, `.json`; one colour per block kind), by the output's
//! extension (default: `FILE.vox` beside the grammar).
//!
//! The program's MDG start rule is evaluated too: what it draws (a ground plate, a
//! site) is added under the building in mesh outputs and pictures, one unit a block,
//! MDG's z-up turned to the buildings' y-up. `--png` shows the example buildings (rebuilt
//! from the shapes' `at` positions) beside the generated one.

use super::Common;
use crate::failure::Failure;
use mdg_export::{self as export, Format};
use mdg_grid::build;
use mdg_grid::format::{self as voxfmt, VoxelFormat};
use mdg_grid::generate::{self, GenerateOptions};
use mdg_grid::{mesh, GridGrammar};
use mdg_vm::bundle::{Bundle, Section as _};
use mdg_vm::output::{Mesh, Output};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `mdg-run` for `grid` grammars.
#[derive(clap::Args, Debug, Default)]
pub struct GridArgs {
    /// Grid grammars: rule applications (default: the grammar's `generate { steps }`, else 50).
    #[arg(long, value_name = "N")]
    pub steps: Option<u32>,
    /// Grid grammars: apply the enclosure constraint (the default unless the grammar says `enclosure off`).
    #[arg(long, conflicts_with = "no_enclosure")]
    pub enclosure: bool,
    /// Grid grammars: skip the enclosure constraint.
    #[arg(long)]
    pub no_enclosure: bool,
    /// Grid grammars: openings up to 2·R blocks wide do not let the outside in (default: the grammar's
    /// `seal`, else 1; 0 = the paper's plain flood fill).
    #[arg(long, value_name = "R")]
    pub seal: Option<u32>,
    /// Grid grammars: the largest box the building may fill: `auto` (2 × the examples' extents, x and z
    /// alike), `none`, `N` (N × N × N; the paper's reference used 25) or `X,Y,Z`.
    #[arg(long, value_name = "auto|none|N|X,Y,Z")]
    pub bounds: Option<String>,
    /// Grid grammars: keep every piece after the enclosure constraint (default: only the largest piece
    /// standing on the ground, so nothing floats).
    #[arg(long)]
    pub keep_all: bool,
    /// Grid grammars: start from a shape drawn at random (as the paper's reference implementation does)
    /// instead of the grammar's `start`.
    #[arg(long)]
    pub random_start: bool,
    /// Grid grammars: the adjacency constraint (the paper's alternative to enclosure): a rule applies only
    /// where every block it adds stands beside blocks it stands beside in an example or a shape.
    #[arg(long)]
    pub adjacency: bool,
    /// Grid grammars: derivations tried per seed; the first complete one is kept (enclosed where the
    /// example is, one piece, ≥ 80 % of the example's blocks, all its block kinds), else the most
    /// complete, with a warning; a complete one lacking kinds gets them added where the rules allow
    /// (default 16; 1: the first derivation as it comes).
    #[arg(long, value_name = "N")]
    pub attempts: Option<u32>,
    /// Grid grammars: `--png` also draws N more buildings, generated from the seeds after `--seed`.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub more: u32,
}

/// Reads `--bounds`.
pub fn parse_bounds(s: &str) -> Option<generate::Bounds> {
    let n = |t: &str| t.trim().parse::<u32>().ok().filter(|&v| v >= 1);
    match s.trim() {
        "auto" => Some(generate::Bounds::Examples(generate::BOUNDS_FACTOR)),
        "none" => Some(generate::Bounds::None),
        t => {
            let parts: Vec<&str> = t.split(',').collect();
            match parts[..] {
                [a] => n(a).map(|v| generate::Bounds::Box([v; 3])),
                [x, y, z] => Some(generate::Bounds::Box([n(x)?, n(y)?, n(z)?])),
                _ => None,
            }
        }
    }
}

/// Where the output goes and in which form.
enum Target {
    Voxels(VoxelFormat),
    Mesh(Format),
}

fn target(path: &Path) -> Option<Target> {
    let ext = path.extension()?.to_str()?;
    if let Some(v) = VoxelFormat::from_extension(ext) {
        return Some(Target::Voxels(v));
    }
    Format::from_extension(ext).map(Target::Mesh)
}

/// What the MDG start rule draws, turned y-up (x, y, z) → (x, z, −y), evaluated
/// with the command line's limits (their warnings are printed).
fn site(bundle: &Bundle, seed: u64, eval: &mdg_vm::eval::EvalOptions) -> Mesh {
    let opts = mdg_vm::eval::EvalOptions { seed: Some(seed), ..eval.clone() };
    let out = mdg_vm::eval::evaluate(bundle, &opts);
    for w in &out.stats.warnings {
        eprintln!("warning: the site (start rule): {w}");
    }
    let mut m = out.flattened();
    let turn = |p: [f32; 3]| [p[0], p[2], -p[1]];
    m.positions.iter_mut().for_each(|p| *p = turn(*p));
    m.normals.iter_mut().for_each(|n| *n = turn(*n));
    m
}

/// Runs the mode; writes its files and reports what it wrote. A failure is the
/// command's to report ([`Failure`]).
pub fn run(bundle: &Bundle, args: &GridArgs, common: &Common) -> Result<(), Failure> {
    let Some(g) = &GridGrammar::from_bundle(bundle).map_err(|e| Failure::input(e.to_string()))? else {
        return Err(Failure::input("the grammar has no `grid` section"));
    };
    let steps = args.steps.unwrap_or(g.generate.steps);
    if steps > mdg_grid::MAX_STEPS {
        return Err(Failure::usage(format!("--steps {steps}: at most {}", mdg_grid::MAX_STEPS)));
    }
    let enclosure = if args.no_enclosure { false } else { args.enclosure || g.generate.enclosure };
    let seed = common.seed.or(g.generate.seed).unwrap_or(0);
    let output: PathBuf = common.output.map(Path::to_path_buf).unwrap_or_else(|| common.file.with_extension("vox"));
    let Some(target) = target(&output) else {
        return Err(Failure::usage(format!(
            "{}: unknown output format (voxels: .vox .schem .nbt .txt; meshes: .glb .obj .stl .ply .json)",
            output.display()
        )));
    };
    let started = Instant::now();
    let seal = args.seal.unwrap_or(g.generate.seal);
    if seal > generate::MAX_SEAL {
        return Err(Failure::usage(format!("--seal {seal}: at most {}", generate::MAX_SEAL)));
    }
    let bounds = match args.bounds.as_deref() {
        None => GenerateOptions::default().bounds,
        Some(b) => parse_bounds(b)
            .ok_or_else(|| Failure::usage(format!("--bounds {b}: expected auto, none, N or X,Y,Z (each ≥ 1)")))?,
    };
    let opts = GenerateOptions {
        steps,
        enclosure,
        seed,
        seal,
        bounds,
        keep_largest: !args.keep_all,
        random_start: args.random_start,
        adjacency: args.adjacency,
        attempts: args.attempts.unwrap_or(generate::DEFAULT_ATTEMPTS),
    };
    if opts.attempts == 0 || opts.attempts > generate::MAX_ATTEMPTS {
        return Err(Failure::usage(format!("--attempts {}: expected 1 to {}", opts.attempts, generate::MAX_ATTEMPTS)));
    }
    let made = build::generate(g, &opts)?;
    let elapsed = started.elapsed().as_secs_f64();
    if let Some(n) = &made.note {
        eprintln!("warning: {n}");
    }
    if made.model.blocks.is_empty() {
        eprintln!("warning: the generated building is empty (the enclosure constraint removed every shape; try another --seed or --no-enclosure)");
    }
    let site_mesh = match (&target, common.png) {
        (Target::Voxels(_), None) => Mesh::default(),
        _ => site(bundle, seed, &common.eval),
    };
    let bytes = match target {
        Target::Voxels(f) => {
            for n in voxfmt::write_notes(f, &made.model) {
                eprintln!("warning: {}: {n}", output.display());
            }
            voxfmt::write(f, &made.model)
                .map_err(|e| Failure::input(format!("cannot write {}: {e}", output.display())))?
        }
        Target::Mesh(f) => {
            let mut out = Output { background: [1.0; 4], ..Output::default() };
            out.mesh = mesh::mesh(&made.model, [0.0; 3]);
            out.mesh.append(&site_mesh);
            // Exporters take MDG's z-up space (glTF/OBJ turn it y up, STL/PLY keep it).
            let mut b = Vec::new();
            export::write(f, &mesh::z_up(&out), &mut b).map_err(|e| Failure::input(format!("cannot export: {e}")))?;
            b
        }
    };
    export::write_atomic(&output, &bytes)
        .map_err(|e| Failure::usage(format!("cannot write {}: {e}", output.display())))?;
    if let Some(png) = common.png {
        let examples = generate::examples(g);
        let mut models: Vec<&mdg_grid::voxel::VoxelModel> = examples.iter().filter(|m| !m.blocks.is_empty()).collect();
        let first = models.len();
        models.push(&made.model);
        if args.more > 16 {
            return Err(Failure::usage(format!("--more {}: at most 16", args.more)));
        }
        let more: Vec<mdg_grid::voxel::VoxelModel> = (1..=args.more as u64)
            .map(|i| build::generate(g, &GenerateOptions { seed: seed.wrapping_add(i), ..opts }).map(|m| m.model))
            .collect::<Result<_, _>>()?;
        models.extend(more.iter().filter(|m| !m.blocks.is_empty()));
        let mut out = mesh::output_side_by_side(&models, 4);
        if let (Some((lo, _)), false) = (made.model.bounds(), site_mesh.positions.is_empty()) {
            // The generated building follows the examples; move the site with it.
            let shift = generated_shift(&models[..=first], lo);
            let mut s = site_mesh.clone();
            s.positions.iter_mut().for_each(|p| *p = [p[0] + shift[0], p[1] + shift[1], p[2] + shift[2]]);
            out.mesh.append(&s);
        }
        let pic = common.pictures.render(None, &mesh::z_up(&out), common.size).map_err(Failure::input)?;
        export::write_atomic(png, &pic).map_err(|e| Failure::usage(format!("cannot write {}: {e}", png.display())))?;
        eprintln!("wrote {}", png.display());
    }
    if common.stats {
        let examples: std::collections::BTreeSet<u32> =
            made.instances.iter().filter_map(|i| g.shapes.get(i.shape as usize)).map(|s| s.example).collect();
        eprintln!(
            "steps {} of {steps}  instances {} (from {} of {} examples)  blocks {}  removed by enclosure {} ({} rounds)  seed {seed}  time {:.1} ms",
            made.applied,
            made.instances.len(),
            examples.len(),
            g.examples.len().max(1),
            made.model.blocks.len(),
            made.removed,
            made.enclosure_rounds,
            elapsed * 1e3
        );
    }
    eprintln!("wrote {}", output.display());
    Ok(())
}

/// The offset [`mesh::output_side_by_side`] gives the last model (whose min corner is `lo`).
fn generated_shift(models: &[&mdg_grid::voxel::VoxelModel], lo: [i32; 3]) -> [f32; 3] {
    let mut x = 0;
    for m in &models[..models.len().saturating_sub(1)] {
        if let Some((a, b)) = m.bounds() {
            x += b[0] - a[0] + 1 + 4;
        }
    }
    [(x - lo[0]) as f32, -lo[1] as f32, -lo[2] as f32]
}
