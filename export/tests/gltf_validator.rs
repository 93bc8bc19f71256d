//! Validates the glTF exporter's output with the Khronos glTF validator (Node), flat
//! and with prototype instances as `EXT_mesh_gpu_instancing` (`GlbOptions::instances`).
//!
//! Needs `node` and `npm ci --prefix tests/gltf`; set `MDG_SKIP_NODE_TESTS=1` to skip
//! where Node is not available.

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::{Quat, Vec3};
use mdg_export::glb::{write_glb_with, GlbOptions, MAX_COLOR_VARIANTS};
use mdg_export::{write, Format};
use mdg_vm::geom::{blend_frames, polygonize, sweep, sweep_averaged, sweep_oriented, sweep_path, Frame, Grid};
use mdg_vm::output::{Animation, Bone, Camera, Instance, Mesh, Output, Polyline, SharedKind, SharedMesh, Track};

/// Emits a unit cube as VERTEX triangles in `frame` (mirrored frames flag their
/// triangles, as the VM does).
fn cube_in(m: &mut Mesh, frame: &Frame, color: [f32; 4]) {
    let faces: [(Vec3, Vec3, Vec3); 6] = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (-Vec3::X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (-Vec3::Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (-Vec3::Z, Vec3::Y, Vec3::X),
    ];
    for (n, a, b) in faces {
        let c = n * 0.5;
        let corners = [c - a * 0.5 - b * 0.5, c + a * 0.5 - b * 0.5, c + a * 0.5 + b * 0.5, c - a * 0.5 + b * 0.5];
        let idx: Vec<u32> = corners
            .iter()
            .map(|&p| m.push_vertex(frame.apply_point(p), frame.apply_normal(n), color, [0.0; 4], 0))
            .collect();
        m.push_triangle([idx[0], idx[1], idx[2]], frame.mirrored());
        m.push_triangle([idx[0], idx[2], idx[3]], frame.mirrored());
    }
}

fn circle(n: usize, r: f32) -> Vec<Vec3> {
    (0..n)
        .map(|k| {
            let a = k as f32 / n as f32 * std::f32::consts::TAU;
            Vec3::new(a.cos(), a.sin(), 0.0) * r
        })
        .collect()
}

fn outputs() -> Vec<(&'static str, Output)> {
    let mut v = Vec::new();

    let mut cube = Output::default();
    cube_in(&mut cube.mesh, &Frame::identity(), [0.8, 0.3, 0.1, 1.0]);
    v.push(("cube", cube));

    let mut mirrored = Output::default();
    let f = Frame::identity()
        .translate(Vec3::new(2.0, 0.0, 0.0))
        .rotate(Quat::from_rotation_y(0.4))
        .reflect(Vec3::X)
        .scale(0.5);
    cube_in(&mut mirrored.mesh, &Frame::identity(), [1.0; 4]);
    cube_in(&mut mirrored.mesh, &f, [2.0, -1.0, 0.5, 1.0]);
    v.push(("mirrored", mirrored));

    let grid = Grid { min: Vec3::splat(-1.0), max: Vec3::splat(1.0), res: [10, 10, 10] };
    let sphere = polygonize(&grid, &|p: Vec3| p.length() - 0.8, 1 << 20, &|| false).expect("sphere");
    let inst = |frame: Frame, color: [f32; 4]| Instance { frame, color, mesh: 0, bone: 0, lin: 0, at: 0 };
    let frame = Frame::identity().translate(Vec3::new(0.0, 3.0, 0.0)).rotate(Quat::from_rotation_z(0.7)).scale(0.3);
    let mirror = Frame::identity().translate(Vec3::new(-3.0, 0.0, 0.0)).reflect(Vec3::Y);
    let at = |x: f32, y: f32| Frame::identity().translate(Vec3::new(x, y, 0.0));
    let instanced = Output {
        shared_meshes: vec![SharedMesh::isosurface("SPHERE", sphere), SharedMesh::isosurface("EMPTY", Mesh::default())],
        instances: [
            inst(at(3.0, 0.0), [1.0, 0.0, 0.0, 1.0]),
            inst(frame, [0.0, 1.0, 0.0, 1.0]),
            inst(at(0.0, -3.0), [1.0, 0.0, 0.0, 1.0]),
            inst(mirror, [0.0, 0.0, 1.0, 0.5]),
            inst(Frame::identity().scale(0.0), [1.0; 4]),
            Instance { mesh: 1, ..inst(Frame::identity(), [1.0; 4]) },
            Instance { mesh: 7, ..inst(Frame::identity(), [1.0; 4]) },
        ]
        .into_iter()
        .collect(),
        ..Output::default()
    };
    v.push(("instanced", instanced));

    let mut sweeps = Output::default();
    let a = Frame::identity();
    let b = a.translate(Vec3::new(1.0, 2.0, 3.0)).rotate(Quat::from_rotation_x(1.2)).scale(0.5);
    let profile = circle(8, 0.3);
    sweep_path(&mut sweeps.sweeps, &profile, &blend_frames(&a, &b, 12), [1.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0], 0);
    sweep(&mut sweeps.sweeps, &profile, &b, &b.translate(Vec3::Z).scale(0.0), [1.0; 4], [1.0; 4], 0);
    sweep_oriented(&mut sweeps.sweeps, &profile, &a, &a.translate(Vec3::new(-2.0, 0.0, 1.0)), [1.0; 4], [1.0; 4], 0);
    let m = a.reflect(Vec3::X).translate(Vec3::new(0.0, -2.0, 0.0));
    sweep_averaged(
        &mut sweeps.sweeps,
        &profile,
        &m,
        &m.rotate(Quat::from_rotation_z(1.0)).translate(Vec3::Z),
        [1.0; 4],
        [1.0; 4],
        0,
    );
    sweeps.lines.push(Polyline {
        namespace: "".into(),
        points: vec![[0.0; 3], [1.0, 2.0, 3.0], [1.0, 3.0, 3.0]],
        bones: Vec::new(),
    });
    sweeps.lines.push(Polyline { namespace: "lonely".into(), points: vec![[5.0; 3]], bones: Vec::new() });
    v.push(("sweeps", sweeps));

    v.push(("empty", Output::default()));
    v.push(("animated", animated()));
    v.push(("prototypes", prototypes()));
    v
}

/// A prototype as the evaluator makes one: a unit square of two triangles in its
/// run's frame, with colour deltas `delta` on its vertices (zero for none).
fn square_prototype(name: &str, delta: [f32; 4]) -> SharedMesh {
    let mut m = Mesh::default();
    for p in [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]] {
        m.push_vertex(Vec3::from(p), Vec3::Z, delta, [0.0; 4], 0);
    }
    m.push_triangle([0, 1, 2], false);
    m.push_triangle([3, 4, 5], false);
    SharedMesh { name: name.into(), mesh: m, kind: SharedKind::Prototype { face_normals: vec![None, None] } }
}

/// Prototype instances the glTF writer groups for `EXT_mesh_gpu_instancing`: a
/// white prototype in three colours (one node with `_COLOR_0`) and mirrored (a node
/// over the mirrored copy), one placed at zero scale (baked: glTF cannot hold it); a
/// prototype with colour deltas in more frame colours than the writer makes variant
/// meshes for (the rest baked into the geometry).
fn prototypes() -> Output {
    let mut out = Output {
        shared_meshes: vec![square_prototype("plain", [0.0; 4]), square_prototype("tinted", [-0.5, 0.0, 0.0, 0.0])],
        ..Output::default()
    };
    let inst = |mesh: u32, frame: Frame, color: [f32; 4]| Instance { frame, color, mesh, bone: 0, lin: 0, at: 0 };
    let at = |x: f32, y: f32| Frame::identity().translate(Vec3::new(x, y, 0.0));
    for (k, c) in [[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]].into_iter().enumerate() {
        out.instances.push(inst(0, at(2.0 * k as f32, 0.0).rotate(Quat::from_rotation_z(0.3)).scale(0.5), c));
    }
    out.instances.push(inst(0, at(0.0, 2.0).reflect(Vec3::X).rotate(Quat::from_rotation_z(0.5)), [1.0; 4]));
    out.instances.push(inst(0, at(0.0, 4.0).scale(0.0), [1.0; 4]));
    for k in 0..MAX_COLOR_VARIANTS + 6 {
        let grey = k as f32 / (MAX_COLOR_VARIANTS + 6) as f32;
        out.instances.push(inst(1, at(k as f32, 6.0), [1.0, grey, grey, 1.0]));
    }
    out
}

/// The instanced nodes of a `.glb` and the instances they place.
fn gpu_instancing(bytes: &[u8]) -> (usize, u64) {
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes")) as usize;
    let json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len]).expect("glTF JSON");
    let mut nodes = 0;
    let mut instances = 0;
    for n in json["nodes"].as_array().into_iter().flatten() {
        if let Some(a) = n.pointer("/extensions/EXT_mesh_gpu_instancing/attributes/TRANSLATION") {
            nodes += 1;
            instances += json["accessors"][a.as_u64().expect("accessor") as usize]["count"].as_u64().unwrap_or(0);
        }
    }
    (nodes, instances)
}

/// Bones (one nested in another, one with a mirrored and scaled motion, one frozen),
/// skinned VERTEX and sweep geometry, an instance on a bone, and an animated camera.
fn animated() -> Output {
    let spin: Vec<Frame> = (1..=12).map(|k| Frame::identity().rotate(Quat::from_rotation_z(k as f32 * 0.5))).collect();
    let bob: Vec<Frame> = (0..7).map(|k| Frame::identity().translate(Vec3::new(0.0, 0.0, 0.1 * k as f32))).collect();
    let flip: Vec<Frame> = (0..4).map(|k| Frame::identity().reflect(Vec3::X).scale(1.0 + 0.25 * k as f32)).collect();
    let cam: Vec<Frame> = (1..=20)
        .map(|k| {
            Frame::identity()
                .rotate(Quat::from_rotation_z(k as f32 * 0.3))
                .translate(Vec3::new(8.0, 0.0, 2.0))
                .rotate(Quat::from_rotation_y(1.5))
        })
        .collect();
    let a_rest = Frame::identity().translate(Vec3::new(2.0, 0.0, 0.0));
    let b_rest = a_rest.translate(Vec3::new(1.0, 0.0, 0.0)).scale(0.5);
    let bone = |rule: &str, parent: u32, rest: Frame, fps: f32, tracks: Vec<u32>| Bone {
        rule: rule.into(),
        parent,
        rest,
        fps,
        tracks,
    };
    let mut out = Output::default();
    cube_in(&mut out.mesh, &Frame::identity(), [1.0; 4]);
    let start = out.mesh.n_vertices();
    cube_in(&mut out.mesh, &a_rest, [1.0, 0.0, 0.0, 1.0]);
    cube_in(&mut out.mesh, &b_rest, [0.0, 1.0, 0.0, 1.0]);
    let n = out.mesh.n_vertices();
    out.mesh.bones = (0..n)
        .map(|i| {
            if i < start {
                0
            } else if i < start + 24 {
                1
            } else {
                3
            }
        })
        .collect();
    sweep(&mut out.sweeps, &circle(6, 0.2), &a_rest, &a_rest.translate(Vec3::Z), [1.0; 4], [1.0; 4], 2);
    let mut line = Polyline::default();
    line.push(Vec3::ZERO, 0);
    line.push(a_rest.u, 1);
    line.push(b_rest.u, 3);
    out.lines.push(line);
    let grid = Grid { min: Vec3::splat(-1.0), max: Vec3::splat(1.0), res: [6, 6, 6] };
    let sphere = polygonize(&grid, &|p: Vec3| p.length() - 0.8, 1 << 16, &|| false).expect("sphere");
    out.shared_meshes.push(SharedMesh::isosurface("SPHERE", sphere));
    out.instances.push(Instance {
        frame: b_rest.translate(Vec3::Z),
        color: [0.2, 0.2, 1.0, 1.0],
        mesh: 0,
        bone: 3,
        lin: 0,
        at: 0,
    });
    // A prototype on the root (instanced with `--instances`) and on a moving bone
    // (expanded into the skinned geometry: three.js cannot instance skinned meshes).
    out.shared_meshes.push(square_prototype("square", [0.0; 4]));
    let at = out.mesh.n_vertices() as u32;
    for (bone, x) in [(0, -2.0), (3, 0.0)] {
        let frame = Frame::identity().translate(Vec3::new(x, -2.0, 0.0));
        out.instances.push(Instance { frame, color: [1.0; 4], mesh: 1, bone, lin: 0, at });
    }
    out.animation = Animation {
        duration: 2.0,
        bones: vec![
            bone("", 0, Frame::identity(), 0.0, Vec::new()),
            bone("a", 0, a_rest, 6.0, vec![0, 1]),
            bone("frozen", 0, a_rest, 0.0, vec![0]),
            bone("b", 1, b_rest, 12.0, vec![2]),
        ],
        tracks: vec![
            Track { rule: "spin".into(), frames: spin, complete: true },
            Track { rule: "bob".into(), frames: bob, complete: false },
            Track { rule: "flip".into(), frames: flip, complete: true },
            Track { rule: "fly".into(), frames: cam, complete: true },
        ],
        camera: Some(Camera { track: 3, fps: 10.0, fov: 45.0, near: 0.1, far: 100.0 }),
    };
    out
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn exported_glb_files_pass_the_khronos_validator() {
    let dir = std::env::temp_dir().join(format!("mdg-gltf-validator-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut paths = Vec::new();
    for (name, out) in outputs() {
        let mut bytes = Vec::new();
        write(Format::Glb, &out, &mut bytes).expect("glb export");
        let p = dir.join(format!("{name}.glb"));
        std::fs::write(&p, &bytes).expect("write glb");
        paths.push(p);
        let mut bytes = Vec::new();
        write_glb_with(&out, &GlbOptions { instances: true }, &mut bytes).expect("glb export with instances");
        let expected = match name {
            // Plain in colours, plain mirrored, one node per colour of the tinted one.
            "prototypes" => (2 + MAX_COLOR_VARIANTS, 4 + MAX_COLOR_VARIANTS as u64),
            // The root's instance only.
            "animated" => (1, 1),
            // The sphere's isosurface instances: three plain, one mirrored (the
            // degenerate one is baked, the empty mesh and the missing one are skipped).
            "instanced" => (2, 4),
            _ => (0, 0),
        };
        assert_eq!(gpu_instancing(&bytes), expected, "{name}: instanced nodes and instances");
        let p = dir.join(format!("{name}.instances.glb"));
        std::fs::write(&p, &bytes).expect("write glb");
        paths.push(p);
    }

    let gltf_dir = workspace_root().join("tests").join("gltf");
    let skip = std::env::var("MDG_SKIP_NODE_TESTS").is_ok_and(|v| v == "1");
    let have_modules = gltf_dir.join("node_modules").join("gltf-validator").is_dir();
    let have_node = Command::new("node").arg("--version").output().is_ok_and(|o| o.status.success());
    if !(have_modules && have_node) {
        let _ = std::fs::remove_dir_all(&dir);
        let missing = if have_node { "the gltf-validator package" } else { "node" };
        if skip {
            eprintln!("skipped: {missing} is missing and MDG_SKIP_NODE_TESTS=1");
            return;
        }
        panic!("{missing} is missing: install Node and run `npm ci --prefix tests/gltf` (or set MDG_SKIP_NODE_TESTS=1 to skip)");
    }

    let result = Command::new("node").arg(gltf_dir.join("validate.mjs")).args(&paths).output().expect("run node");
    let stdout = String::from_utf8_lossy(&result.stdout);
    let stderr = String::from_utf8_lossy(&result.stderr);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(result.status.success(), "glTF validator reported errors:\n{stdout}\n{stderr}");
    assert_eq!(stdout.matches(" 0 errors").count(), paths.len(), "{stdout}");
    println!("{stdout}");
}
