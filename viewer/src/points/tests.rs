//! Tests of the point stand-ins: placing, shading (one point and four at a time,
//! against `powf` and the scalar rounding) and the bytes they give.

use super::*;

/// A record: rows of `l` with translation `t`, colour `c`, bone 0.
fn record(l: Mat3, t: Vec3, c: [f32; 4]) -> Vec<u8> {
    let rows = l.transpose();
    let mut r = Vec::new();
    for (k, row) in [rows.x_axis, rows.y_axis, rows.z_axis].into_iter().enumerate() {
        for x in row.extend(t[k]).to_array() {
            r.extend_from_slice(&x.to_le_bytes());
        }
    }
    for x in c {
        r.extend_from_slice(&x.to_le_bytes());
    }
    r.extend_from_slice(&0u32.to_le_bytes());
    r
}

/// A unit square in z = 0 facing +z, matte (as Context Free's squares are).
fn square() -> (StandIn, Vec<Facet>) {
    let s = StandIn { first_facet: 0, n_facets: 1, centre: Vec3::ZERO, radius: 0.5f32.sqrt(), closed: false };
    (s, vec![Facet { area: Vec3::Z, centre: Vec3::ZERO, normal: Vec3::Z, delta: [0.0; 4], matte: true }])
}

/// Looking down −z from z = 10 with a 90° field of view onto a 100 × 100 target:
/// at depth 10, 5 pixels per unit.
fn view() -> View {
    let proj = glam::camera::rh::proj::directx::perspective(std::f32::consts::FRAC_PI_2, 1.0, 0.1, 100.0);
    let v = glam::camera::rh::view::look_at_mat4(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y);
    View {
        view_projection: proj * v,
        eye: Vec3::new(0.0, 0.0, 10.0),
        light: Vec3::new(0.0, 0.0, 10.0),
        spec: [1.0, 1.0, 1.0, 32.0],
        width: 100.0,
        height: 100.0,
        flat: true,
    }
}

fn draw(n: u32) -> InstancedDraw {
    InstancedDraw {
        first_index: 0,
        index_count: 6,
        vertex_offset: 0,
        first_instance: 0,
        instance_count: n,
        closed: false,
    }
}

fn point(sel: &Selection, k: usize) -> (Vec3, f32, [u8; 4]) {
    points_of(sel)[k]
}

/// Every point of `sel`: position, size, colour.
fn points_of(sel: &Selection) -> Vec<(Vec3, f32, [u8; 4])> {
    let mut all = vec![0u8; sel.n_points() * 20];
    sel.write_points(&mut all);
    all.chunks_exact(20).map(unpack).collect()
}

fn unpack(v: &[u8]) -> (Vec3, f32, [u8; 4]) {
    let f = |i: usize| f32::from_le_bytes([v[4 * i], v[4 * i + 1], v[4 * i + 2], v[4 * i + 3]]);
    (Vec3::new(f(0), f(1), f(2)), f(3), [v[16], v[17], v[18], v[19]])
}

/// Rounding a colour channel without libm gives `round`'s bytes, halves and
/// the floats next to them included.
#[test]
fn colour_channels_round_as_round_does() {
    let mut xs: Vec<f32> = (0..=255 * 64).map(|k| k as f32 / 64.0).collect();
    for k in 0..255 {
        let h = k as f32 + 0.5;
        xs.extend([h, f32::from_bits(h.to_bits() - 1), f32::from_bits(h.to_bits() + 1)]);
    }
    xs.extend([0.0, 0.49999997, 254.99998, 255.0, 255.5, 300.0, 1e10, f32::INFINITY]);
    for x in xs {
        assert_eq!(round_unit(x), x.round() as u8, "{x}");
    }
    for x in [-0.0, -0.4, -0.5, -3.7, -1e10, f32::NEG_INFINITY, f32::NAN] {
        assert_eq!(round_unit(x), 0, "{x}");
    }
}

/// Four points shaded together get the bytes each gets alone: lit and unlit,
/// matte, at the highlight and away from it, degenerate positions (on the
/// light, at NaN), other specular powers and colours.
#[test]
fn four_points_shaded_together_are_shaded_as_each_alone() {
    let mut views = vec![view()];
    let mut other = view();
    other.light = Vec3::new(3.0, -2.0, 6.0);
    other.eye = Vec3::new(-1.0, 4.0, 9.0);
    other.spec = [0.3, 0.9, 0.05, 20.0];
    views.push(other);
    let mut compared = 0;
    let mut seed = 12345u32;
    let mut next = move || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) as f32 / (1u32 << 24) as f32
    };
    for v in &views {
        let mut pts = Vec::new();
        for k in 0..4000 {
            let pos = Vec3::new(next() * 8.0 - 4.0, next() * 8.0 - 4.0, next() * 2.0 - 1.0);
            let normal = Vec3::new(next() - 0.5, next() - 0.5, next()).normalize_or_zero();
            let color = Vec4::new(next(), next(), next(), if k % 5 == 0 { 0.5 } else { 1.0 });
            pts.push(Point { pos, size: 1.0, normal, color, matte: k % 7 == 0 });
        }
        pts.push(Point { pos: v.light, size: 1.0, normal: Vec3::Z, color: Vec4::ONE, matte: false });
        pts.push(Point { pos: Vec3::NAN, size: 1.0, normal: Vec3::Z, color: Vec4::ONE, matte: false });
        pts.push(Point { pos: Vec3::ZERO, size: 1.0, normal: -Vec3::Z, color: Vec4::ONE, matte: false });
        // (Directions whose squared length overflows, underflows to zero, or is
        // infinite; signed zeros.)
        for pos in [
            Vec3::new(1e20, -3e19, 0.5),
            v.light + Vec3::new(1e-30, -1e-30, 0.0),
            Vec3::new(f32::INFINITY, 0.0, 1.0),
            Vec3::new(-0.0, -0.0, -0.0),
            v.eye,
            Vec3::new(f32::NEG_INFINITY, f32::NAN, 0.0),
            v.eye + Vec3::new(0.0, 1e-25, 0.0),
            Vec3::new(2.0, -0.0, 0.25),
        ] {
            let normal = Vec3::new(-0.0, 0.0, 1.0);
            pts.push(Point { pos, size: 1.0, normal, color: Vec4::new(0.2, 0.9, -0.0, 1.0), matte: false });
        }
        pts.push(Point { pos: Vec3::new(0.0, 0.0, 1.0), size: 1.0, normal: Vec3::Z, color: Vec4::ONE, matte: false });
        // Colours out of range, infinite and NaN (clamped lane by lane as
        // `Vec3::clamp` clamps), and on the bytes' rounding edges.
        for (k, color) in [
            Vec4::new(1.5, -0.25, f32::NAN, 1.0),
            Vec4::new(f32::INFINITY, f32::NEG_INFINITY, -0.0, 0.5),
            Vec4::new(0.5 / 255.0, 1.5 / 255.0, 254.5 / 255.0, 1.0),
            Vec4::new(f32::from_bits((127.5f32 / 255.0).to_bits() - 1), 3.0, 0.0, 0.0),
            Vec4::new(0.25, 0.5, 0.75, f32::NAN),
            Vec4::new(0.25, 0.5, 0.75, -2.0),
            Vec4::new(0.25, 0.5, 0.75, f32::INFINITY),
            Vec4::new(0.25, 0.5, 0.75, 254.5 / 255.0),
        ]
        .into_iter()
        .enumerate()
        {
            for pos in [Vec3::new(0.3, -0.2, 0.1), Vec3::new(-2.0, 1.0, 0.0), v.light, Vec3::new(0.0, 0.5, 2.0)] {
                pts.push(Point { pos, size: 1.0, normal: Vec3::Z, color, matte: k % 3 == 0 && pos.x < 0.0 });
            }
        }
        assert!(pts.len().is_multiple_of(4));
        for four in pts.chunks_exact(4) {
            let four = [four[0], four[1], four[2], four[3]];
            assert_eq!(rgba4(v, &four), four.map(|p| p.rgba(v)), "{four:?}");
            compared += 4;
        }
    }
    assert!(compared >= 8000);
}

/// [`unorm4`] gives [`unorm`]'s byte in every lane: sampled `f32`s of
/// `-0.0..=1.0`, and each rounding edge `(k + 0.5) / 255` with its neighbours.
#[test]
fn four_channels_round_as_one_does() {
    let mut vals = vec![-0.0f32, 0.0, 1.0, f32::MIN_POSITIVE, 1e-45];
    let mut bits = 0u32;
    while f32::from_bits(bits) <= 1.0 {
        vals.push(f32::from_bits(bits));
        bits += 997;
    }
    for k in 0..255 {
        let e = (k as f32 + 0.5) / 255.0;
        vals.extend([e, f32::from_bits(e.to_bits() - 1), f32::from_bits(e.to_bits() + 1)]);
    }
    vals.retain(|v| (-0.0..=1.0).contains(v));
    assert!(vals.len() > 1_000_000);
    for four in vals.chunks(4) {
        let v = std::array::from_fn(|i| four.get(i).copied().unwrap_or(0.5));
        assert_eq!(unorm4(Vec4::from_array(v)), v.map(|c| i32::from(unorm(c))), "{v:?}");
    }
}

/// The specular term without `powf` gives `powf`'s bytes: `x^32` in `f64` is
/// within one step of `powf` (and `powf` below 2^-3 within 0..2^-64), and the
/// bytes, over bases and specular colours that put channels on rounding
/// edges, are those of `powf`'s value (sampled: every 4093rd `f32` below 2).
#[test]
fn the_specular_term_without_powf_gives_powf_bytes() {
    let tiny = TINY_SPECULAR;
    assert_eq!(tiny, 2f32.powi(-64));
    let specs = [Vec3::ONE, Vec3::new(0.3, 0.9, 0.05), Vec3::new(-0.5, 2.0, 1e-3)];
    let (mut bits, mut n) = (0u32, 0usize);
    while f32::from_bits(bits) < 2.0 {
        let x = f32::from_bits(bits);
        let p = x.powf(32.0);
        if x >= 0.0625 {
            let s = pow32(x);
            assert!(p == s || p == s.next_up() || p == s.next_down(), "{x:e}: {p:e} {s:e}");
        }
        if x < 0.125 {
            assert!((0.0..=tiny).contains(&p), "{x:e}: {p:e}");
        }
        // Bases whose channels fall on and next to rounding edges.
        let k = (bits % 255) as f32;
        let edge = (k + 0.5) / 255.0;
        let base = Vec3::new(edge, f32::from_bits(edge.to_bits() - 1), (k + 0.5 - 1e-3) / 255.0);
        for spec in specs {
            let rgb = |s: f32| (base + s * spec).clamp(Vec3::ZERO, Vec3::ONE);
            assert_eq!(specular_bytes(x, 32.0, rgb), bytes(rgb(p)), "{x:e} {base} {spec}");
            assert_eq!(specular_bytes(x, 20.0, rgb), bytes(rgb(x.powf(20.0))), "{x:e}");
        }
        bits += 4093;
        n += 1;
    }
    assert!(n > 250_000);
}

#[test]
fn a_small_square_becomes_a_point_of_its_area_and_colour_and_a_big_one_stays() {
    let (s, facets) = square();
    // 0.4 units → 2 pixels across: a point of 2 × 2 pixels in the lit colour
    // (the light is at the eye: full Lambert, matte, so 0.15 + 0.85 = 1 × red).
    let mut records = record(Mat3::from_diagonal(Vec3::splat(0.4)), Vec3::ZERO, [0.8, 0.2, 0.0, 1.0]);
    // 4 units → 20 pixels: kept as a mesh.
    records.extend(record(Mat3::from_diagonal(Vec3::splat(4.0)), Vec3::new(1.0, 0.0, 0.0), [0.0; 4]));
    let sel = select(&view(), &[draw(2)], &[s], &facets, &records, 1);
    assert_eq!(sel.n_points(), 1);
    assert_eq!(sel.kept, vec![vec![1]]);
    let (p, size, c) = point(&sel, 0);
    assert!(p.length() < 1e-6, "{p}");
    assert!((size - 2.0).abs() < 1e-3, "size {size}");
    assert_eq!(c, [204, 51, 0, 255]);
}

#[test]
fn a_mirrored_or_turned_instance_keeps_its_projected_area() {
    let (s, facets) = square();
    let small = Mat3::from_diagonal(Vec3::splat(0.4));
    let mirrored = Mat3::from_diagonal(Vec3::new(-0.4, 0.4, 0.4));
    // Turned 60° about x: seen at cos 60° = half its area.
    let turned = Mat3::from_rotation_x(std::f32::consts::FRAC_PI_3) * small;
    let edge_on = Mat3::from_rotation_x(std::f32::consts::FRAC_PI_2) * small;
    let mut records = Vec::new();
    for l in [small, mirrored, turned, edge_on] {
        records.extend(record(l, Vec3::ZERO, [0.5, 0.5, 0.5, 1.0]));
    }
    let sel = select(&view(), &[draw(4)], &[s], &facets, &records, 1);
    // Edge-on, it is as thin as can be: a mesh (which covers next to nothing).
    assert_eq!(sel.n_points(), 3);
    assert_eq!(sel.kept, vec![vec![3]]);
    let sizes: Vec<f32> = (0..3).map(|k| point(&sel, k).1).collect();
    assert!((sizes[0] - 2.0).abs() < 1e-3 && (sizes[1] - 2.0).abs() < 1e-3, "{sizes:?}");
    assert!((sizes[2] * sizes[2] - 2.0).abs() < 0.05, "half of 4 px²: {sizes:?}");
    // Two-sided: the mirrored square (seen from behind as wound) is lit the same.
    assert_eq!(point(&sel, 0).2, point(&sel, 1).2);
}

#[test]
fn a_thin_instance_stays_a_mesh_unless_it_is_tiny() {
    // A 0.05 × 1 strip: 5 pixels long and a quarter of a pixel wide (a mesh),
    // then 0.75 pixels long (a point).
    let s = StandIn { first_facet: 0, n_facets: 1, centre: Vec3::ZERO, radius: 0.5, closed: false };
    let facets =
        vec![Facet { area: Vec3::Z * 0.05, centre: Vec3::ZERO, normal: Vec3::Z, delta: [0.0; 4], matte: true }];
    let mut records = record(Mat3::IDENTITY, Vec3::ZERO, [1.0; 4]);
    records.extend(record(Mat3::from_diagonal(Vec3::splat(0.15)), Vec3::ZERO, [1.0; 4]));
    let sel = select(&view(), &[draw(2)], &[s], &facets, &records, 1);
    assert_eq!(sel.kept, vec![vec![0]]);
    assert_eq!(sel.n_points(), 1);
    // In a 3-D model, open meshes are never points.
    let sel = select(&View { flat: false, ..view() }, &[draw(2)], &[s], &facets, &records, 1);
    assert_eq!(sel.kept, vec![vec![0, 1]]);
}

#[test]
fn a_closed_box_shows_its_front_faces_and_the_choice_is_the_same_on_any_number_of_threads() {
    // A unit cube: six faces of area 1.
    let facets: Vec<Facet> = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
        .map(|n| Facet { area: n, centre: n * 0.5, normal: n, delta: [0.0; 4], matte: false })
        .to_vec();
    let s = StandIn { first_facet: 0, n_facets: 6, centre: Vec3::ZERO, radius: 0.75f32.sqrt(), closed: true };
    let mut records = Vec::new();
    let n = 40_000u32;
    for i in 0..n {
        let t = Vec3::new((i % 200) as f32 * 0.01 - 1.0, (i / 200) as f32 * 0.01 - 1.0, 0.0);
        records.extend(record(Mat3::from_diagonal(Vec3::splat(0.2)), t, [0.2, 0.4, 0.6, 1.0]));
    }
    let one = select(&view(), &[draw(n)], &[s], &facets, &records, 1);
    let four = select(&view(), &[draw(n)], &[s], &facets, &records, 4);
    assert_eq!(one, four);
    assert_eq!(one.n_kept(), 0);
    // Seen from the front: the +z face, 0.2² units² = 1 px² at depth 10 (a
    // little more, its centre being nearer), then the sides that face the eye
    // (perspective), never the back (−z) face.
    let mut total = 0.0;
    let mut fronts = 0;
    for (p, size, _) in points_of(&one) {
        assert!(p.z > -0.1 + 1e-6, "a back face drawn: {p}");
        if (p.z - 0.1).abs() < 1e-6 {
            assert!(size * size > 0.999 && size * size < 1.1, "{size}");
            fronts += 1;
        }
        total += size * size;
    }
    assert_eq!(fronts, n);
    let per_box = total / n as f32;
    assert!(per_box > 1.0 && per_box < 1.3, "{per_box} px² a box");
}

/// A closed unit cube's six facets, not matte, with colour deltas.
fn cube() -> (StandIn, Vec<Facet>) {
    let s = StandIn { first_facet: 0, n_facets: 6, centre: Vec3::ZERO, radius: 0.75f32.sqrt(), closed: true };
    let facets = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
        .into_iter()
        .enumerate()
        .map(|(k, n)| Facet {
            area: n,
            centre: n * 0.5,
            normal: n,
            delta: [0.01 * k as f32, 0.0, 0.0, 0.0],
            matte: false,
        })
        .collect();
    (s, facets)
}

/// A run's oriented facets give every instance of the run the points
/// `stand_in_points` gives it alone, bit for bit: turned, scaled, mirrored and
/// singular linear parts, squares and cubes, at several places.
#[test]
fn oriented_facets_give_the_same_points_as_the_instance_alone() {
    let v = view();
    let turned = Mat3::from_quat(glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1));
    let linears = [
        Mat3::IDENTITY,
        Mat3::from_diagonal(Vec3::splat(0.37)),
        turned * 0.2,
        Mat3::from_diagonal(Vec3::new(-0.3, 0.3, 0.3)) * turned,
        Mat3::from_diagonal(Vec3::new(0.4, 0.1, 0.0)),
    ];
    let places = [Vec3::ZERO, Vec3::new(1.3, -2.1, 0.4), Vec3::new(-3.7, 0.25, -1.5), Vec3::new(0.1, 0.1, 8.0)];
    let color = Vec4::new(0.2, 0.5, 0.9, 1.0);
    let mut o = Oriented::default();
    let (mut alone, mut shared) = (Vec::new(), Vec::new());
    let mut compared = 0;
    for (s, facets) in [square(), cube()] {
        for l in linears {
            o.set(l, &facets);
            for t in places {
                let at = Placed::new(&v, &s, l, t);
                let a = stand_in_points(&v, &s, &facets, l, t, color, &at, &mut alone);
                let b = stand_in_points_oriented(&v, &s, &facets, &o, t, color, &at, &mut shared);
                assert_eq!(a, b, "{l:?} {t}");
                let bits = |p: &[Point]| {
                    p.iter()
                        .map(|p| (p.pos.to_array().map(f32::to_bits), p.size.to_bits(), p.rgba(&v)))
                        .collect::<Vec<_>>()
                };
                assert_eq!(bits(&alone), bits(&shared), "{l:?} {t}");
                compared += alone.len();
            }
        }
    }
    assert!(compared > 40, "{compared} points compared");
}
