//! Real clients we did not write open every std example's files: Blender (PyPI
//! `bpy`, headless), three.js's `GLTFLoader` under Node, and assimp (`assimp info`).
//!
//! For each example `mdg-run` writes `.glb` (with `--stats` and a `--png` picture).
//! What MDG itself holds at t = 0 (the pose a client shows) gives the expected
//! counts and bounding box: evaluated here through the library, every instance
//! expanded, or, for the grid and guided modes (which `mdg-run` runs its own way),
//! read back from `mdg-run --time 0 -o X.ply` (z up, MDG's axes, flattened).
//! Examples of at most [`FLAT_LIMIT`] expanded vertices are also written as `.ply`,
//! `.obj`, `.stl` for assimp (the biggest expand to gigabytes). Then, with one
//! Blender process and one Node process for all files:
//!
//! * Blender and three.js import every `.glb` without an error;
//! * the model is upright: Blender's bounding box (z up) equals MDG's, three.js's
//!   (y up) equals MDG's turned (x, y, z) → (x, z, −y), within 1e-3 of the size;
//! * three.js draws as many vertices and triangles as MDG holds, Blender has as
//!   many polygons; mesh objects other than `geometry` are the isosurface instances
//!   (prototype instances are expanded into the geometry), as many as MDG's output
//!   has unless there are more than the exporter writes as nodes
//!   ([`mdg_export::glb::MAX_INSTANCE_NODES`]), when at most as many;
//!   `--stats` vertices and triangles are at most the drawn ones (instances add);
//! * animated examples (the `.glb` has animations) have Blender actions and
//!   three.js clips with tracks; at least two std examples are animated;
//! * the mean colour of what Blender renders (Cycles from MDG's home view, lit like
//!   MDG's pictures, no tone mapping, composited over the picture's background) is
//!   close to the mean colour of `mdg-run --png`'s picture, both over the pixels
//!   that differ from the background: its chromaticity (r, g, b)/(r + g + b) within
//!   [`CHROMA_TOLERANCE`], each channel (0..1 display values) within
//!   [`CHANNEL_TOLERANCE`] (the renderers light differently: Blender lights in
//!   linear light, MDG in display values). Display colours written where glTF wants
//!   linear ones are desaturated and brighter in Blender (measured in
//!   docs/decisions.md, issue 21). Not for the guided mode, whose picture draws
//!   the guide curves over the model, nor above [`PICTURE_LIMIT`] vertices (coral:
//!   30 million, minutes for the software picture);
//! * `assimp info` reads every `.glb`, and the `.ply`, `.obj`, `.stl` written (exit 0,
//!   faces reported);
//! * `mdg-run --instances` (prototype instances as `EXT_mesh_gpu_instancing`): where
//!   the output has nothing to instance, the file is the flat one byte for byte;
//!   otherwise three.js makes one InstancedMesh per instanced node with the expected
//!   instance counts, Blender (in the same process as the rest) an object per
//!   instance, and both show MDG's geometry and bounding box; assimp opens the file
//!   and shows each instanced mesh once; the benchmark tree at depth 16 (131,071
//!   squares) is a handful of InstancedMesh objects (see [`check_instanced`]).
//!
//! The clients are installed by `.ci/run`: the `bpy` venv at
//! `$MDG_BPY_PYTHON` (default `~/.cache/mdg/bpy-venv/bin/python`), `three` by
//! `npm ci --prefix tests/clients`, `assimp` from Debian's `assimp-utils`. A missing
//! client fails the test with what to install; `MDG_SKIP_CLIENT_TESTS=1` skips it.
//! `MDG_SKIP_BLENDER=REASON` skips only the Blender checks, saying so with the reason
//! (`.ci/run` sets it on machines without Python 3.11, which `bpy` 5 needs: Ubuntu
//! 24.04); three.js and assimp are still checked.
//! `MDG_CLIENTS_KEEP=DIR` keeps every file written (the pictures, the renders).
//! `MDG_CLIENTS_ONLY=NAME[,NAME]` checks only those std examples (not the
//! whole-set checks).

use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use mdg_export::glb::MAX_COLOR_VARIANTS;
use mdg_vm::bundle::SectionKind;

/// Largest difference allowed between the chromaticities (r, g, b)/(r + g + b) of the
/// mean colours of Blender's render and MDG's picture.
const CHROMA_TOLERANCE: f64 = 0.05;
/// Largest difference allowed per channel (0..1, display values) between those mean
/// colours: the same light lights a little brighter in linear light (Blender) than
/// in display values (MDG), and views differ where the grammar has its own camera.
/// The fewest model pixels in each picture for their mean colours to be compared.
const MIN_COLOUR_PIXELS: usize = 100;
const CHANNEL_TOLERANCE: f64 = 0.2;
/// The most expanded vertices for which MDG's picture is drawn and compared.
const PICTURE_LIMIT: usize = 5_000_000;
/// The most expanded vertices for which OBJ, STL and PLY are written for assimp.
const FLAT_LIMIT: usize = 100_000;

/// Picture size for `--png` and Blender's render.
const SIZE: (u32, u32) = (96, 72);

/// The `mdg-run` binary. The one place the tests look for it (it moves with the CLI).
fn mdg_run() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_mdg-run"))
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").canonicalize().expect("workspace root")
}

/// The Python interpreter of the venv holding `bpy`.
fn bpy_python() -> PathBuf {
    if let Some(p) = std::env::var_os("MDG_BPY_PYTHON") {
        return PathBuf::from(p);
    }
    let cache = std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
        .unwrap_or_else(|| PathBuf::from(".cache"));
    cache.join("mdg/bpy-venv/bin/python")
}

fn find_on_path(name: &str) -> Option<PathBuf> {
    std::env::split_paths(&std::env::var_os("PATH")?).map(|d| d.join(name)).find(|p| p.is_file())
}

/// Why the Blender checks are skipped: `MDG_SKIP_BLENDER`, when set and not empty.
fn blender_skipped() -> Option<String> {
    std::env::var("MDG_SKIP_BLENDER").ok().filter(|r| !r.trim().is_empty())
}

/// Every client (Blender's Python unless [`blender_skipped`]), or a message saying
/// what is missing and how to install it.
fn clients() -> Result<(Option<PathBuf>, PathBuf), String> {
    let mut missing = Vec::new();
    let python = blender_skipped().is_none().then(bpy_python);
    let bpy_ok = python.as_ref().is_none_or(|python| {
        Command::new(python).args(["-c", "import bpy"]).output().is_ok_and(|o| o.status.success())
    });
    if let (false, Some(python)) = (bpy_ok, &python) {
        missing.push(format!(
            "Blender's `bpy` (no `import bpy` with {}: python3.11 -m venv ~/.cache/mdg/bpy-venv && ~/.cache/mdg/bpy-venv/bin/pip install 'bpy>=5,<6', or set MDG_BPY_PYTHON; MDG_SKIP_BLENDER=REASON skips the Blender checks)",
            python.display()
        ));
    }
    if !root().join("tests/clients/node_modules/three").is_dir() {
        missing.push("three.js (npm ci --prefix tests/clients)".into());
    }
    let node = find_on_path("node");
    if node.is_none() {
        missing.push("Node.js (apt-get install nodejs)".into());
    }
    if find_on_path("assimp").is_none() {
        missing.push("assimp (apt-get install assimp-utils)".into());
    }
    if missing.is_empty() {
        Ok((python, node.unwrap_or_default()))
    } else {
        Err(format!(
            "the real-client test needs: {}.\n`bash .ci/run` installs them all; set MDG_SKIP_CLIENT_TESTS=1 to skip this test.",
            missing.join("; ")
        ))
    }
}

/// What `mdg-run --stats` printed: (vertices, triangles, instances).
fn parse_stats(stderr: &str) -> Option<(u64, u64, u64)> {
    let line = stderr.lines().find(|l| l.starts_with("rule calls "))?;
    let words: Vec<&str> = line.split_whitespace().collect();
    let after = |key: &str| -> Option<u64> {
        let i = words.iter().position(|w| *w == key)?;
        words.get(i + 1)?.parse().ok()
    };
    Some((after("vertices")?, after("triangles")?, after("instances")?))
}

/// A binary PLY written by MDG: (vertex count, face count, min, max).
fn read_ply(path: &Path) -> (usize, usize, [f64; 3], [f64; 3]) {
    let bytes = std::fs::read(path).expect("read ply");
    let end = bytes.windows(11).position(|w| w == b"end_header\n").expect("PLY header") + 11;
    let header = String::from_utf8_lossy(&bytes[..end]);
    let count = |el: &str| -> usize {
        header
            .lines()
            .find_map(|l| l.strip_prefix(&format!("element {el} ")))
            .and_then(|n| n.parse().ok())
            .expect("element count")
    };
    let (n, f) = (count("vertex"), count("face"));
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for i in 0..n {
        let o = end + i * 28;
        for k in 0..3 {
            let x = f32::from_le_bytes(bytes[o + 4 * k..o + 4 * k + 4].try_into().expect("4 bytes")) as f64;
            lo[k] = lo[k].min(x);
            hi[k] = hi[k].max(x);
        }
    }
    (n, f, lo, hi)
}

/// The pixels of a PNG as RGBA floats in 0..1.
fn pixels(path: &Path) -> Vec<[f64; 4]> {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).expect("open png")));
    let mut reader = decoder.read_info().expect("png header");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("png data");
    let channels = info.color_type.samples();
    buf[..info.buffer_size()]
        .chunks(channels)
        .map(|p| {
            let a = if channels == 4 { p[3] } else { 255 };
            [p[0], p[1], p[2], a].map(|x| x as f64 / 255.0)
        })
        .collect()
}

/// The mean RGB of the pixels of `px` (composited over `bg`) that differ from `bg`
/// by more than 6/255 in some channel, and their number.
fn mean_colour(px: &[[f64; 4]], bg: [f64; 3]) -> ([f64; 3], usize) {
    let mut sum = [0.0; 3];
    let mut n = 0;
    for p in px {
        let c: [f64; 3] = std::array::from_fn(|k| p[k] * p[3] + bg[k] * (1.0 - p[3]));
        if (0..3).any(|k| (c[k] - bg[k]).abs() > 6.0 / 255.0) {
            for k in 0..3 {
                sum[k] += c[k];
            }
            n += 1;
        }
    }
    (sum.map(|s| s / n.max(1) as f64), n)
}

fn chromaticity(c: [f64; 3]) -> [f64; 3] {
    let s = (c[0] + c[1] + c[2]).max(1e-9);
    c.map(|x| x / s)
}

/// MDG's geometry as a client should show it: vertices, triangles, bounding box.
type Geometry = (usize, usize, [f64; 3], [f64; 3]);

/// What MDG's output says a client should show.
struct Expected {
    geometry: Geometry,
    /// What `--instances` makes of the prototype instances ([`expected_gpu_instancing`]).
    gpu: (usize, usize),
    /// Isosurface instances with triangles: one node each in a `.glb` (prototype
    /// instances are expanded into the geometry unless `--instances`).
    isosurfaces: u64,
}

/// What MDG holds at t = 0 (the pose a glTF client shows): vertices and triangles
/// with every instance expanded (instances of meshes without triangles are not
/// drawn), and the bounding box of those vertices; what `--instances` makes of the
/// output's prototype instances; how many isosurface instances there are.
fn expected_in_process(bundle: &mdg_vm::bundle::Bundle) -> Expected {
    let opts = mdg_vm::eval::EvalOptions { time: Some(0.0), ..Default::default() };
    let unposed = mdg_vm::eval::evaluate(bundle, &opts);
    let gpu = expected_gpu_instancing(&unposed);
    let isosurfaces = unposed
        .instances
        .iter()
        .filter(|i| unposed.shared(i).is_some_and(|s| !s.is_prototype() && !s.mesh.triangles.is_empty()))
        .count() as u64;
    let out = unposed.posed(0.0);
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut grow = |p: [f32; 3]| {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k] as f64);
            hi[k] = hi[k].max(p[k] as f64);
        }
    };
    let (mut v, mut t) = (0, 0);
    let _ = out.for_each_piece::<()>(mdg_vm::output::Groups::ALL, |p| {
        if !p.triangles.is_empty() {
            v += p.vertices.len();
            t += p.triangles.len();
            p.mesh.positions[p.vertices.clone()].iter().for_each(|q| grow(*q));
        }
        Ok(())
    });
    Expected { geometry: (v, t, lo, hi), gpu, isosurfaces }
}

/// What `mdg-run --instances` should write for `out`'s instances of shared meshes
/// (prototypes and isosurfaces), grouped as the glTF writer documents it
/// (`export/src/glb.rs`): one instanced node per (shared mesh, mirrored, frame
/// colour where a prototype's items add colours), at most [`MAX_COLOR_VARIANTS`]
/// colours per prototype; left to the geometry or to nodes: meshes without
/// triangles, instances of animated bones in a skinned output, frames of zero or
/// non-finite scale, isosurfaces in frames with a non-uniform factor. Returns
/// (instanced nodes, instances they place).
fn expected_gpu_instancing(out: &mdg_vm::output::Output) -> (usize, usize) {
    let skinned = out.animation.bones.len() > 1;
    let mut groups = std::collections::BTreeSet::new();
    let mut variants: BTreeMap<u32, std::collections::BTreeSet<[u32; 4]>> = BTreeMap::new();
    let mut instances = 0;
    for inst in &out.instances {
        let Some(shared) = out.shared(&inst).filter(|s| !s.mesh.triangles.is_empty()) else {
            continue;
        };
        let f = &inst.frame;
        let scale = f.q.length_squared() * f.qh.length_squared();
        if (skinned && inst.bone != 0) || !(scale.is_finite() && scale > 0.0 && f.u.is_finite()) || inst.lin != 0 {
            continue;
        }
        let deltas = shared.is_prototype() && shared.mesh.colors.iter().any(|c| *c != [0.0; 4]);
        let colour = deltas.then(|| inst.color.map(f32::to_bits));
        if let Some(c) = colour {
            let seen = variants.entry(inst.mesh).or_default();
            if !seen.contains(&c) && seen.len() >= MAX_COLOR_VARIANTS {
                continue;
            }
            seen.insert(c);
        }
        groups.insert((inst.mesh, f.mirrored(), colour));
        instances += 1;
    }
    (groups.len(), instances)
}

/// What a `.glb`'s JSON says about `EXT_mesh_gpu_instancing`.
#[derive(Debug, Default)]
struct GlbInstancing {
    /// Per node with the extension: its instance count and whether it has `_COLOR_0`.
    nodes: Vec<(u64, bool)>,
    /// Nodes with a mesh and without the extension (objects a client makes besides
    /// the instances).
    plain_mesh_nodes: usize,
}

fn glb_instancing(doc: &Value) -> GlbInstancing {
    let mut g = GlbInstancing::default();
    for n in doc["nodes"].as_array().into_iter().flatten() {
        match n.pointer("/extensions/EXT_mesh_gpu_instancing/attributes") {
            Some(attrs) => {
                let count = doc["accessors"][attrs["TRANSLATION"].as_u64().unwrap_or(u64::MAX) as usize]["count"]
                    .as_u64()
                    .unwrap_or(0);
                g.nodes.push((count, attrs.get("_COLOR_0").is_some()));
            }
            None if n.get("mesh").is_some() => g.plain_mesh_nodes += 1,
            None => {}
        }
    }
    g
}

/// The JSON chunk of a `.glb`.
fn glb_json(bytes: &[u8]) -> Value {
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes")) as usize;
    serde_json::from_slice(&bytes[20..20 + json_len]).expect("glTF JSON")
}

/// A file written with `mdg-run --instances` that holds instanced nodes, and what
/// clients should make of it.
struct InstancedFile {
    name: String,
    glb: PathBuf,
    /// MDG's geometry, as for the flat file.
    expected: Geometry,
    /// From MDG's output: (instanced nodes, instances) ([`expected_gpu_instancing`]);
    /// `None` for the guided mode, whose search runs in `mdg-run`.
    gpu: Option<(usize, usize)>,
    json: GlbInstancing,
    /// Imported by Blender too (one object per instance: not the depth-16 tree).
    in_blender: bool,
}

fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array().map(|a| a.iter().filter_map(Value::as_f64).collect()).unwrap_or_default()
}

/// One example's files and what MDG says about it.
struct Example {
    name: String,
    glb: PathBuf,
    /// MDG's picture (none above [`PICTURE_LIMIT`] vertices).
    picture: Option<PathBuf>,
    render: PathBuf,
    /// `--stats`: vertices, triangles, instances (`None` for the grid mode).
    stats: Option<(u64, u64, u64)>,
    /// Isosurface instances with triangles (`None` for the guided and grid modes,
    /// which `mdg-run` runs its own way).
    isosurfaces: Option<u64>,
    /// MDG at t = 0: vertices, triangles, bounding box.
    ply: (usize, usize, [f64; 3], [f64; 3]),
    animated: bool,
    /// The guided mode's picture draws the guides over the model: no colour check.
    guided: bool,
}

fn run_mdg(args: &[&std::ffi::OsStr]) -> Result<String, String> {
    let out = Command::new(mdg_run()).args(args).output().map_err(|e| format!("cannot run mdg-run: {e}"))?;
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    if out.status.success() {
        Ok(stderr)
    } else {
        Err(stderr)
    }
}

/// Blender's checks (`tests/clients/blender_check.py`) on the jobs, in one process:
/// its results by job name, and the seconds it took.
fn run_blender(python: &Path, dir: &Path, jobs: &[Value]) -> (BTreeMap<String, Value>, f64) {
    let jobs_path = dir.join("blender-jobs.json");
    let result_path = dir.join("blender-result.json");
    std::fs::write(&jobs_path, serde_json::to_vec(jobs).expect("json")).expect("write jobs");
    let t = Instant::now();
    let out = Command::new(python)
        .arg(root().join("tests/clients/blender_check.py"))
        .arg(&jobs_path)
        .arg(&result_path)
        .output()
        .expect("run Blender's Python");
    let blender_seconds = t.elapsed().as_secs_f64();
    assert!(
        out.status.success(),
        "Blender check failed:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let blender: Value = serde_json::from_slice(&std::fs::read(&result_path).expect("Blender result")).expect("json");
    let blender = blender["results"]
        .as_array()
        .expect("results")
        .iter()
        .map(|r| (r["name"].as_str().unwrap_or_default().to_string(), r.clone()))
        .collect();
    (blender, blender_seconds)
}

#[test]
fn blender_three_and_assimp_open_every_std_example() {
    if std::env::var("MDG_SKIP_CLIENT_TESTS").is_ok_and(|v| v == "1") {
        eprintln!("skipped: MDG_SKIP_CLIENT_TESTS=1");
        return;
    }
    let (python, node) = clients().unwrap_or_else(|e| panic!("{e}"));
    if let Some(reason) = blender_skipped() {
        eprintln!("SKIPPED: the Blender checks of this test (MDG_SKIP_BLENDER): {reason}");
    }
    let dir = match std::env::var_os("MDG_CLIENTS_KEEP") {
        Some(d) => PathBuf::from(d),
        None => std::env::temp_dir().join(format!("mdg-clients-{}", std::process::id())),
    };
    std::fs::create_dir_all(&dir).expect("output dir");
    let started = Instant::now();
    let mut sources: Vec<PathBuf> = std::fs::read_dir(root().join("std/examples"))
        .expect("std/examples")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "mdg"))
        .collect();
    sources.sort();
    assert!(sources.len() >= 12, "std examples");
    // `MDG_CLIENTS_ONLY=emblem,tree` checks only those examples (a quick run after
    // changing one; the whole-set checks, such as the animated count, are left out).
    let only: Option<Vec<String>> = std::env::var("MDG_CLIENTS_ONLY")
        .ok()
        .filter(|v| !v.trim().is_empty())
        .map(|v| v.split(',').map(|s| s.trim().to_string()).collect());
    if let Some(only) = &only {
        sources.retain(|p| p.file_stem().is_some_and(|s| only.iter().any(|o| *o == s.to_string_lossy())));
        eprintln!("MDG_CLIENTS_ONLY: checking {} of the std examples: {only:?}", sources.len());
        assert!(!sources.is_empty(), "MDG_CLIENTS_ONLY names no std example");
    }

    let mut failures = Vec::new();
    let mut examples = Vec::new();
    let mut all_files = Vec::new();
    let mut instanced: Vec<InstancedFile> = Vec::new();
    for src in &sources {
        let name = src.file_stem().expect("name").to_string_lossy().into_owned();
        let example_started = Instant::now();
        // The creature mode writes a directory of generations, not one model; its own
        // tests (tests/tests/creature.rs) validate those files.
        let opts = mdg_compiler::expand::Options { std_dir: Some(root().join("std")), ..Default::default() };
        let bundle = match mdg_compiler::driver::build(&mdg_compiler::source::FsLoader, src, &opts) {
            Ok((bundle, _)) if bundle.extensions.has(SectionKind::Creatures) => {
                eprintln!("{name}: the creature mode writes many models: not a client check");
                continue;
            }
            Ok((bundle, _)) => bundle,
            Err(_) => {
                failures.push(format!("{name}: does not compile"));
                continue;
            }
        };
        let own_mode = bundle.extensions.has(SectionKind::Grid) || bundle.extensions.has(SectionKind::Guided);
        let file = |ext: &str| dir.join(format!("{name}.{ext}"));
        let (glb, picture) = (file("glb"), dir.join(format!("{name}.mdg.png")));
        let write_flat = |ext: &str| -> Result<PathBuf, String> {
            let out = file(ext);
            run_mdg(&[src.as_os_str(), "--time".as_ref(), "0".as_ref(), "-o".as_ref(), out.as_os_str()])
                .map(|_| out)
                .map_err(|e| format!("{name}: mdg-run -o {ext} failed:\n{e}"))
        };
        let (expected, gpu, isosurfaces) = if own_mode {
            match write_flat("ply") {
                Ok(ply) => {
                    all_files.push(ply.clone());
                    (read_ply(&ply), None, None)
                }
                Err(e) => {
                    failures.push(e);
                    continue;
                }
            }
        } else {
            let e = expected_in_process(&bundle);
            (e.geometry, Some(e.gpu), Some(e.isosurfaces))
        };
        let size = format!("{}x{}", SIZE.0, SIZE.1);
        // MDG's picture of a model of millions of vertices takes minutes on the CPU.
        let with_picture = expected.0 <= PICTURE_LIMIT;
        let mut args: Vec<&std::ffi::OsStr> = vec![src.as_os_str(), "-o".as_ref(), glb.as_os_str(), "--stats".as_ref()];
        if with_picture {
            args.extend(["--png".as_ref(), picture.as_os_str(), "--size".as_ref(), size.as_ref()]);
        }
        let stderr = match run_mdg(&args) {
            Ok(s) => s,
            Err(e) => {
                failures.push(format!("{name}: mdg-run failed:\n{e}"));
                continue;
            }
        };
        if !glb.is_file() {
            failures.push(format!("{name}: mdg-run wrote no {}", glb.display()));
            continue;
        }
        // The grid mode prints its own counters (steps, blocks), none of these.
        let stats = parse_stats(&stderr);
        if expected.0 <= FLAT_LIMIT {
            for ext in ["ply", "obj", "stl"] {
                if own_mode && ext == "ply" {
                    continue;
                }
                match write_flat(ext) {
                    Ok(f) => all_files.push(f),
                    Err(e) => failures.push(e),
                }
            }
        }
        all_files.push(glb.clone());
        let bytes = std::fs::read(&glb).expect("read glb");
        let doc = glb_json(&bytes);
        let animated = doc.get("animations").is_some();
        // With --instances (the grid mode makes no prototype instances): where there is
        // nothing to instance, the flat file byte for byte.
        if !bundle.extensions.has(SectionKind::Grid) {
            let path = file("instances.glb");
            match run_mdg(&[src.as_os_str(), "--instances".as_ref(), "-o".as_ref(), path.as_os_str()]) {
                Err(e) => failures.push(format!("{name}: mdg-run --instances failed:\n{e}")),
                Ok(_) => {
                    let inst_bytes = std::fs::read(&path).expect("read glb");
                    let json = glb_instancing(&glb_json(&inst_bytes));
                    let made = (json.nodes.len(), json.nodes.iter().map(|n| n.0 as usize).sum::<usize>());
                    if gpu.is_some_and(|g| g != made) {
                        failures.push(format!(
                            "{name}: --instances wrote {made:?} (instanced nodes, instances), MDG's output gives {gpu:?}"
                        ));
                    }
                    if json.nodes.is_empty() {
                        if inst_bytes != bytes {
                            failures.push(format!("{name}: nothing instanced, yet --instances changed the .glb"));
                        }
                    } else {
                        instanced.push(InstancedFile {
                            name: name.clone(),
                            glb: path,
                            expected,
                            gpu,
                            json,
                            in_blender: true,
                        });
                    }
                }
            }
        }
        eprintln!("{name}: files written in {:.1} s", example_started.elapsed().as_secs_f64());
        examples.push(Example {
            render: dir.join(format!("{name}.blender.png")),
            ply: expected,
            name,
            glb,
            picture: with_picture.then_some(picture),
            stats,
            isosurfaces,
            animated,
            guided: bundle.extensions.has(SectionKind::Guided),
        });
    }
    // Every kind of prototype instance (colour variants, mirrored items, bones), and
    // the draw-call claim: the benchmark tree at depth 16 (131,071 squares) is a
    // handful of InstancedMesh objects in three.js (too many objects for Blender).
    let tree = dir.join("tree_workload_16.mdg");
    let text = std::fs::read_to_string(root().join("benches/workloads/tree.mdg")).expect("tree workload");
    assert!(text.contains("maxdepth 19"), "the tree workload changed");
    std::fs::write(&tree, text.replace("maxdepth 19", "maxdepth 16")).expect("write tree");
    // And isosurfaces: 12,000 spheres in two colours are two InstancedMesh objects
    // (they were 12,000 nodes, each a draw call).
    let spheres = dir.join("spheres_12000.mdg");
    std::fs::write(
        &spheres,
        "@import primitives\nstartshape grid\nrule grid { 30 * {x 1} 20 * {y 1} 10 * {z 1} { SPHERE {s 0.4} SPHERE {z 0.5 s 0.3 B -1} } }\n",
    )
    .expect("write spheres");
    let opts = mdg_compiler::expand::Options { std_dir: Some(root().join("std")), ..Default::default() };
    for (name, src, in_blender) in [
        ("prototypes", root().join("tests/instancing/prototypes.mdg"), true),
        ("tree_workload_16", tree, false),
        ("spheres_12000", spheres, false),
    ] {
        let (bundle, _) = mdg_compiler::driver::build(&mdg_compiler::source::FsLoader, &src, &opts)
            .unwrap_or_else(|_| panic!("{name} does not compile"));
        let Expected { geometry: expected, gpu, .. } = expected_in_process(&bundle);
        if name == "tree_workload_16" {
            assert_eq!(gpu, (1, (1 << 17) - 1), "the tree at depth 16: one prototype, 2^17 - 1 instances");
        }
        if name == "spheres_12000" {
            assert_eq!(gpu, (1, 12_000), "12,000 isosurface spheres: one shared mesh, one instanced node");
        }
        let glb = dir.join(format!("{name}.instances.glb"));
        run_mdg(&[src.as_os_str(), "--instances".as_ref(), "-o".as_ref(), glb.as_os_str()])
            .unwrap_or_else(|e| panic!("mdg-run --instances {name} failed:\n{e}"));
        let json = glb_instancing(&glb_json(&std::fs::read(&glb).expect("read glb")));
        instanced.push(InstancedFile { name: name.into(), glb, expected, gpu: Some(gpu), json, in_blender });
    }
    let mdg_seconds = started.elapsed().as_secs_f64();

    // Blender: one process for every file.
    let jobs: Vec<Value> = examples
        .iter()
        .map(|e| {
            serde_json::json!({
                "name": e.name,
                "glb": e.glb,
                "png": e.render,
                "size": [SIZE.0, SIZE.1],
            })
        })
        // The --instances files in the same Blender process, not rendered (Blender
        // drops the per-instance colours, `_COLOR_0`).
        .chain(instanced.iter().filter(|i| i.in_blender).map(|i| {
            serde_json::json!({"name": format!("{}.instances", i.name), "glb": i.glb, "png": null, "size": [SIZE.0, SIZE.1]})
        }))
        .collect();
    let (blender, blender_seconds) = match &python {
        Some(python) => run_blender(python, &dir, &jobs),
        None => (BTreeMap::new(), 0.0),
    };

    // three.js: one Node process for every file.
    let t = Instant::now();
    let out = Command::new(&node)
        .arg(root().join("tests/clients/three_check.mjs"))
        .args(examples.iter().map(|e| &e.glb))
        .args(instanced.iter().map(|i| &i.glb))
        .output()
        .expect("run node");
    let three_seconds = t.elapsed().as_secs_f64();
    assert!(out.status.success(), "three.js check failed:\n{}", String::from_utf8_lossy(&out.stderr));
    let three: Value = serde_json::from_slice(&out.stdout).expect("three.js JSON");
    let mut three: Vec<Value> = three["results"].as_array().expect("results").clone();
    assert_eq!(three.len(), examples.len() + instanced.len());
    let three_instanced = three.split_off(examples.len());

    let max_nodes = mdg_export::glb::MAX_INSTANCE_NODES as u64;
    let mut animated = 0;
    for (e, t) in examples.iter().zip(&three) {
        let name = &e.name;
        let (vertices, faces, lo, hi) = e.ply;
        let (stat_v, stat_t, instances) = e.stats.unwrap_or((0, 0, 0));
        let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let tol = 1e-3 * size.max(1e-3);
        if e.stats.is_some()
            && (stat_v > vertices as u64 || stat_t > faces as u64 || (instances == 0 && stat_t != faces as u64))
        {
            failures
                .push(format!("{name}: --stats {stat_v} vertices {stat_t} triangles, the PLY {vertices} and {faces}"));
        }
        // three.js
        if let Some(err) = t.get("error") {
            failures.push(format!("{name}: three.js cannot load the .glb: {err}"));
        } else {
            if t["vertices"].as_u64() != Some(vertices as u64) || t["triangles"].as_u64() != Some(faces as u64) {
                failures.push(format!(
                    "{name}: three.js draws {} vertices {} triangles, MDG has {vertices} and {faces}",
                    t["vertices"], t["triangles"]
                ));
            }
            let y_up_lo = [lo[0], lo[2], -hi[1]];
            let y_up_hi = [hi[0], hi[2], -lo[1]];
            if !close(&floats(&t["min"]), &y_up_lo, tol) || !close(&floats(&t["max"]), &y_up_hi, tol) {
                failures.push(format!(
                    "{name}: three.js (y up) bounds {} .. {}, expected {y_up_lo:?} .. {y_up_hi:?}",
                    t["min"], t["max"]
                ));
            }
            let instance_objects =
                t["meshes"].as_u64().unwrap_or(0).saturating_sub(t["geometry"].as_u64().unwrap_or(0));
            // The isosurface instances are nodes; prototype instances are expanded into
            // the geometry (`--stats` counts both). Above the node limit the exporter
            // merges instances of small meshes. The guided and grid modes' isosurfaces
            // are not known here: at most `--stats`'s instances.
            let ok = match e.isosurfaces {
                Some(iso) if iso <= max_nodes => instance_objects == iso,
                Some(iso) => instance_objects <= iso,
                None => instance_objects <= instances,
            };
            if !ok {
                failures.push(format!(
                    "{name}: three.js has {instance_objects} instance objects, MDG {:?} isosurface instances (--stats {instances} instances)",
                    e.isosurfaces
                ));
            }
            let clips = t["animations"].as_array().map(Vec::len).unwrap_or(0);
            if e.animated && (clips == 0 || t["animations"][0]["tracks"].as_u64().unwrap_or(0) == 0) {
                failures.push(format!("{name}: animated, but three.js has no animation tracks"));
            }
        }
        if e.animated {
            animated += 1;
        }
        // Blender
        if python.is_none() {
            continue;
        }
        let Some(b) = blender.get(name) else {
            failures.push(format!("{name}: no Blender result"));
            continue;
        };
        if let Some(err) = b.get("error") {
            failures.push(format!("{name}: Blender cannot import the .glb: {err}"));
            continue;
        }
        if b["polygons"].as_u64() != Some(faces as u64) {
            failures.push(format!("{name}: Blender has {} polygons, MDG {faces} triangles", b["polygons"]));
        }
        if !close(&floats(&b["min"]), &lo, tol) || !close(&floats(&b["max"]), &hi, tol) {
            failures.push(format!("{name}: Blender (z up) bounds {} .. {}, MDG {lo:?} .. {hi:?}", b["min"], b["max"]));
        }
        if e.animated && b["actions"].as_array().is_none_or(Vec::is_empty) {
            failures.push(format!("{name}: animated, but Blender has no actions"));
        }
        // The picture's background is its corner pixel (the grammar's `background`).
        let Some(picture) = &e.picture else {
            eprintln!("{name}: {vertices} vertices, no MDG picture to compare colours with");
            continue;
        };
        let picture = pixels(picture);
        let bg = [picture[0][0], picture[0][1], picture[0][2]];
        let (mdg_mean, mdg_n) = mean_colour(&picture, bg);
        let (blender_mean, blender_n) = mean_colour(&pixels(&e.render), bg);
        let (cm, cb) = (chromaticity(mdg_mean), chromaticity(blender_mean));
        eprintln!(
            "{name}: colour MDG {mdg_mean:.3?} ({mdg_n} px), Blender {blender_mean:.3?} ({blender_n} px), chromaticity MDG {cm:.3?} Blender {cb:.3?}, import {:.2} s",
            b["import_seconds"].as_f64().unwrap_or(0.0)
        );
        // A model of sub-pixel triangles (koch_snowflake at this size, at one sample)
        // covers a few dozen pixels, each mostly background: too few for a mean colour.
        let compared = mdg_n >= MIN_COLOUR_PIXELS && blender_n >= MIN_COLOUR_PIXELS;
        if !compared && mdg_n > 0 && blender_n > 0 {
            eprintln!(
                "{name}: colours NOT compared: MDG's picture has {mdg_n} model pixels, Blender's {blender_n} (fewer than {MIN_COLOUR_PIXELS})"
            );
        }
        if !e.guided
            && compared
            && (!close(&cm, &cb, CHROMA_TOLERANCE) || !close(&mdg_mean, &blender_mean, CHANNEL_TOLERANCE))
        {
            failures.push(format!(
                "{name}: Blender's render has mean colour {blender_mean:.3?} (chromaticity {cb:.3?}), MDG's picture {mdg_mean:.3?} ({cm:.3?}); tolerances {CHROMA_TOLERANCE} and {CHANNEL_TOLERANCE}"
            ));
        }
        if mdg_n == 0 || blender_n == 0 {
            failures.push(format!("{name}: nothing drawn (MDG {mdg_n} pixels, Blender {blender_n})"));
        }
    }
    if animated < 2 && only.is_none() {
        failures.push(format!("only {animated} std examples are animated; the animation check needs two"));
    }

    // assimp: every format of every example.
    let t = Instant::now();
    for f in &all_files {
        let out = Command::new("assimp").arg("info").arg(f).output().expect("run assimp");
        let text = String::from_utf8_lossy(&out.stdout);
        let faces = text
            .lines()
            .find_map(|l| l.trim().strip_prefix("Faces:"))
            .and_then(|n| n.trim().parse::<u64>().ok())
            .unwrap_or(0);
        if !out.status.success() || faces == 0 {
            failures.push(format!(
                "assimp info {} failed ({}, {faces} faces):\n{text}{}",
                f.display(),
                out.status,
                String::from_utf8_lossy(&out.stderr)
            ));
        }
    }
    let assimp_seconds = t.elapsed().as_secs_f64();
    check_instanced(&instanced, &three_instanced, python.is_some().then_some(&blender), &mut failures);
    eprintln!(
        "{} examples: mdg-run {mdg_seconds:.1} s, Blender {} ({}), three.js {three_seconds:.1} s, assimp {assimp_seconds:.1} s ({} files)",
        examples.len(),
        if python.is_some() { format!("{blender_seconds:.1} s") } else { "skipped".into() },
        blender.len(),
        all_files.len()
    );
    if std::env::var_os("MDG_CLIENTS_KEEP").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    assert!(failures.is_empty(), "{} problems:\n{}", failures.len(), failures.join("\n"));
}

/// The `--instances` files as the clients read them (three.js's report `three`,
/// Blender's `blender` by job name), and `assimp info` on each:
///
/// * three.js: one InstancedMesh per instanced node, as many as MDG's output gives
///   (grouped as the writer groups), each with `instanceMatrix.count` = its count and
///   `instanceColor` where the node has `_COLOR_0`; their counts add up to the
///   instances MDG made (less those left to the geometry); drawn with every instance,
///   the vertices, triangles and world bounding box (y up) are MDG's;
/// * Blender makes an object of every instance: its mesh objects are the instances
///   plus the file's other mesh nodes, its polygons and bounding box (z up) MDG's;
/// * assimp ignores the extension: it opens the file and shows each instanced mesh
///   once (the depth-16 tree: one square, 2 faces).
fn check_instanced(
    instanced: &[InstancedFile],
    three: &[Value],
    blender: Option<&BTreeMap<String, Value>>,
    failures: &mut Vec<String>,
) {
    for (i, t) in instanced.iter().zip(three) {
        let name = format!("{}.instances", i.name);
        let (vertices, faces, lo, hi) = i.expected;
        let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let tol = 1e-3 * size.max(1e-3);
        let nodes = i.json.nodes.len();
        let instances: u64 = i.json.nodes.iter().map(|n| n.0).sum();
        if let Some(gpu) = i.gpu {
            if gpu != (nodes, instances as usize) {
                failures.push(format!("{name}: the file has {nodes} instanced nodes placing {instances} instances, MDG's output gives {gpu:?}"));
            }
        }
        // three.js
        if let Some(err) = t.get("error") {
            failures.push(format!("{name}: three.js cannot load the .glb: {err}"));
        } else {
            let objects = t["instanced"].as_array().cloned().unwrap_or_default();
            let mut got: Vec<(u64, bool)> =
                objects.iter().map(|o| (o["count"].as_u64().unwrap_or(0), o["color"] == true)).collect();
            let mut want = i.json.nodes.clone();
            got.sort();
            want.sort();
            if got != want {
                failures.push(format!(
                    "{name}: three.js has InstancedMesh objects (count, instanceColor) {got:?}, the file's nodes {want:?}"
                ));
            }
            if let Some(o) = objects.iter().find(|o| o["count"] != o["matrices"]) {
                failures.push(format!(
                    "{name}: InstancedMesh {} has count {} but {} matrices",
                    o["name"], o["count"], o["matrices"]
                ));
            }
            if t["drawn_vertices"].as_u64() != Some(vertices as u64)
                || t["drawn_triangles"].as_u64() != Some(faces as u64)
            {
                failures.push(format!(
                    "{name}: three.js draws {} vertices {} triangles with every instance, MDG has {vertices} and {faces}",
                    t["drawn_vertices"], t["drawn_triangles"]
                ));
            }
            let y_up_lo = [lo[0], lo[2], -hi[1]];
            let y_up_hi = [hi[0], hi[2], -lo[1]];
            if !close(&floats(&t["min"]), &y_up_lo, tol) || !close(&floats(&t["max"]), &y_up_hi, tol) {
                failures.push(format!(
                    "{name}: three.js (y up) bounds with every instance {} .. {}, expected {y_up_lo:?} .. {y_up_hi:?}",
                    t["min"], t["max"]
                ));
            }
            eprintln!(
                "{name}: three.js {} InstancedMesh ({instances} instances), {} mesh objects in all (MDG: {faces} triangles)",
                objects.len(),
                t["meshes"]
            );
        }
        // Blender
        if let (true, Some(blender)) = (i.in_blender, blender) {
            match blender.get(&name) {
                None => failures.push(format!("{name}: no Blender result")),
                Some(b) if b.get("error").is_some() => {
                    failures.push(format!("{name}: Blender cannot import the .glb: {}", b["error"]))
                }
                Some(b) => {
                    let objects = i.json.plain_mesh_nodes as u64 + instances;
                    if b["mesh_objects"].as_u64() != Some(objects) {
                        failures.push(format!(
                            "{name}: Blender has {} mesh objects, expected {objects} ({instances} instances and {} other mesh nodes)",
                            b["mesh_objects"], i.json.plain_mesh_nodes
                        ));
                    }
                    if b["polygons"].as_u64() != Some(faces as u64) {
                        failures.push(format!("{name}: Blender has {} polygons, MDG {faces} triangles", b["polygons"]));
                    }
                    if !close(&floats(&b["min"]), &lo, tol) || !close(&floats(&b["max"]), &hi, tol) {
                        failures.push(format!(
                            "{name}: Blender (z up) bounds {} .. {}, MDG {lo:?} .. {hi:?}",
                            b["min"], b["max"]
                        ));
                    }
                    eprintln!(
                        "{name}: Blender {} mesh objects ({} sharing their mesh data), {} empties, import {:.2} s",
                        b["mesh_objects"],
                        b["shared_mesh_objects"],
                        b["empties"],
                        b["import_seconds"].as_f64().unwrap_or(0.0)
                    );
                }
            }
        }
        // assimp
        let out = Command::new("assimp").arg("info").arg(&i.glb).output().expect("run assimp");
        let text = String::from_utf8_lossy(&out.stdout);
        let count = |key: &str| {
            text.lines()
                .find_map(|l| l.trim().strip_prefix(key))
                .and_then(|n| n.trim().parse::<u64>().ok())
                .unwrap_or(0)
        };
        let (assimp_faces, assimp_nodes) = (count("Faces:"), count("Nodes:"));
        if !out.status.success() || assimp_faces == 0 {
            failures.push(format!("{name}: assimp info failed ({}, {assimp_faces} faces):\n{text}", out.status));
        } else if i.name == "tree_workload_16" && assimp_faces != 2 {
            failures.push(format!("{name}: assimp shows {assimp_faces} faces, the one square of the prototype is 2"));
        }
        eprintln!("{name}: assimp {assimp_nodes} nodes, {assimp_faces} faces (MDG: {faces} triangles)");
    }
    // The draw-call claim: a handful of InstancedMesh objects, not 131,071 meshes;
    // and the 12,000 isosurface spheres one InstancedMesh for their shared mesh.
    match instanced.iter().zip(three).find(|(i, _)| i.name == "tree_workload_16") {
        Some((_, t)) if t["meshes"].as_u64().is_some_and(|m| m <= 4) => {}
        found => failures.push(format!(
            "tree_workload_16.instances: three.js has {} mesh objects, a handful expected",
            found.map(|(_, t)| t["meshes"].clone()).unwrap_or_default()
        )),
    }
    match instanced.iter().zip(three).find(|(i, _)| i.name == "spheres_12000") {
        Some((_, t))
            if t["meshes"].as_u64() == Some(1)
                && t["instanced"].as_array().is_some_and(|a| a.len() == 1 && a[0]["count"] == 12_000) => {}
        found => failures.push(format!(
            "spheres_12000.instances: three.js has {} mesh objects ({}), one InstancedMesh of 12,000 expected",
            found.map(|(_, t)| t["meshes"].clone()).unwrap_or_default(),
            found.map(|(_, t)| t["instanced"].clone()).unwrap_or_default()
        )),
    }
}

/// What the editor's preview reads, as three.js reads it: a guided grammar's guides
/// and bones as line nodes of their own (`guides`, `bones`, besides the pen `lines`),
/// and with `--sites` the rule and line of every `VERTEX` triangle in the geometry's
/// extras (three.js puts them in `geometry.userData.mdg_sites`); without, none.
#[test]
fn three_reads_guides_bones_and_sites() {
    if std::env::var("MDG_SKIP_CLIENT_TESTS").is_ok_and(|v| v == "1") {
        eprintln!("skipped: MDG_SKIP_CLIENT_TESTS=1");
        return;
    }
    let (_, node) = clients().unwrap_or_else(|e| panic!("{e}"));
    let dir = std::env::temp_dir().join(format!("mdg-clients-sites-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("output dir");
    let (guided, with, without) = (dir.join("guided.glb"), dir.join("tree_sites.glb"), dir.join("tree.glb"));
    let example = |name: &str| root().join("std/examples").join(name);
    let os = std::ffi::OsStr::new;
    // A fixed number of generations: the same model whatever the machine's speed.
    let g = example("guided_tree.mdg");
    let search = ["--search-generations", "30", "--budget", "none", "-o"].map(os);
    run_mdg(&[&[g.as_os_str()], &search[..], &[guided.as_os_str()]].concat()).unwrap_or_else(|e| panic!("{e}"));
    let t = example("tree.mdg");
    run_mdg(&[t.as_os_str(), os("--sites"), os("-o"), with.as_os_str()]).unwrap_or_else(|e| panic!("{e}"));
    run_mdg(&[t.as_os_str(), os("-o"), without.as_os_str()]).unwrap_or_else(|e| panic!("{e}"));
    let out = Command::new(&node)
        .arg(root().join("tests/clients/three_check.mjs"))
        .args([&guided, &with, &without])
        .output()
        .expect("run node");
    assert!(out.status.success(), "three.js check failed:\n{}", String::from_utf8_lossy(&out.stderr));
    let report: Value = serde_json::from_slice(&out.stdout).expect("three.js JSON");
    let results = report["results"].as_array().expect("results");
    let (g, w, wo) = (&results[0], &results[1], &results[2]);
    let named = &g["named_lines"];
    assert!(named["guides"].as_f64().unwrap_or(0.0) > 10.0, "guide segments: {g}");
    assert!(named["bones"].as_f64().unwrap_or(0.0) > 5.0, "bone segments: {g}");
    assert!(w["error"].is_null(), "{w}");
    assert!(w["sites"].as_u64().unwrap_or(0) > 0, "no sites with --sites: {w}");
    assert_eq!(wo["sites"].as_u64(), Some(0), "sites without --sites: {wo}");
    assert_eq!(w["triangles"], wo["triangles"], "--sites changes only the extras");
    let _ = std::fs::remove_dir_all(&dir);
}
