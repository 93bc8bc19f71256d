//! `mdg-run --time T` bakes the pose at T into formats without animation: the
//! written vertices equal the rest vertices moved by the bone's transform at
//! frame ⌊T·fps⌋ (docs/reference.md §11), computed here independently.

use std::path::PathBuf;
use std::process::Command;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mdg-run-time-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// The `v x y z …` lines of an OBJ file, in MDG's z-up axes (OBJ is written y up:
/// MDG's (x, y, z) as (x, z, −y)).
fn obj_vertices(path: &std::path::Path) -> Vec<[f64; 3]> {
    let text = std::fs::read_to_string(path).expect("read obj");
    text.lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().take(3).map(|x| x.parse().expect("number")).collect();
            [v[0], -v[2], v[1]]
        })
        .collect()
}

fn run(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_mdg-run")).args(args).output().expect("run mdg-run")
}

#[test]
fn time_bakes_the_pose_into_obj() {
    let dir = temp_dir("obj");
    let src = dir.join("arm.mdg");
    // A bone at {x 2 rz 90} spinning 36° per frame about its own origin, at 10 fps.
    std::fs::write(
        &src,
        "startshape scene\nfps 10\nduration 3\nrule scene { arm {x 2 rz 90} }\n\
         rule arm : spin { VERTEX {x 1} VERTEX {x 1 y 0.5} VERTEX {y 1} }\n\
         rule spin { 10/10 * {rz 360} FRAME {} }\n",
    )
    .expect("write source");
    let obj = dir.join("pose.obj");
    for t in ["0", "1.75", "2.3", "12.05"] {
        let out = run(&[src.to_str().expect("utf-8 path"), "--time", t, "-o", obj.to_str().expect("utf-8 path")]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let got = obj_vertices(&obj);
        // Frame i = ⌊t·10⌋ turns by 36°·((i mod 10) + 1) about the bone's origin (2, 0, 0);
        // the rest vertices are (2, 1, 0), (1.5, 1, 0), (1, 0, 0).
        let secs: f64 = t.parse().expect("time");
        let i = (secs * 10.0 + 1e-9).floor() as u64;
        let a = (36.0 * ((i % 10) + 1) as f64).to_radians();
        let rest = [[2.0, 1.0], [1.5, 1.0], [1.0, 0.0]];
        assert_eq!(got.len(), 3);
        for (k, r) in rest.iter().enumerate() {
            let (x, y) = (r[0] - 2.0, r[1]);
            let want = [2.0 + x * a.cos() - y * a.sin(), x * a.sin() + y * a.cos(), 0.0];
            for c in 0..3 {
                assert!((got[k][c] - want[c]).abs() < 1e-5, "t = {t}, vertex {k}: {:?} vs {want:?}", got[k]);
            }
        }
    }
    // Without --time, OBJ gets the rest pose and a note says so.
    let out = run(&[src.to_str().expect("utf-8 path"), "-o", obj.to_str().expect("utf-8 path")]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("rest pose"));
    let got = obj_vertices(&obj);
    assert!((got[0][0] - 2.0).abs() < 1e-6 && (got[0][1] - 1.0).abs() < 1e-6, "{:?}", got[0]);
    // A bad time is a usage error.
    let out = run(&[src.to_str().expect("utf-8 path"), "--time", "-1", "-o", obj.to_str().expect("utf-8 path")]);
    assert_eq!(out.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn time_beyond_duration_samples_an_infinite_rule_further() {
    let dir = temp_dir("lazy");
    let src = dir.join("drift.mdg");
    std::fs::write(
        &src,
        "startshape a\nfps 10\nduration 1\nmaxdepth 10000\nrule a : drift { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n\
         rule drift { FRAME {} drift {z 0.1} }\n",
    )
    .expect("write source");
    let stl = dir.join("pose.obj");
    let out = run(&[src.to_str().expect("utf-8 path"), "--time", "5", "-o", stl.to_str().expect("utf-8 path")]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // Frame 50 of `drift` is 5 up, though `duration` only needs frames 0..=10.
    let got = obj_vertices(&stl);
    assert!((got[0][2] - 5.0).abs() < 1e-4 && (got[1][0] - 1.0).abs() < 1e-5, "{got:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `mdg-run --png` draws with the Vulkan renderer: the bundle's own `program`
/// (a shader painting everything `uniform tint`, green) shows in the picture,
/// which the software fallback could not draw.
#[test]
fn png_uses_the_vulkan_renderer_and_the_bundles_program() {
    if std::env::var_os("MDG_SKIP_VULKAN_TESTS").is_some() {
        return;
    }
    let dir = temp_dir("png");
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/custom_shader.mdg");
    let png = dir.join("custom.png");
    let out = run(&[
        data.to_str().expect("utf-8"),
        "-o",
        dir.join("custom.glb").to_str().expect("utf-8"),
        "--png",
        png.to_str().expect("utf-8"),
        "--size",
        "160x120",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(!stderr.contains("software renderer"), "fell back to software: {stderr}");
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).expect("png written")));
    let mut reader = decoder.read_info().expect("png header");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("png data");
    assert_eq!((info.width, info.height), (160, 120));
    let px: Vec<&[u8]> = buf.chunks(4).collect();
    let green = px.iter().filter(|c| c[0] <= 1 && c[1] >= 254 && c[2] <= 1).count();
    assert!(green > px.len() / 50, "{green} pure green pixels of {}", px.len());
}

/// Every mode's flags share one command line: clap's consistency checks (unique
/// names and ids) pass and `--help` lists each mode's flags.
#[test]
fn help_lists_every_modes_flags() {
    let out = run(&["--help"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for flag in
        ["--guides", "--search-generations", "--generations", "--population", "--keep", "--steps", "--enclosure"]
    {
        assert!(text.contains(flag), "--help lacks {flag}:\n{text}");
    }
}

/// `--format none` evaluates and writes nothing, and `--stats` reports the wall and
/// CPU time of each phase (issue 37); `-o` with it is refused, naming the flags.
#[test]
fn format_none_writes_nothing_and_stats_report_cpu_time() {
    let dir = temp_dir("none");
    let src = dir.join("squares.mdg");
    std::fs::write(&src, "startshape s\nrule s { 3 * {x 2} { VERTEX {} VERTEX {x 1} VERTEX {y 1} } }\n")
        .expect("write source");
    let out = Command::new(env!("CARGO_BIN_EXE_mdg-run"))
        .current_dir(&dir)
        .args([src.to_str().expect("utf-8 path"), "--format", "none", "--stats"])
        .output()
        .expect("run mdg-run");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let files: Vec<String> = std::fs::read_dir(&dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into())
        .collect();
    assert_eq!(files, vec!["squares.mdg".to_string()], "nothing written: {stderr}");
    assert!(!stderr.contains("wrote"), "{stderr}");
    assert!(stderr.contains("vertices 9 "), "{stderr}");
    let times = stderr.lines().find(|l| l.starts_with("time: ")).unwrap_or_else(|| panic!("no time line: {stderr}"));
    assert!(times.contains("evaluate ") && times.contains(" ms wall ") && times.contains(" ms CPU"), "{times}");
    assert!(times.contains("process ") && !times.contains("write "), "no write phase: {times}");
    // With a model written, the write phase is timed too.
    let glb = dir.join("squares.glb");
    let out = run(&[src.to_str().expect("utf-8 path"), "-o", glb.to_str().expect("utf-8 path"), "--stats"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && glb.exists(), "{stderr}");
    assert!(stderr.lines().any(|l| l.starts_with("time: ") && l.contains("write ")), "{stderr}");
    let out = run(&[src.to_str().expect("utf-8 path"), "--format", "none", "-o", glb.to_str().expect("utf-8 path")]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--format none writes no model; drop -o"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A `.glb` written with `--instances` keeps prototype instances as records, and the
/// vertex budget counts them so: the 8,191 squares of a tree (49,146 vertices when
/// expanded) pass a budget of 20,000 whole, while the flat file stops at it.
#[test]
fn instances_kept_instanced_cost_the_budget_their_records() {
    let dir = temp_dir("budget");
    let src = dir.join("tree.mdg");
    std::fs::write(
        &src,
        "startshape T\nmaxdepth 12\nrule T {\n  VERTEX [x -0.5 y -0.5] VERTEX [x 0.5 y -0.5] VERTEX [x 0.5 y 0.5]\n  \
         VERTEX [x -0.5 y -0.5] VERTEX [x 0.5 y 0.5] VERTEX [x -0.5 y 0.5]\n  T [y 1 rz 25 s 0.75]\n  T [y 1 rz -25 s 0.75]\n}\n",
    )
    .expect("write source");
    let glb = dir.join("tree.glb");
    let args = [
        src.to_str().expect("utf-8 path"),
        "-o",
        glb.to_str().expect("utf-8 path"),
        "--stats",
        "--max-vertices",
        "20000",
    ];
    let flat = run(&args);
    let flat_err = String::from_utf8_lossy(&flat.stderr);
    assert!(flat.status.success(), "{flat_err}");
    assert!(flat_err.contains("vertex budget 20000 reached"), "{flat_err}");
    let inst = run(&[&args[..], &["--instances"]].concat());
    let inst_err = String::from_utf8_lossy(&inst.stderr);
    assert!(inst.status.success(), "{inst_err}");
    assert!(!inst_err.contains("vertex budget"), "{inst_err}");
    assert!(inst_err.contains("vertices 49146 "), "every square: {inst_err}");
    let _ = std::fs::remove_dir_all(&dir);
}
