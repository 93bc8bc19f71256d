//! Offscreen render tests on Vulkan (lavapipe in CI) with the validation layer on:
//! every test fails on any validation error. Without a Vulkan device they fail
//! with instructions (`bash .ci/run`), unless `MDG_SKIP_VULKAN_TESTS=1`.
//!
//! Tolerances are stated where they are used and come from the geometry, not from
//! the measured results: a silhouette's edge pixels are partly covered (4× MSAA
//! blends them with the background), so a pixel count may differ from the exact
//! projected area by at most the perimeter (one pixel along every edge).

mod common;

use common::*;
use glam::Vec3;
use mdg_cli::toolchain::Toolchain;
use mdg_viewer::model::Loader as _;
use mdg_viewer::offscreen::Offscreen;
use mdg_viewer::renderer::FrameParams;
use mdg_viewer::{program, scene};

const W: u32 = 512;
const H: u32 = 384;

/// Screen hull of a unit cube at `center` for a render.
fn hull(r: &Render, center: Vec3) -> Vec<(f32, f32)> {
    let pts = cube_corners(center, 1.0).into_iter().map(|p| project(&r.camera, &r.info, W, H, p)).collect();
    convex_hull(pts)
}

#[test]
fn red_cube_left_blue_cube_right_on_white() {
    let Some(ctx) = vulkan() else { return };
    let r = render(&ctx, "red_blue_cubes.mdg", W, H);
    r.image.save("red_blue_cubes.png");
    let red_hull = hull(&r, Vec3::new(-1.5, 0.0, 0.0));
    let blue_hull = hull(&r, Vec3::new(1.5, 0.0, 0.0));
    // The home view looks from the front right: -x is on the left of the picture.
    let cx = |h: &[(f32, f32)]| h.iter().map(|p| p.0).sum::<f32>() / h.len() as f32;
    assert!(cx(&red_hull) < W as f32 * 0.5 && cx(&blue_hull) > W as f32 * 0.5, "red must be left, blue right");

    for (name, poly, is_colour) in [("red", &red_hull, reddish as fn([u8; 4]) -> bool), ("blue", &blue_hull, bluish)] {
        let (area, perimeter) = area_perimeter(poly);
        // Coverage: pixels that are not background, on or next to the silhouette
        // (the two cubes are far apart), match the projected silhouette area within one pixel per
        // unit of perimeter.
        let covered = r.image.count(|x, y, c| {
            let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
            !white(c) && (inside(poly, px, py) || edge_distance(poly, px, py) <= 1.5)
        });
        eprintln!("{name}: covered {covered} px, projected area {area:.0} px, perimeter {perimeter:.0} px");
        assert!(
            (covered as f32 - area).abs() <= perimeter,
            "{name} cube covers {covered} px, projected area {area:.0} px (tolerance ±{perimeter:.0} px)"
        );
        // Colour: every pixel well inside the silhouette (≥ 2 px from its edge) is
        // the cube's colour, except specular highlights: at most 3% of them.
        let interior = r.image.count(|x, y, _| {
            let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
            inside(poly, px, py) && edge_distance(poly, px, py) >= 2.0
        });
        let coloured = r.image.count(|x, y, c| {
            let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
            inside(poly, px, py) && edge_distance(poly, px, py) >= 2.0 && is_colour(c)
        });
        eprintln!("{name}: {coloured} of {interior} interior pixels coloured");
        assert!(interior > 1000, "{name} cube too small to test: {interior} px");
        assert!(
            coloured as f32 >= 0.97 * interior as f32,
            "{name}: {coloured} of {interior} interior pixels have the cube's colour"
        );
    }
    // Lighting: the face turned to the light is bright, the others darker, and
    // faces differ (three faces are visible from the home view).
    let reds: Vec<u8> = (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|(x, y)| r.image.at(x, y))
        .filter(|c| reddish(*c))
        .map(|c| c[0])
        .collect();
    let max = reds.iter().copied().max().unwrap_or(0);
    let min = reds.iter().copied().min().unwrap_or(0);
    eprintln!("red shades {min}..{max}");
    assert!(max >= 180, "the lit face is too dark: max red {max}");
    assert!(max - min >= 40, "faces are not shaded differently: red {min}..{max}");
    // Background: every pixel more than 2 px from both silhouettes is exactly white.
    let stray = r.image.count(|x, y, c| {
        let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
        let near = |p: &[(f32, f32)]| inside(p, px, py) || edge_distance(p, px, py) <= 2.0;
        !near(&red_hull) && !near(&blue_hull) && !white(c)
    });
    assert_eq!(stray, 0, "background pixels that are not the background colour (1, 1, 1)");
}

/// Mean absolute difference per channel over the pixels of either image that are
/// not background.
fn mean_diff(a: &Image, b: &Image) -> (f64, usize) {
    let (mut sum, mut n) = (0.0, 0usize);
    for y in 0..a.h {
        for x in 0..a.w {
            let (p, q) = (a.at(x, y), b.at(x, y));
            if white(p) && white(q) {
                continue;
            }
            n += 1;
            sum += (0..3).map(|k| (p[k] as f64 - q[k] as f64).abs()).sum::<f64>() / 3.0;
        }
    }
    (sum / n.max(1) as f64, n)
}

#[test]
fn mirrored_model_is_lit_on_the_outside() {
    let Some(ctx) = vulkan() else { return };
    let plain = render(&ctx, "cube.mdg", W, H);
    let mirrored_model = load(&data("mirrored_cube.mdg"));
    assert!(
        mirrored_model.output.vertex_mesh().mirrored.iter().all(|m| *m),
        "the fx cube's triangles must be emitted mirrored"
    );
    let mirrored = render_model(&ctx, &mirrored_model, W, H);
    plain.image.save("cube.png");
    mirrored.image.save("mirrored_cube.png");
    // The mirror image of a cube about its centre is the same cube: the pictures
    // agree except where the two faces' diagonals (mirrored too) rasterise a
    // hair differently — a mean difference below 1 level of 255.
    let (d, n) = mean_diff(&plain.image, &mirrored.image);
    eprintln!("mirrored vs plain: mean difference {d:.3} over {n} px");
    assert!(n > 5000, "cube too small: {n} px");
    assert!(d < 1.0, "mirrored cube differs from the plain one by {d:.2} levels on average");
    let brightest = |img: &Image| img.count(|_, _, c| reddish(c) && c[0] >= 180);
    assert!(brightest(&mirrored.image) > 500, "the mirrored cube's lit face is missing");

    // Control: the same mirrored output drawn with its winding left uncorrected
    // (as if `oriented_triangles` were ignored) is lit on the inside — dark where
    // the light falls — so the comparison above can fail.
    let mut wrong = mirrored_model.output.clone();
    wrong.expand_prototypes();
    wrong.mesh.mirrored.iter_mut().for_each(|m| *m = false);
    let mut off = Offscreen::new(&ctx, W, H, 4).expect("offscreen");
    let prog = program::for_bundle(&mirrored_model.bundle, &programs()).expect("program");
    let sc = scene::build(&wrong);
    off.renderer_mut()
        .set_scene(&sc, &mirrored_model.bundle, &mirrored_model.output, &prog, &programs().lines)
        .expect("upload");
    let px = off
        .render(&FrameParams { camera: mirrored.camera, time: 0.0, wireframe: false, camera_rule: false })
        .expect("render");
    drop(off);
    assert_no_validation_errors(&ctx);
    let control = Image { px, w: W, h: H };
    control.save("mirrored_cube_unoriented.png");
    let (dc, _) = mean_diff(&plain.image, &control);
    eprintln!("unoriented control vs plain: mean difference {dc:.2}; bright px {}", brightest(&control));
    assert!(dc > 20.0, "the control (winding not corrected) should be lit wrongly, differs by only {dc:.2}");
    assert!(brightest(&control) < 50, "the control should have no brightly lit face");
}

#[test]
fn custom_program_and_user_uniform_change_the_picture() {
    let Some(ctx) = vulkan() else { return };
    let phong = render(&ctx, "cube.mdg", W, H);
    let custom = render(&ctx, "custom_shader.mdg", W, H);
    custom.image.save("custom_shader.png");
    assert!(
        custom.info.program.contains("flat_vs") && custom.info.program.contains("tint_fs"),
        "program: {}",
        custom.info.program
    );
    let green = |c: [u8; 4]| c[0] <= 1 && c[1] >= 254 && c[2] <= 1;
    let covered_phong = phong.image.count(|_, _, c| !white(c));
    let covered_custom = custom.image.count(|_, _, c| !white(c));
    let pure_green = custom.image.count(|_, _, c| green(c));
    // Same geometry, same camera: same coverage, to within the MSAA edge pixels
    // whose blend with white may round to 255 in one picture and not the other
    // (well under 1% of the silhouette).
    eprintln!("coverage phong {covered_phong}, custom {covered_custom}, pure green {pure_green}");
    let diff = (covered_phong as i64 - covered_custom as i64).unsigned_abs() as f64;
    assert!(diff <= 0.01 * covered_phong as f64, "coverage {covered_phong} vs {covered_custom}");
    // The tint shader paints `uniform tint 0 1 0 1`: every fully covered pixel is
    // pure green; only edge pixels (blended with white) are not — under 10%.
    assert!(
        pure_green as f64 >= 0.9 * covered_custom as f64,
        "{pure_green} of {covered_custom} covered pixels are pure green"
    );
    assert_eq!(custom.image.count(|_, _, c| reddish(c)), 0, "no Phong-lit red may remain");
    assert!(phong.image.count(|_, _, c| reddish(c)) as f64 > 0.9 * covered_phong as f64);
}

#[test]
fn pen_lines_without_sweeps_are_drawn_as_lines() {
    let Some(ctx) = vulkan() else { return };
    let r = render(&ctx, "pen_lines.mdg", W, H);
    r.image.save("pen_lines.png");
    assert_eq!(r.info.n_triangles, 0);
    assert_eq!(r.info.n_line_segments, 4);
    // The square's outline is seen from above (a flat model): dark ink along its
    // four sides, white inside and outside.
    let corners: Vec<(f32, f32)> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .iter()
        .map(|&(x, y)| project(&r.camera, &r.info, W, H, Vec3::new(x, y, 0.0)))
        .collect();
    let (_, perimeter) = area_perimeter(&corners);
    let ink = r.image.count(|_, _, c| c[0].max(c[1]).max(c[2]) < 200);
    // One-pixel lines: between half and twice the perimeter (plus 4 px at each
    // corner) in inked pixels (a
    // line's coverage is spread over one or two pixels by 4× MSAA; a pixel counts
    // as inked when the dark ink covers at least a fifth of it).
    eprintln!("{ink} inked pixels, perimeter {perimeter:.0}");
    assert!(
        (ink as f32) >= 0.5 * perimeter && (ink as f32) <= 2.0 * perimeter + 16.0,
        "{ink} ink pixels for a perimeter of {perimeter:.0}"
    );
    let (cx, cy) = project(&r.camera, &r.info, W, H, Vec3::ZERO);
    assert!(white(r.image.at(cx as u32, cy as u32)), "the inside of the square must be background");
}

#[test]
fn wireframe_draws_edges_only() {
    let Some(ctx) = vulkan() else { return };
    if !ctx.wireframe {
        eprintln!("device has no fillModeNonSolid; the wireframe toggle is off there");
        return;
    }
    let model = load(&data("cube.mdg"));
    let mut off = Offscreen::new(&ctx, W, H, 4).expect("offscreen");
    off.set_model(&model, &programs()).expect("upload");
    let camera = off.home_camera();
    let fill = off.render(&FrameParams { camera, time: 0.0, wireframe: false, camera_rule: false }).expect("render");
    let wire = off.render(&FrameParams { camera, time: 0.0, wireframe: true, camera_rule: false }).expect("render");
    drop(off);
    assert_no_validation_errors(&ctx);
    let covered = |px: &[u8]| px.chunks_exact(4).filter(|c| !(c[0] == 255 && c[1] == 255 && c[2] == 255)).count();
    let (f, w) = (covered(&fill), covered(&wire));
    Image { px: wire, w: W, h: H }.save("cube_wireframe.png");
    eprintln!("wireframe {w} px, filled {f} px");
    assert!(w > 100 && w * 4 < f, "wireframe covers {w} px, filled {f} px");
}

#[test]
fn glsl_error_is_reported_at_the_mdg_line() {
    // No GPU needed: this is the compiler's shader stage seen through the viewer.
    let path = data("glsl_error.mdg");
    let Err(fail) = Toolchain.load(&path, &load_options()) else { panic!("a GLSL error must fail the load") };
    let text = fail.error.to_string();
    assert!(text.contains("E0501"), "{text}");
    // `nope` is on line 13, column 27 of the .mdg file.
    assert!(text.contains("glsl_error.mdg:13:27"), "{text}");
    assert!(text.contains("nope"), "{text}");
}

#[test]
fn bones_in_the_shader_match_the_vm_pose() {
    let Some(ctx) = vulkan() else { return };
    let model = load(&data("animated_arm.mdg"));
    assert!(model.output.animation.is_animated(), "the arm must be a bone");
    let mut off = Offscreen::new(&ctx, W, H, 4).expect("offscreen");
    off.set_model(&model, &programs()).expect("upload");
    let camera = off.home_camera();
    let at = |off: &mut Offscreen, t: f32| {
        off.render(&FrameParams { camera, time: t, wireframe: false, camera_rule: false }).expect("render")
    };
    let (rest, moved) = (at(&mut off, 0.0), at(&mut off, 1.0));
    // The same instant posed on the CPU by the VM (`Output::posed`), drawn as a
    // static model from the same camera.
    let mut posed = load(&data("animated_arm.mdg"));
    posed.output = model.output.posed(1.0);
    off.set_model(&posed, &programs()).expect("upload");
    let cpu = at(&mut off, 0.0);
    drop(off);
    assert_no_validation_errors(&ctx);
    let img = |px| Image { px, w: W, h: H };
    let (rest, moved, cpu) = (img(rest), img(moved), img(cpu));
    moved.save("animated_arm_t1.png");
    // GPU skinning and CPU posing agree to well under one level per channel (they
    // differ only in float rounding of the same transform).
    let (d, n) = mean_diff(&moved, &cpu);
    eprintln!("bones: GPU vs CPU pose mean difference {d:.3} over {n} px");
    assert!(n > 5000 && d < 0.5, "GPU-posed and VM-posed pictures differ by {d:.3} levels");
    // And time matters: at t = 0 the blue cube is elsewhere.
    let (d0, _) = mean_diff(&rest, &moved);
    assert!(d0 > 20.0, "the arm did not move between t = 0 and t = 1 (difference {d0:.2})");
    assert_eq!(
        rest.count(|_, _, c| reddish(c)),
        moved.count(|_, _, c| reddish(c)),
        "the static red cube must not move"
    );
}

#[test]
fn camera_rule_looks_along_its_minus_z() {
    let Some(ctx) = vulkan() else { return };
    let model = load(&data("camera_rule.mdg"));
    let mut off = Offscreen::new(&ctx, W, H, 4).expect("offscreen");
    let info = off.set_model(&model, &programs()).expect("upload");
    assert!(info.has_camera_rule);
    let camera = off.home_camera();
    let px = off.render(&FrameParams { camera, time: 0.0, wireframe: false, camera_rule: true }).expect("render");
    drop(off);
    assert_no_validation_errors(&ctx);
    let img = Image { px, w: W, h: H };
    img.save("camera_rule.png");
    // The front face (y = -0.5) seen head-on from 9.5 units with a 40° vertical
    // field of view: a square of side H · (1 / 9.5) / (2 tan 20°), centred.
    let side = H as f32 * (1.0 / 9.5) / (2.0 * 20f32.to_radians().tan());
    let (cx, cy) = (W as f32 / 2.0, H as f32 / 2.0);
    let square = [
        (cx - side / 2.0, cy - side / 2.0),
        (cx + side / 2.0, cy - side / 2.0),
        (cx + side / 2.0, cy + side / 2.0),
        (cx - side / 2.0, cy + side / 2.0),
    ];
    let (area, perimeter) = area_perimeter(&square);
    let covered = img.count(|_, _, c| !white(c));
    eprintln!("camera rule: covered {covered} px, expected {area:.0} ± {perimeter:.0}");
    assert!((covered as f32 - area).abs() <= perimeter, "covered {covered} px, expected {area:.0} ± {perimeter:.0}");
    assert!(reddish(img.at(cx as u32, cy as u32)), "the cube must be in the centre");
    let stray = img.count(|x, y, c| {
        !white(c)
            && edge_distance(&square, x as f32 + 0.5, y as f32 + 0.5) > 1.5
            && !inside(&square, x as f32 + 0.5, y as f32 + 0.5)
    });
    assert_eq!(stray, 0, "pixels drawn outside the expected square");
}

#[test]
fn a_turntable_writes_its_numbered_views_and_the_sheet() {
    if skip_vulkan() {
        return;
    }
    let dir = out_dir().join("turntable");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    std::fs::write(dir.join("a.mdg"), "startshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n").expect("write");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_mdg-view"))
        .args(["a.mdg", "--png", "sheet.png", "--turntable", "3", "--size", "64x48"])
        .current_dir(&dir)
        .output()
        .expect("run mdg-view");
    assert!(out.status.success(), "mdg-view failed: {}", String::from_utf8_lossy(&out.stderr));
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png"))
        .collect();
    names.sort();
    assert_eq!(names, ["sheet-00.png", "sheet-01.png", "sheet-02.png", "sheet.png"]);
    for n in &names[..3] {
        let view = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(dir.join(n)).expect("open")));
        let info = view.read_info().expect("a PNG").info().clone();
        assert_eq!((info.width, info.height), (64, 48), "{n}");
    }
}

/// Every std example drawn with one sample and edge smoothing (`--samples auto` on a
/// CPU driver) and with one sample alone, small instances at their level of detail,
/// differs from its 4× picture at full detail (how every picture was drawn before)
/// only at edges: at most 0.5 % of the pixels differ by
/// more than 8/255 away from an edge of the 4× picture, and the mean difference is
/// under 3/255 (4/255 unsmoothed). The metric has teeth: the 4× picture with every colour 12/255 off fails it.
#[test]
fn one_sample_pictures_differ_from_four_sample_ones_only_at_edges() {
    let Some(ctx) = vulkan() else { return };
    let (w, h) = (240, 180);
    let dir = std_examples();
    let programs = programs();
    let mut report = Vec::new();
    let mut failures = Vec::new();
    let mut checked = 0;
    for path in &dir {
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let model = load(path);
        let draw = |samples: u32, smooth: bool, lod: bool| {
            let mut off = Offscreen::new(&ctx, w, h, samples).expect("offscreen");
            off.smooth = smooth;
            off.renderer_mut().lod = lod;
            let info = off.set_model(&model, &programs).expect("upload");
            let camera = off.home_camera();
            let frame = FrameParams { camera, time: 0.0, wireframe: false, camera_rule: info.has_camera_rule };
            let img = Image { px: off.render(&frame).expect("render"), w, h };
            (img, off.renderer_mut().drawn_points())
        };
        // Before: 4x, every instance at full detail. Now: the level of detail on
        // (coarse meshes, and point sprites for the smallest instances), at 1x and 4x.
        let (four, _) = draw(4, false, false);
        let (four_lod, points) = draw(4, false, true);
        let (one, _) = draw(1, false, true);
        let (smooth, _) = draw(1, true, true);
        if name == "tree" {
            four.save("eq-tree-4x.png");
            smooth.save("eq-tree-1x-smooth.png");
        }
        for (label, img, bound) in
            [("4x+lod", &four_lod, EQ_MEAN), ("1x", &one, EQ_MEAN_ALIASED), ("1x+smoothing", &smooth, EQ_MEAN)]
        {
            let (mean, off_edge) = off_edge_differences(&four, img);
            report.push(format!(
                "{name} {label}: mean {mean:.2}/255, {off_edge} px off edges; at 4x, {} instances as {} points",
                points.0, points.1
            ));
            if mean > bound || off_edge as f64 > EQ_OFF_EDGE_SHARE * f64::from(w * h) {
                failures.push(report.last().cloned().unwrap_or_default());
            }
        }
        // The metric's teeth: the reference with every colour channel moved 12/255
        // toward mid-grey (a change away from edges, as a wrong light or colour would
        // make) fails it.
        let moved: Vec<u8> = four
            .px
            .chunks_exact(4)
            .flat_map(|p| {
                let m = |c: u8| if c < 128 { c + 12 } else { c - 12 };
                [m(p[0]), m(p[1]), m(p[2]), p[3]]
            })
            .collect();
        let (mean, off_edge) = off_edge_differences(&four, &Image { px: moved, w, h });
        assert!(
            mean > EQ_MEAN || off_edge as f64 > EQ_OFF_EDGE_SHARE * f64::from(w * h),
            "{name}: a picture 12/255 off passes the metric (mean {mean:.2}, {off_edge} px off edges)"
        );
        checked += 1;
    }
    assert_no_validation_errors(&ctx);
    eprintln!("{}", report.join("\n"));
    assert_eq!(checked, dir.len());
    assert!(failures.is_empty(), "pictures that differ off edges:\n{}", failures.join("\n"));
}

/// A picture's shaders (std's Phong program, its instanced variant, the line
/// program) are compiled once and taken from the SPIR-V disk cache afterwards: a
/// second `mdg-run --png` rewrites no cache file (a compile would replace its file).
#[test]
fn a_second_picture_recompiles_no_shader() {
    if skip_vulkan() {
        return;
    }
    let dir = out_dir().join("spirv-cache");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch");
    let run = || {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_mdg-run"))
            .current_dir(&dir)
            .env("XDG_CACHE_HOME", dir.join("cache"))
            .env_remove("MDG_SPIRV_CACHE")
            .arg(root().join("std/examples/tree.mdg"))
            // (Vulkan's path: the CPU renderer, `auto`'s choice for std's program,
            // compiles no shader at all: cli/tests/cpu_render.rs.)
            .args(["-o", "tree.png", "--size", "64x48", "--renderer", "vulkan"])
            .output()
            .expect("run mdg-run");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    let files = || -> Vec<(String, u64, std::time::SystemTime)> {
        use std::os::unix::fs::MetadataExt as _;
        let mut v: Vec<_> = std::fs::read_dir(dir.join("cache/mdg/spirv"))
            .map(|rd| {
                rd.flatten()
                    .filter_map(|e| {
                        let m = e.metadata().ok()?;
                        Some((e.file_name().to_string_lossy().into_owned(), m.ino(), m.modified().ok()?))
                    })
                    .collect()
            })
            .unwrap_or_default();
        v.sort();
        v
    };
    run();
    let first = files();
    // std's phong_vs, phong_instanced_vs, phong_fs and the two line shaders.
    assert!(first.len() >= 5, "the first run cached {} shaders: {first:?}", first.len());
    std::thread::sleep(std::time::Duration::from_millis(20));
    run();
    assert_eq!(files(), first, "the second run compiled shaders again");
}

/// The level of detail (scene::Lod): std's tree at 600 × 600 draws its 3,373 leaf
/// blobs (~1,190 triangles each) with their coarse mesh, far fewer triangles, and
/// the picture's mean colour stays within 2/255 of the full render in every channel.
#[test]
fn small_instances_use_their_level_of_detail_and_keep_the_mean_colour() {
    let Some(ctx) = vulkan() else { return };
    let (w, h) = (600, 600);
    let model = load(&root().join("std/examples/tree.mdg"));
    let programs = programs();
    let draw = |lod: bool| {
        let mut off = Offscreen::new(&ctx, w, h, 1).expect("offscreen");
        off.smooth = true;
        off.renderer_mut().lod = lod;
        off.set_model(&model, &programs).expect("upload");
        let camera = off.home_camera();
        let px = off.render(&FrameParams { camera, time: 0.0, wireframe: false, camera_rule: false }).expect("render");
        (Image { px, w, h }, off.renderer_mut().drawn_triangles())
    };
    let (full, full_tris) = draw(false);
    let (coarse, coarse_tris) = draw(true);
    full.save("lod-tree-full.png");
    coarse.save("lod-tree-lod.png");
    assert_no_validation_errors(&ctx);
    eprintln!("level of detail: {coarse_tris} triangles drawn instead of {full_tris}");
    assert!(coarse_tris * 4 < full_tris, "{coarse_tris} triangles with the level of detail, {full_tris} without");
    let mean = |img: &Image, c: usize| img.px.chunks_exact(4).map(|p| f64::from(p[c])).sum::<f64>() / f64::from(w * h);
    for c in 0..3 {
        let (a, b) = (mean(&full, c), mean(&coarse, c));
        eprintln!("channel {c}: mean {a:.2} full, {b:.2} with the level of detail");
        assert!((a - b).abs() <= 2.0, "channel {c}: mean {a:.2} full, {b:.2} with the level of detail");
    }
}

/// The point stand-ins (`mdg_viewer::points`): the benchmark's million boxes
/// (`benches/workloads/boxes.mdg`, 3–5 pixels each at 1024²) drawn as point sprites
/// give a picture whose mean colour is within 2/255 of the full-detail picture in
/// every channel, with nearly every box a point.
#[test]
fn a_million_small_boxes_as_points_keep_the_mean_colour() {
    let Some(ctx) = vulkan() else { return };
    let (w, h) = (1024, 1024);
    let mut opts = load_options();
    opts.eval.max_vertices = 100_000_000;
    let model = match Toolchain.load(&root().join("benches/workloads/boxes.mdg"), &opts) {
        Ok((m, _)) => m,
        Err(f) => panic!("boxes.mdg does not load:\n{}", f.error),
    };
    assert_eq!(model.output.instances.len(), 1_000_000);
    let programs = programs();
    let draw = |stand_ins: bool| {
        let mut off = Offscreen::new(&ctx, w, h, 0).expect("offscreen");
        off.renderer_mut().stand_ins = stand_ins;
        off.set_model(&model, &programs).expect("upload");
        let camera = off.home_camera();
        let px = off.render(&FrameParams { camera, time: 0.0, wireframe: false, camera_rule: false }).expect("render");
        (Image { px, w, h }, off.renderer_mut().drawn_points())
    };
    let (full, none) = draw(false);
    let (points, n_points) = draw(true);
    full.save("boxes-full.png");
    points.save("boxes-points.png");
    assert_no_validation_errors(&ctx);
    assert_eq!(none, (0, 0));
    let (boxes, n_points) = n_points;
    eprintln!("{boxes} of 1,000,000 boxes drawn as {n_points} points");
    assert!(boxes > 900_000, "{boxes} boxes as points");
    let mean = |img: &Image, c: usize| img.px.chunks_exact(4).map(|p| f64::from(p[c])).sum::<f64>() / f64::from(w * h);
    for c in 0..3 {
        let (a, b) = (mean(&full, c), mean(&points, c));
        eprintln!("channel {c}: mean {a:.2} full, {b:.2} with points");
        assert!((a - b).abs() <= 2.0, "channel {c}: mean {a:.2} full, {b:.2} with points");
    }
}

/// GPU instancing draws what the expanded model draws: std's tree (prototype and
/// isosurface instances, their records written straight into the instance buffer)
/// drawn instanced and drawn from the evaluator's expansion of every instance into
/// world-space vertices, at one sample and full detail, differ by float rounding
/// alone (the transform applied in the shader rather than on the CPU): a mean below
/// 1/255 and at most 0.5 % of the pixels off by more than 8/255 away from an edge.
#[test]
fn instanced_pictures_equal_the_expanded_model() {
    let Some(ctx) = vulkan() else { return };
    let (w, h) = (400, 400);
    let model = load(&root().join("std/examples/tree.mdg"));
    let programs = programs();
    let draw = |instanced: bool| {
        let mut off = Offscreen::new(&ctx, w, h, 1).expect("offscreen");
        off.renderer_mut().lod = false;
        if instanced {
            off.set_model(&model, &programs).expect("upload");
        } else {
            let program = program::for_bundle(&model.bundle, &programs).expect("program");
            let scene = scene::build(&model.output);
            assert!(scene.instanced.is_none());
            off.renderer_mut()
                .set_scene(&scene, &model.bundle, &model.output, &program, &programs.lines)
                .expect("upload expanded");
        }
        let camera = off.home_camera();
        let px = off.render(&FrameParams { camera, time: 0.0, wireframe: false, camera_rule: false }).expect("render");
        Image { px, w, h }
    };
    let instanced = draw(true);
    let expanded = draw(false);
    instanced.save("instanced-tree.png");
    expanded.save("expanded-tree.png");
    assert_no_validation_errors(&ctx);
    let (mean, off_edge) = off_edge_differences(&expanded, &instanced);
    eprintln!("instanced vs expanded: mean {mean:.3}/255, {off_edge} px off edges");
    assert!(
        mean < 1.0 && off_edge as f64 <= EQ_OFF_EDGE_SHARE * f64::from(w * h),
        "instanced vs expanded: mean {mean:.3}/255, {off_edge} px off edges"
    );
}
