//! `mdg-run` on a grammar with a `creature` section: evolves generations of
//! monsters and writes, per generation, one `.glb` per monster, a contact sheet
//! (PNG) and thumbnails, plus an `index.html` gallery with each monster's
//! structure; prints the diversity per generation.

use super::Common;
use crate::failure::{Exit, Failure};
use crate::pictures::Pictures;
use mdg_creature::error::UnknownMonster;
use mdg_creature::evolve::{lineage_name, structure_key, Evolution, EvolveOptions, Generation, Individual, Population};
use mdg_creature::geometry::{assemble, output_of, program_text, write_glb, Library};
use mdg_creature::sheet::compose;
use mdg_creature::table::{CreatureTable, RuleKind, MAX_GENERATIONS, MAX_POPULATION};
use mdg_export as export;
use mdg_vm::bundle::{Bundle, Section as _};
use mdg_vm::output::Mesh;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `mdg-run` for `creature` grammars.
#[derive(clap::Args, Debug, Default, Clone)]
pub struct CreatureArgs {
    /// Creature grammar: generations to evolve (default: the `evolve` block's).
    #[arg(long, value_name = "N")]
    pub generations: Option<u32>,
    /// Creature grammar: monsters presented per generation (default: the `evolve` block's).
    #[arg(long, value_name = "N")]
    pub population: Option<u32>,
    /// Creature grammar: continue evolution from these monsters (ids from the
    /// gallery, e.g. `g3-04,g3-11`, of one generation), read from the record
    /// (`run.json`) of the run that made them (see `--from`); that run's grammar
    /// and options must be this one's.
    #[arg(long, value_name = "ID,ID", value_delimiter = ',')]
    pub keep: Vec<String>,
    /// Creature grammar: the folder of the run `--keep` continues (its
    /// `run.json`; default: the folder a run without `-o` writes).
    #[arg(long, value_name = "DIR")]
    pub from: Option<PathBuf>,
    /// Creature grammar: pick the presented, background and next sets uniformly
    /// at random instead of by structure-based diversity control (paper Figs. 11–12).
    #[arg(long)]
    pub no_diversity_control: bool,
    /// Creature grammar: leave out the structure rules of these kinds
    /// (`increase`, `insert`, `replace`, `combine`), e.g. for an ablation.
    #[arg(long, value_name = "KIND,KIND", value_delimiter = ',')]
    pub without_rules: Vec<String>,
    /// Creature grammar: let a lineage (the regular creature a monster descends
    /// from) die out of the presented set; by default every lineage among the
    /// parents keeps a place there.
    #[arg(long)]
    pub no_lineages: bool,
    /// Creature grammar: present monsters that look like another one (alike
    /// silhouettes); by default the look-alikes are dropped before diversity control.
    #[arg(long)]
    pub allow_lookalikes: bool,
}

/// The evolution options from the table and the command line.
pub fn options(t: &CreatureTable, args: &CreatureArgs, seed: Option<u64>) -> Result<EvolveOptions, String> {
    let mut o = EvolveOptions::from_table(t);
    if let Some(s) = seed {
        o.seed = s;
    }
    if let Some(g) = args.generations {
        if g > MAX_GENERATIONS {
            return Err(format!("--generations {g}: at most {MAX_GENERATIONS}"));
        }
        o.generations = g;
    }
    if let Some(p) = args.population {
        if p == 0 || p > MAX_POPULATION {
            return Err(format!("--population {p}: expected 1 to {MAX_POPULATION}"));
        }
        // Offspring scale with the population unless the grammar fixed both.
        if t.evolve.offspring == t.evolve.population * 3 {
            o.offspring = p * 3;
        }
        o.population = p;
    }
    o.diversity_control = !args.no_diversity_control;
    o.lineages = !args.no_lineages;
    o.drop_lookalikes = !args.allow_lookalikes;
    for w in &args.without_rules {
        match RuleKind::NAMES.iter().find(|(n, _)| n == w) {
            Some((_, k)) => o.disabled.push(*k),
            None => return Err(format!("--without-rules {w}: expected increase, insert, replace or combine")),
        }
    }
    Ok(o)
}

/// The SHA-256 of the compiled grammar (the bundle's encoding), hex.
pub fn grammar_hash(bundle: &Bundle) -> String {
    use sha2::{Digest, Sha256};
    Sha256::digest(mdg_vm::bundle::encode(bundle)).iter().map(|b| format!("{b:02x}")).collect()
}

/// The options a continuation must share with the run it continues (all but
/// the number of generations).
fn options_record(o: &EvolveOptions) -> serde_json::Value {
    let mut disabled: Vec<&str> =
        o.disabled.iter().filter_map(|k| RuleKind::NAMES.iter().find(|(_, x)| x == k).map(|(n, _)| *n)).collect();
    disabled.sort_unstable();
    serde_json::json!({
        "seed": o.seed,
        "population": o.population,
        "background": o.background,
        "offspring": o.offspring,
        "steps": o.steps,
        "attempts": o.attempts,
        "maxparts": o.maxparts,
        "without_rules": disabled,
        "diversity_control": o.diversity_control,
        "stability": o.stability,
        "require_contact": o.require_contact,
        "lineages": o.lineages,
        "drop_lookalikes": o.drop_lookalikes,
    })
}

/// A monster in the record: id, structure (as in the gallery) and abstract shape.
fn monster_record(t: &CreatureTable, i: &Individual) -> serde_json::Value {
    serde_json::json!({
        "id": i.id,
        "structure": i.shape.describe(t),
        "vector": structure_key(t, &i.shape),
        "lineage": lineage_name(t, i.lineage),
        "shape": i.shape,
    })
}

/// `run.json`: what made the run (grammar hash, every option) and, per
/// generation, every presented and background monster's abstract shape.
fn record(
    t: &CreatureTable,
    file: &Path,
    hash: &str,
    opts: &EvolveOptions,
    gens: &[Generation],
    continued: serde_json::Value,
) -> serde_json::Value {
    let generations: Vec<serde_json::Value> = gens
        .iter()
        .map(|g| {
            serde_json::json!({
                "index": g.index,
                "presented": g.presented.iter().map(|i| monster_record(t, i)).collect::<Vec<_>>(),
                "background": g.background.iter().map(|i| monster_record(t, i)).collect::<Vec<_>>(),
            })
        })
        .collect();
    serde_json::json!({
        "grammar": { "file": file.display().to_string(), "sha256": hash },
        "options": options_record(opts),
        "generations_run": opts.generations,
        "continued_from": continued,
        "generations": generations,
    })
}

/// Reads the kept monsters from the record in `dir`: (their generation, the kept
/// monsters, the background set — the rest of that generation's presented set and
/// its background). Refuses a record of another grammar or other options.
fn read_record(
    evo: &Evolution,
    dir: &Path,
    keep: &[String],
    hash: &str,
) -> Result<(u32, Vec<Individual>, Vec<Individual>), String> {
    let path = dir.join("run.json");
    let text = std::fs::read_to_string(&path).map_err(|e| {
        format!("--keep needs the record of the run that made the monsters: cannot read {} ({e}); give --from DIR, that run's folder", path.display())
    })?;
    let rec: serde_json::Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    if rec["grammar"]["sha256"].as_str() != Some(hash) {
        return Err(format!(
            "{} records a run of another grammar (or another version of it): its monsters' ids mean other monsters here",
            path.display()
        ));
    }
    let mine = options_record(&evo.opts);
    let theirs = &rec["options"];
    let differ: Vec<String> = mine
        .as_object()
        .into_iter()
        .flatten()
        .filter(|(k, v)| theirs.get(k.as_str()) != Some(v))
        .map(|(k, v)| format!("{k} {v} here, {} there", theirs.get(k.as_str()).unwrap_or(&serde_json::Value::Null)))
        .collect();
    if !differ.is_empty() {
        return Err(format!("{} was made with other options: {}", path.display(), differ.join("; ")));
    }
    let mut upto = None;
    for id in keep {
        let g = id_generation(id).ok_or_else(|| format!("--keep {id}: expected a monster id like g3-07"))?;
        if upto.is_some_and(|u| u != g) {
            return Err(format!("--keep {}: monsters of one generation", keep.join(",")));
        }
        upto = Some(g);
    }
    let upto = upto.unwrap_or(0);
    let gens = rec["generations"].as_array().cloned().unwrap_or_default();
    let gen = gens
        .iter()
        .find(|g| g["index"].as_u64() == Some(upto as u64))
        .ok_or_else(|| format!("{} has no generation {upto}", path.display()))?;
    let revive = |m: &serde_json::Value| -> Result<Individual, String> {
        let id = m["id"].as_str().unwrap_or("?").to_string();
        let shape: mdg_creature::shape::Shape =
            serde_json::from_value(m["shape"].clone()).map_err(|e| format!("{}: monster {id}: {e}", path.display()))?;
        shape.check(evo.table).map_err(|e| format!("{}: monster {id}: {e}", path.display()))?;
        let name = m["lineage"].as_str().unwrap_or("");
        let lineage = evo.table.shapes.iter().position(|s| s.name == name).ok_or_else(|| {
            format!("{}: monster {id}: its lineage `{name}` is no regular creature of the grammar", path.display())
        })?;
        Ok(evo.revive(shape, id, lineage as u32))
    };
    let presented = gen["presented"].as_array().cloned().unwrap_or_default();
    let mut kept = Vec::new();
    for id in keep {
        let m = presented.iter().find(|m| m["id"].as_str() == Some(id)).ok_or_else(|| {
            let have: Vec<&str> = presented.iter().filter_map(|m| m["id"].as_str()).collect();
            format!("no monster `{id}` in generation {upto} (presented: {})", have.join(", "))
        })?;
        kept.push(revive(m)?);
    }
    let mut background = Vec::new();
    for m in gen["background"].as_array().into_iter().flatten().chain(&presented) {
        if !m["id"].as_str().is_some_and(|id| keep.iter().any(|k| k == id)) {
            background.push(revive(m)?);
        }
    }
    Ok((upto, kept, background))
}

/// The command that continues this run from the monsters ticked in the gallery
/// (`IDS` stands for them).
fn keep_command(file: &Path, out_dir: &Path, o: &EvolveOptions, args: &CreatureArgs) -> String {
    let quote = |s: String| if s.contains([' ', '\'', '"']) { format!("'{}'", s.replace('\'', "'\\''")) } else { s };
    let mut c = format!(
        "mdg-run {} --keep IDS --from {}",
        quote(file.display().to_string()),
        quote(out_dir.display().to_string())
    );
    c.push_str(&format!(" --seed {} --population {}", o.seed, o.population));
    if !args.without_rules.is_empty() {
        c.push_str(&format!(" --without-rules {}", args.without_rules.join(",")));
    }
    if !o.diversity_control {
        c.push_str(" --no-diversity-control");
    }
    if !o.lineages {
        c.push_str(" --no-lineages");
    }
    if !o.drop_lookalikes {
        c.push_str(" --allow-lookalikes");
    }
    c.push_str(&format!(" -o {}", quote(format!("{}-more", out_dir.display()))));
    c
}

/// Parses a monster id `gN-K` into its generation.
fn id_generation(id: &str) -> Option<u32> {
    let rest = id.strip_prefix('g').or_else(|| id.strip_prefix('b'))?;
    let (g, k) = rest.split_once('-')?;
    k.parse::<u32>().ok()?;
    g.parse().ok()
}

/// The bundle with its OBJ meshes embedded: as it is when they are, else (a
/// bundle lowered without [`mdg_compiler::ext::creature::embed_meshes`]) read from the
/// `.mdg` source through the compiler's file loader, with the same path rules.
fn with_meshes<'b>(
    bundle: &'b Bundle,
    file: &Path,
    opts: &mdg_compiler::expand::Options,
) -> Result<std::borrow::Cow<'b, Bundle>, String> {
    let Some(t) = CreatureTable::from_bundle(bundle).map_err(|e| e.to_string())? else {
        return Ok(std::borrow::Cow::Borrowed(bundle));
    };
    if t.meshes.iter().all(|m| !m.triangles.is_empty()) {
        return Ok(std::borrow::Cow::Borrowed(bundle));
    }
    if file.extension().is_none_or(|e| e != "mdg") {
        return Err(format!(
            "{}: the mesh parts' OBJ files are not embedded in this bundle; run the `.mdg` source",
            file.display()
        ));
    }
    // The command line's `--std`, `--param` and `--preset`, as the bundle was compiled.
    let loader = mdg_compiler::source::FsLoader;
    let a =
        mdg_compiler::driver::analyze(&loader, file, opts, mdg_compiler::check::CheckOptions { require_start: true });
    let mut b = bundle.clone();
    let d =
        mdg_compiler::ext::creature::embed_meshes(&mut b, &a.expanded, &a.sources, &loader, opts.std_dir.as_deref());
    if !d.is_empty() {
        return Err(mdg_compiler::diag::render_plain(&d, &a.sources).trim_end().to_string());
    }
    Ok(std::borrow::Cow::Owned(b))
}

/// Runs the mode; writes its files and reports what it wrote. A failure is the
/// command's to report ([`Failure`]).
pub fn run(bundle: &Bundle, args: &CreatureArgs, common: &Common) -> Result<(), Failure> {
    let bundle = with_meshes(bundle, common.file, common.compile).map_err(Failure::input)?;
    let bundle = bundle.as_ref();
    let Some(table) = &CreatureTable::from_bundle(bundle).map_err(|e| Failure::input(e.to_string()))? else {
        return Err(Failure::input("the grammar has no `creature` section"));
    };
    let opts = options(table, args, common.seed).map_err(Failure::usage)?;
    let out_dir = match common.output {
        Some(p) => p.to_path_buf(),
        None => default_dir(common.file),
    };
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| Failure::usage(format!("cannot create {}: {e}", out_dir.display())))?;
    let started = Instant::now();
    let (lib, warnings) = Library::build_with(bundle, table, &common.eval)?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    let lib_ms = started.elapsed().as_secs_f64() * 1000.0;
    let evo = Evolution::new(table, &lib, opts.clone());
    let (mut pop, g0) = evo.start();
    if opts.stability {
        for ind in g0.presented.iter().filter(|i| !i.shape.floats && !i.layout.stability.stable) {
            eprintln!(
                "mdg-run: warning: regular creature `{}` does not stand (stability margin {:.3}); its offspring must (a swimmer or a flier says `floats;`)",
                ind.name, ind.layout.stability.margin
            );
        }
    }
    let mut generations: Vec<Generation> = Vec::new();
    let mut note = String::new();
    let total_steps;
    let hash = grammar_hash(bundle);
    let mut continued = serde_json::Value::Null;
    if !args.keep.is_empty() {
        let from = args.from.clone().unwrap_or_else(|| default_dir(common.file));
        let (upto, kept, background) = read_record(&evo, &from, &args.keep, &hash).map_err(Failure::usage)?;
        pop = evo.resume(upto, kept, background);
        total_steps = opts.generations;
        let bar = progress_bar(total_steps as u64 * opts.offspring as u64);
        let tick = |_g: u32, _d: usize, _t: usize| bar.inc(1);
        note = format!("continued from {} (generation {upto} of the run in {})", args.keep.join(", "), from.display());
        continued = serde_json::json!({ "from": from.display().to_string(), "generation": upto, "keep": args.keep });
        eprintln!("continuing from {} (generation {upto} of {})", args.keep.join(", "), from.display());
        for _ in 0..opts.generations {
            let g = evo.step(&mut pop, Some(&tick));
            if let Some(why) = g.empty(&opts) {
                bar.finish_and_clear();
                return Err(Failure { exit: Exit::Extinct, message: why });
            }
            generations.push(g);
        }
        bar.finish_and_clear();
    } else {
        total_steps = opts.generations;
        let bar = progress_bar(total_steps as u64 * opts.offspring as u64);
        let tick = |_g: u32, _d: usize, _t: usize| bar.inc(1);
        generations.push(g0);
        for _ in 0..opts.generations {
            let g = evo.step(&mut pop, Some(&tick));
            if let Some(why) = g.empty(&opts) {
                bar.finish_and_clear();
                return Err(Failure { exit: Exit::Extinct, message: why });
            }
            generations.push(g);
        }
        bar.finish_and_clear();
    }
    let evolve_ms = started.elapsed().as_secs_f64() * 1000.0 - lib_ms;
    let made: usize = generations.iter().filter(|g| g.index > 0).map(|g| g.n_offspring).sum();
    for g in &generations {
        let d = &g.diversity;
        let o = &g.offspring_diversity;
        eprintln!(
            "generation {}: {} monsters; diversity HDM {:.2} ({} visibly different by silhouette, {} clusters, {} structures) of {} offspring, {:.2} ({} visibly different, {} clusters, {} structures) presented; mean C_s {:.1}, mean meta-parts {:.1}; {} unstable tries rejected, {} with a part touching nothing, {} look-alikes dropped",
            g.index,
            g.presented.len(),
            o.hdm,
            o.visible,
            o.clusters,
            o.structures,
            g.n_offspring,
            d.hdm,
            d.visible,
            d.clusters,
            d.structures,
            d.mean_complexity,
            d.mean_metas,
            g.n_unstable,
            g.n_detached,
            g.n_lookalikes
        );
        for note in &g.extinct {
            eprintln!("mdg-run: warning: {note}");
        }
    }
    if common.stats {
        eprintln!(
            "part library {lib_ms:.1} ms; evolution {evolve_ms:.1} ms for {made} offspring ({:.3} ms per offspring)",
            if made > 0 { evolve_ms / made as f64 } else { 0.0 },
        );
    }
    let _ = total_steps;
    let record = record(table, common.file, &hash, &opts, &generations, continued);
    let record_text = serde_json::to_string_pretty(&record).map_err(|e| Failure::usage(format!("run.json: {e}")))?;
    let keep_command = keep_command(common.file, &out_dir, &opts, args);
    let text = GalleryText { note: &note, keep_command: &keep_command };
    write_outputs(table, &lib, &generations, &out_dir, &text, &opts, common.pictures).map_err(Failure::usage)?;
    write(&out_dir.join("run.json"), format!("{record_text}\n").as_bytes()).map_err(Failure::usage)?;
    eprintln!("wrote {}", out_dir.join("index.html").display());
    // `--png`: the last generation's contact sheet (it used to be ignored here).
    if let (Some(png), Some(last)) = (common.png, generations.last()) {
        let sheet = out_dir.join(format!("gen{}", last.index)).join("sheet.png");
        let bytes =
            std::fs::read(&sheet).map_err(|e| Failure::usage(format!("cannot read {}: {e}", sheet.display())))?;
        write(png, &bytes).map_err(Failure::usage)?;
        eprintln!("wrote {} (the contact sheet of generation {})", png.display(), last.index);
    }
    Ok(())
}

fn progress_bar(len: u64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} offspring  {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

/// Background of every picture.
const BACKGROUND: [f32; 4] = [0.86, 0.88, 0.9, 1.0];

/// A monster's mesh, turned for a three-quarter view from the preview camera.
pub fn monster_mesh(lib: &Library, ind: &Individual, offset: glam::Vec3) -> Mesh {
    let mut mesh = Mesh::default();
    assemble(lib, &ind.layout.placed, offset, &mut mesh);
    mesh
}

/// Turns a mesh about z (pictures only: the exported models keep the creature
/// convention, facing −y).
fn turn(mesh: &mut Mesh, degrees: f32, pivot: glam::Vec3) {
    let r = glam::Mat3::from_rotation_z(degrees.to_radians());
    for p in &mut mesh.positions {
        *p = (pivot + r * (glam::Vec3::from(*p) - pivot)).to_array();
    }
    for n in &mut mesh.normals {
        *n = (r * glam::Vec3::from(*n)).to_array();
    }
}

/// A low hexagonal plinth under a monster (so a contact sheet reads as a lineup).
fn plinth(mesh: &mut Mesh, centre: glam::Vec3, radius: f32) {
    let color = [0.55, 0.57, 0.6, 1.0];
    let h = radius * 0.06;
    let ring: Vec<glam::Vec3> = (0..6)
        .map(|i| {
            let a = i as f32 * std::f32::consts::TAU / 6.0;
            centre + glam::Vec3::new(radius * a.cos(), radius * a.sin(), 0.0)
        })
        .collect();
    let top = centre - glam::Vec3::Z * 0.002;
    let up = glam::Vec3::Z;
    let c = mesh.push_vertex(top, up, color, [0.0; 4], 0);
    for i in 0..6 {
        let (a, b) = (ring[i] - up * 0.002, ring[(i + 1) % 6] - up * 0.002);
        let ia = mesh.push_vertex(a, up, color, [0.0; 4], 0);
        let ib = mesh.push_vertex(b, up, color, [0.0; 4], 0);
        mesh.push_triangle([c, ia, ib], false);
        let side = ((a + b) * 0.5 - centre).normalize_or_zero();
        let v = [a, b, b - up * h, a - up * h].map(|p| mesh.push_vertex(p, side, color, [0.0; 4], 0));
        mesh.push_triangle([v[0], v[3], v[2]], false);
        mesh.push_triangle([v[0], v[2], v[1]], false);
    }
}

/// How a monster is turned about z for its pictures: a three-quarter view, the
/// face and a flank both visible.
const PICTURE_TURN_DEG: f32 = -15.0;
/// Size of a monster's picture (thumbnail and contact-sheet tile), pixels.
const TILE: u32 = 320;
/// Columns of a contact sheet.
const SHEET_COLUMNS: usize = 6;

/// A monster's picture: turned for a three-quarter view, on a plinth, rendered
/// by `pictures` at `size`.
pub fn picture(pictures: &dyn Pictures, lib: &Library, ind: &Individual, size: (u32, u32)) -> Result<Vec<u8>, String> {
    let mut mesh = monster_mesh(lib, ind, glam::Vec3::ZERO);
    turn(&mut mesh, PICTURE_TURN_DEG, glam::Vec3::ZERO);
    let s = ind.layout.max - ind.layout.min;
    plinth(&mut mesh, glam::Vec3::ZERO, s.x.max(s.y).max(0.3) * 0.55);
    pictures.render(None, &output_of(mesh, BACKGROUND), size)
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), String> {
    export::write_atomic(path, bytes).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The gallery's texts about the run: where it was continued from, and the
/// command that continues it (`IDS` for the ticked monsters).
struct GalleryText<'a> {
    note: &'a str,
    keep_command: &'a str,
}

fn write_outputs(
    t: &CreatureTable,
    lib: &Library,
    gens: &[Generation],
    out_dir: &Path,
    text: &GalleryText,
    opts: &EvolveOptions,
    pictures: &dyn Pictures,
) -> Result<(), String> {
    let (note, keep_command) = (text.note, text.keep_command);
    let mut html = String::new();
    let title = if t.name.is_empty() { "creatures".to_string() } else { t.name.clone() };
    let _ = write!(
        html,
        "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>{} — monsters</title>\n<style>\
body{{font-family:sans-serif;margin:1.5em;background:#f4f5f7;color:#222}}\
.sheet{{max-width:100%;border:1px solid #ccc}}\
.grid{{display:flex;flex-wrap:wrap;gap:10px}}\
.m{{background:#fff;border:1px solid #ddd;padding:6px;width:320px;font-size:11px}}\
.m img{{width:320px;height:320px}}\
.m code{{word-break:break-all;font-size:10px;color:#444}}\
table.d td,table.d th{{padding:2px 10px;text-align:right}}\
</style></head><body>\n<h1>{}</h1>\n<p>Seed {}, population {}, {} offspring per generation, {} derivation steps each.{}</p>\n",
        html_escape(&title),
        html_escape(&title),
        opts.seed,
        opts.population,
        opts.offspring,
        opts.steps,
        if note.is_empty() { String::new() } else { format!(" {}.", html_escape(note)) }
    );
    html.push_str(
        "<table class=\"d\"><tr><th>generation</th><th>offspring</th><th>HDM of offspring</th><th>structures</th><th>monsters</th><th>HDM presented</th><th>mean C<sub>s</sub></th><th>mean meta-parts</th><th>unstable tries</th></tr>\n",
    );
    for g in gens {
        let d = &g.diversity;
        let _ = writeln!(
            html,
            "<tr><td><a href=\"#gen{}\">{}</a></td><td>{}</td><td>{:.2}</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{:.1}</td><td>{:.1}</td><td>{}</td></tr>",
            g.index,
            g.index,
            g.n_offspring,
            g.offspring_diversity.hdm,
            g.offspring_diversity.clusters,
            g.presented.len(),
            d.hdm,
            d.mean_complexity,
            d.mean_metas,
            g.n_unstable
        );
    }
    html.push_str("</table>\n<p>HDM = N + Σ D<sub>i</sub>: N structure clusters (equal structure vectors), D<sub>i</sub> the spread of the geometric descriptor in cluster i over the largest spread (see docs/creatures.md).</p>\n");
    let _ = writeln!(
        html,
        "<p>Tick the monsters to keep; this command continues the run from them (the run's record is <a href=\"run.json\">run.json</a>):</p>\n<pre id=\"keep\" data-command=\"{}\"></pre>\n<script>\nfunction keepCommand() {{\n  const ids = [...document.querySelectorAll('input.keep:checked')].map(e => e.value);\n  const pre = document.getElementById('keep');\n  pre.textContent = ids.length ? pre.dataset.command.replace('IDS', ids.join(',')) : '(tick the monsters of one generation to keep)';\n}}\ndocument.addEventListener('change', keepCommand);\ndocument.addEventListener('DOMContentLoaded', keepCommand);\n</script>",
        html_escape(keep_command)
    );
    for g in gens {
        let dir_name = format!("gen{}", g.index);
        let dir = out_dir.join(&dir_name);
        std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let _ = writeln!(
            html,
            "<h2 id=\"gen{0}\">Generation {0}</h2>\n<p>{1} monsters, HDM {2:.2} ({3} visibly different). Lineages: {4}.{5}</p>\n<img class=\"sheet\" src=\"{6}/sheet.png\">\n<div class=\"grid\">",
            g.index,
            g.presented.len(),
            g.diversity.hdm,
            g.diversity.visible,
            html_escape(&g.lineages.iter().map(|(k, v)| format!("{k} {v}")).collect::<Vec<_>>().join(", ")),
            g.extinct.iter().map(|n| format!(" <b>{}.</b>", html_escape(n))).collect::<String>(),
            dir_name
        );
        let mut tiles = Vec::new();
        for ind in &g.presented {
            let bytes = write_glb(t, lib, &ind.id, &ind.shape, &ind.layout.placed).map_err(|e| e.to_string())?;
            write(&dir.join(format!("{}.glb", ind.id)), &bytes)?;
            let thumb = picture(pictures, lib, ind, (TILE, TILE))?;
            write(&dir.join(format!("{}.png", ind.id)), &thumb)?;
            tiles.push((thumb, ind.id.clone()));
            let origin = if ind.name.is_empty() {
                format!(
                    "base {} + assist {}, lineage {}",
                    ind.parents.0,
                    ind.parents.1,
                    mdg_creature::evolve::lineage_name(t, ind.lineage)
                )
            } else {
                format!("regular creature `{}`", ind.name)
            };
            let rules: Vec<String> = ind
                .applied
                .iter()
                .map(|a| if a.function { a.rule.clone() } else { format!("{} (identity)", a.rule) })
                .collect();
            let s = &ind.layout.stability;
            let _ = writeln!(
                html,
                "<div class=\"m\"><a href=\"{dir}/{id}.glb\"><img src=\"{dir}/{id}.png\" alt=\"{id}\"></a><br><label><input type=\"checkbox\" class=\"keep\" value=\"{id}\"> <b>{id}</b></label> — {origin}<br>rules: {rules}<br>C<sub>s</sub> = {cs:.2}, {n} meta-parts, stability margin {margin:.3}<br>structure: <code>{structure}</code><br>vector: <code>{vector}</code><br>geometry rules: <code>{program}</code></div>",
                dir = dir_name,
                id = html_escape(&ind.id),
                origin = html_escape(&origin),
                rules = if rules.is_empty() { "—".into() } else { html_escape(&rules.join(", ")) },
                cs = ind.complexity,
                n = ind.shape.n_metas(),
                margin = s.margin,
                structure = html_escape(&ind.shape.describe(t)),
                vector = html_escape(&structure_key(t, &ind.shape)),
                program = html_escape(&program_text(t, &ind.layout.program)),
            );
        }
        html.push_str("</div>\n");
        if !tiles.is_empty() {
            let bg = BACKGROUND.map(|c| (c * 255.0).round() as u8);
            let sheet = compose(&tiles, SHEET_COLUMNS, [bg[0], bg[1], bg[2]]).map_err(|e| e.to_string())?;
            write(&dir.join("sheet.png"), &sheet)?;
        }
    }
    html.push_str("</body></html>\n");
    write(&out_dir.join("index.html"), html.as_bytes())
}

/// Where `mdg-run` puts a run's files by default: a folder in the current directory, named after the grammar.
pub fn default_dir(file: &Path) -> PathBuf {
    PathBuf::from(file.file_stem().unwrap_or(std::ffi::OsStr::new("monsters")))
}

/// Evolves `generations` generations from the table's regular creatures (the
/// library function behind the mode, for tests and scripts): every generation,
/// generation 0 first.
pub fn evolve(t: &CreatureTable, lib: &Library, opts: &EvolveOptions) -> Vec<Generation> {
    let evo = Evolution::new(t, lib, opts.clone());
    let (mut pop, g0) = evo.start();
    let mut out = vec![g0];
    for _ in 0..opts.generations {
        out.push(evo.step(&mut pop, None));
    }
    out
}

/// Continues a population from kept monsters for `more` generations.
pub fn continue_from(
    evo: &Evolution,
    pop: &mut Population,
    keep: &[String],
    more: u32,
) -> Result<Vec<Generation>, UnknownMonster> {
    evo.keep(pop, keep)?;
    Ok((0..more).map(|_| evo.step(pop, None)).collect())
}
