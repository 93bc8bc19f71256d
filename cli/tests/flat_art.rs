//! The `flat` directive's pictures (Context Free's flat art) on Vulkan (lavapipe in
//! CI), with the validation layer on: painted in derivation order, unlit, on white;
//! and three Context Free programs ported to MDG against `cfdg`'s own pictures.
//! Without a Vulkan device they fail with instructions (`bash .ci/run`), unless
//! `MDG_SKIP_VULKAN_TESTS=1`; without `cfdg` (Debian `contextfree`) the comparison
//! is skipped with a message.

mod common;

use common::*;

#[test]
fn flat_shapes_paint_in_order_unlit_on_white() {
    let Some(ctx) = vulkan() else { return };
    let (w, h) = (400, 400);
    let r = render(&ctx, "flat_overlap.mdg", w, h);
    r.image.save("flat_overlap.png");
    assert!(r.info.flat, "the `flat` directive reaches the renderer");
    // The three squares, as laid out in flat_overlap.mdg and seen from the front
    // (y up): black at the origin, red half over it to the right, blue at z -1 half
    // under both, above.
    let at = |x: f32, y: f32| {
        let (px, py) = project(&r.camera, &r.info, w, h, glam::Vec3::new(x, y, 0.0));
        r.image.at(px.round() as u32, py.round() as u32)
    };
    assert_eq!(at(-0.3, -0.3), [0, 0, 0, 255], "the black square stays black: no shading, no specular");
    assert_eq!(at(0.3, -0.3), [255, 0, 0, 255], "red, drawn later, is on top of black");
    assert_eq!(at(0.3, 0.3), [255, 0, 0, 255], "red is on top of blue (z -1)");
    assert_eq!(at(-0.3, 0.7), [0, 0, 255, 255], "blue where nothing covers it");
    assert_eq!(at(-0.3, 0.3), [0, 0, 0, 255], "black is on top of blue (z -1)");
    assert_eq!(r.image.at(2, 2), [255, 255, 255, 255], "Context Free's white background");
}

#[test]
fn flat_primitives_have_no_specular_highlight_in_the_lit_picture() {
    let Some(ctx) = vulkan() else { return };
    let (w, h) = (400, 400);
    let r = render(&ctx, "matte_flat_primitives.mdg", w, h);
    r.image.save("matte_flat_primitives.png");
    assert!(!r.info.flat, "no `flat` directive: the default lit program");
    // Everything is black, so any light pixel is a specular highlight.
    let at = |x: f32, y: f32| {
        let (px, py) = project(&r.camera, &r.info, w, h, glam::Vec3::new(x, y, 0.0));
        r.image.at(px.round() as u32, py.round() as u32)
    };
    // Points well inside each flat primitive (laid out as in matte_flat_primitives.mdg):
    // the square, the non-uniformly scaled square (its items run one by one, not as
    // an instance), the circle and the triangle.
    let mut inside: Vec<(f32, f32)> = Vec::new();
    for i in 0..=8 {
        for j in 0..=8 {
            let (u, v) = (i as f32 / 8.0, j as f32 / 8.0);
            inside.push((-2.0 + 1.6 * u, -0.8 + 1.6 * v));
            inside.push((-2.0 + 1.6 * u, -2.55 + 0.7 * v));
            let (a, rr) = (u * std::f32::consts::TAU, 0.55 * v);
            inside.push((1.2 + rr * a.cos(), -2.2 + rr * a.sin()));
            inside.push((1.2 + 0.6 * (u - 0.5), 0.4 + 0.4 * (v - 0.5)));
        }
    }
    let lit: Vec<_> =
        inside.iter().map(|&(x, y)| ((x, y), at(x, y))).filter(|(_, c)| c[..3].iter().any(|&k| k > 1)).collect();
    assert!(
        lit.is_empty(),
        "flat primitives stay black (0 ± 1), got {} light points: {:?}",
        lit.len(),
        &lit[..lit.len().min(8)]
    );
    // A box (std primitives' cube, 3D) where the circle was keeps its highlight.
    let cube = render(&ctx, "matte_cube.mdg", w, h);
    cube.image.save("matte_cube.png");
    let (px, py) = project(&cube.camera, &cube.info, w, h, glam::Vec3::new(1.2, -2.2, 0.005));
    let c = cube.image.at(px.round() as u32, py.round() as u32);
    assert!(c[..3].iter().all(|&k| k > 40), "the black box shows a specular highlight: {c:?}");
}

/// What a picture's ink (pixels unlike its corner's background) looks like, framing
/// aside: the ink's bounding box (its aspect), the fraction of the box it covers,
/// the box's mean colour (ink and background: edge smoothing moves colour between
/// pixels but keeps this sum) and the ink's coverage in each cell of an 8 × 8 grid.
struct Ink {
    aspect: f64,
    coverage: f64,
    mean: [f64; 3],
    grid: [f64; 64],
}

fn ink(px: &[u8], w: u32, h: u32, channels: usize) -> Ink {
    let at = |x: u32, y: u32| {
        let i = (y * w + x) as usize * channels;
        // (cfdg writes a grey picture as grey, or grey and alpha.)
        if channels < 3 {
            [px[i]; 3].map(i32::from)
        } else {
            [px[i], px[i + 1], px[i + 2]].map(i32::from)
        }
    };
    let bg = at(0, 0);
    let is_ink = |c: [i32; 3]| (0..3).map(|k| (c[k] - bg[k]).abs()).sum::<i32>() > 48;
    let (mut lo, mut hi) = ((w, h), (0, 0));
    for y in 0..h {
        for x in 0..w {
            if is_ink(at(x, y)) {
                lo = (lo.0.min(x), lo.1.min(y));
                hi = (hi.0.max(x), hi.1.max(y));
            }
        }
    }
    assert!(hi.0 > lo.0 && hi.1 > lo.1, "a picture without ink");
    let (bw, bh) = (hi.0 - lo.0 + 1, hi.1 - lo.1 + 1);
    let (mut n, mut sum) = (0usize, [0f64; 3]);
    let mut cells = [(0usize, 0usize); 64];
    for y in lo.1..=hi.1 {
        for x in lo.0..=hi.0 {
            let c = at(x, y);
            let cell = (((y - lo.1) * 8 / bh) * 8 + (x - lo.0) * 8 / bw) as usize;
            cells[cell].1 += 1;
            for k in 0..3 {
                sum[k] += f64::from(c[k]);
            }
            if is_ink(c) {
                n += 1;
                cells[cell].0 += 1;
            }
        }
    }
    Ink {
        aspect: f64::from(bw) / f64::from(bh),
        coverage: n as f64 / f64::from(bw * bh),
        mean: sum.map(|s| s / f64::from(bw * bh) / 255.0),
        grid: std::array::from_fn(|i| cells[i].0 as f64 / cells[i].1.max(1) as f64),
    }
}

/// Three Context Free programs and their MDG ports (tests/data/cf/): the picture's
/// ink has the same aspect (within 5 %), coverage (within 0.06), mean colour (within
/// 0.04 per channel) and the same place (mean difference over an 8 × 8 grid within
/// 0.08). Tolerances: the two renderers smooth edges differently (cfdg's exact
/// area coverage, MDG's 4× multisampling), which changes thin parts' coverage by a
/// few per cent; a shape painted in the wrong order or shaded changes the mean
/// colour or a cell by far more.
#[test]
fn ported_context_free_programs_draw_what_cfdg_draws() {
    if std::process::Command::new("cfdg").arg("--help").output().is_err() {
        eprintln!("skipped: `cfdg` (Debian package contextfree, installed by .ci/run) is not on PATH");
        return;
    }
    let Some(ctx) = vulkan() else { return };
    let size = 400;
    for name in ["spiral", "rings", "tree"] {
        let cf_png = out_dir().join(format!("cf-{name}.png"));
        let st = std::process::Command::new("cfdg")
            .args(["-q", "-s", &size.to_string()])
            .arg(data(&format!("cf/{name}.cfdg")))
            .arg(&cf_png)
            .status()
            .expect("run cfdg");
        assert!(st.success(), "cfdg failed on cf/{name}.cfdg");
        let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&cf_png).expect("cfdg's png")));
        let mut reader = decoder.read_info().expect("png header");
        let mut buf = vec![0; reader.output_buffer_size().expect("png size")];
        let frame = reader.next_frame(&mut buf).expect("png data");
        let channels = frame.color_type.samples();
        let cf = ink(&buf[..frame.buffer_size()], frame.width, frame.height, channels);
        let r = render(&ctx, &format!("cf/{name}.mdg"), size, size);
        r.image.save(&format!("mdg-{name}.png"));
        let mdg = ink(&r.image.px, size, size, 4);
        let grid = cf.grid.iter().zip(&mdg.grid).map(|(a, b)| (a - b).abs()).sum::<f64>() / 64.0;
        let report = format!(
            "{name}: aspect {:.3} cfdg / {:.3} mdg, coverage {:.3} / {:.3}, mean colour {:.3?} / {:.3?}, grid difference {grid:.3}",
            cf.aspect, mdg.aspect, cf.coverage, mdg.coverage, cf.mean, mdg.mean
        );
        eprintln!("{report}");
        assert!((cf.aspect / mdg.aspect - 1.0).abs() < 0.05, "{report}");
        assert!((cf.coverage - mdg.coverage).abs() < 0.06, "{report}");
        assert!((0..3).all(|k| (cf.mean[k] - mdg.mean[k]).abs() < 0.04), "{report}");
        assert!(grid < 0.08, "{report}");
    }
}
