//! Flat paths: the path a rule definition builds with `MOVETO`/`LINETO`/`ARCTO`/
//! `CURVETO`/`CLOSEPOLY` and paints with `FILL`/`STROKE` (reference §9, "Flat
//! paths"). The points are kept in world space as they are made; a paint maps
//! them into the plane of the frame it is called in (before its own adjustment),
//! fills or strokes them there ([`crate::geom::path`]) and draws the triangles
//! under its adjusted frame, so `FILL {y 2}` draws the path moved as Context
//! Free's does.

use super::*;
use crate::bundle::ops::path_bits as bits;
use crate::geom::path::{self as kernel, Cap, FillRule, Join, P2};

/// The path being built (one for the run: Context Free's paths are built and
/// painted within one definition).
#[derive(Default)]
pub(super) struct PathState {
    /// Subpaths: world points, and whether `CLOSEPOLY` closed it.
    subs: Vec<(Vec<Vec3>, bool)>,
    /// A paint happened since the last op: the next op starts a new path (a FILL
    /// then a STROKE paint the same one).
    painted: bool,
    /// The last curve's last control point (world), for `smooth` curves.
    last_ctrl: Option<Vec3>,
    /// How many subpath activations are running (a path's calls of paths): a
    /// path's implied `FILL` paints only outside them.
    pub(super) subpaths: u32,
}

impl PathState {
    /// The current point and whether a subpath is open to extend.
    fn current(&self) -> Option<Vec3> {
        match self.subs.last() {
            Some((p, false)) => p.last().copied(),
            _ => None,
        }
    }
}

fn local(inv: Option<&Affine>, p: Vec3) -> P2 {
    let q = inv.map_or(p, |i| i.apply_point(p));
    [f64::from(q.x), f64::from(q.y)]
}

fn world(a: &Affine, p: P2) -> Vec3 {
    a.apply_point(Vec3::new(p[0] as f32, p[1] as f32, 0.0))
}

impl<'b> Eval<'b> {
    /// One flat path op with its arguments (see [`crate::bundle::ops::path_arity`]):
    /// `base` is the state before the op's adjustment, `s` after.
    pub(super) fn path_op(&mut self, kind: Drawable, base: &State, s: &State, args: &[f64], bone: u32, pc: u32) {
        let flags = args.last().map_or(0, |f| *f as u32);
        let arg = |i: usize| args.get(i).copied().unwrap_or(0.0);
        if matches!(kind, Drawable::Fill | Drawable::Stroke) {
            // A subpath's points stay for the calling path to paint.
            if flags & bits::IMPLIED != 0 && self.path.subpaths > 0 {
                return;
            }
            self.path.painted = true;
            self.paint(kind, base, s, arg(0), flags, bone, pc);
            return;
        }
        if std::mem::take(&mut self.path.painted) {
            self.path.subs.clear();
            self.path.last_ctrl = None;
        }
        let a = self.lins.affine(s);
        let inv = a.inverse();
        // The start of a segment (and the origin of relative ops): the current
        // point; after a closed subpath its start; with no subpath the frame's
        // origin before the adjustment (an implied `MOVETO`).
        let start = match (self.path.current(), self.path.subs.last()) {
            (Some(p), _) => p,
            (None, Some((pts, true))) => pts.first().copied().unwrap_or(base.f.u),
            (None, _) => self.lins.affine(base).f.u,
        };
        let p0 = local(inv.as_ref(), start);
        // `MOVEREL`, `LINEREL`, `ARCREL`, `CURVEREL`: the point and the control
        // points are offsets from the start (an arc's radii and angle are not).
        let rel = flags & bits::REL != 0;
        let pt = |i: usize| if rel { [p0[0] + arg(i), p0[1] + arg(i + 1)] } else { [arg(i), arg(i + 1)] };
        if kind == Drawable::MoveTo {
            self.path.subs.push((vec![world(&a, pt(0))], false));
            self.path.last_ctrl = None;
            return;
        }
        if kind == Drawable::ClosePoly {
            if let Some((p, closed)) = self.path.subs.last_mut() {
                if !*closed && p.len() > 1 {
                    if flags & bits::ALIGN != 0 {
                        if let Some(first) = p.first().copied() {
                            if let Some(last) = p.last_mut() {
                                *last = first;
                            }
                        }
                    }
                    *closed = true;
                }
            }
            self.path.last_ctrl = None;
            return;
        }
        // A segment from the start; a new subpath there unless one is open.
        if self.path.current().is_none() {
            self.path.subs.push((vec![start], false));
        }
        let p1 = pt(0);
        let mut pts = Vec::new();
        match kind {
            Drawable::LineTo => {
                pts.push(p1);
                self.path.last_ctrl = None;
            }
            Drawable::ArcTo => {
                let (large, cw) = (flags & bits::LARGE != 0, flags & bits::CW != 0);
                kernel::arc(p0, p1, arg(2), arg(3), arg(4), large, cw, &mut pts);
                if pts.is_empty() {
                    pts.push(p1);
                }
                self.path.last_ctrl = None;
            }
            Drawable::CurveTo => {
                // The reflection of the last curve's control point (the current
                // point itself after anything but a curve).
                let mirrored = || {
                    let c = self.path.last_ctrl.map_or(p0, |c| local(inv.as_ref(), c));
                    [2.0 * p0[0] - c[0], 2.0 * p0[1] - c[1]]
                };
                let (smooth, cubic) = (flags & bits::SMOOTH != 0, flags & bits::CUBIC != 0);
                let last = match (smooth, cubic) {
                    (false, false) => {
                        let c = pt(2);
                        kernel::quadratic(p0, c, p1, &mut pts);
                        c
                    }
                    (false, true) => {
                        let c2 = pt(4);
                        kernel::cubic(p0, pt(2), c2, p1, &mut pts);
                        c2
                    }
                    (true, false) => {
                        let c = mirrored();
                        kernel::quadratic(p0, c, p1, &mut pts);
                        c
                    }
                    (true, true) => {
                        let c2 = pt(2);
                        kernel::cubic(p0, mirrored(), c2, p1, &mut pts);
                        c2
                    }
                };
                self.path.last_ctrl = Some(world(&a, last));
            }
            _ => {}
        }
        if let Some((sub, _)) = self.path.subs.last_mut() {
            sub.extend(pts.into_iter().map(|p| world(&a, p)));
        }
    }

    /// `FILL`/`STROKE`: the path's triangles, in the plane of `base`, drawn under `s`.
    #[allow(clippy::too_many_arguments)]
    fn paint(&mut self, kind: Drawable, base: &State, s: &State, width: f64, flags: u32, bone: u32, pc: u32) {
        if !self.path.subs.iter().any(|(p, _)| p.len() > 1) {
            return;
        }
        let (ab, a) = (self.lins.affine(base), self.lins.affine(s));
        let Some(inv) = ab.inverse() else { return };
        let lines: Vec<(Vec<P2>, bool)> = self
            .path
            .subs
            .iter()
            .map(|(p, closed)| (p.iter().map(|q| local(Some(&inv), *q)).collect(), *closed))
            .collect();
        let mut tris = Vec::new();
        if kind == Drawable::Fill {
            let rule = if flags & bits::EVENODD != 0 { FillRule::EvenOdd } else { FillRule::NonZero };
            let contours: Vec<Vec<P2>> = lines.into_iter().map(|(p, _)| p).collect();
            kernel::fill(&contours, rule, &mut tris);
        } else {
            let join = if flags & bits::ROUNDJOIN != 0 {
                Join::Round
            } else if flags & bits::BEVELJOIN != 0 {
                Join::Bevel
            } else {
                Join::Miter
            };
            let cap = if flags & bits::ROUNDCAP != 0 {
                Cap::Round
            } else if flags & bits::SQUARECAP != 0 {
                Cap::Square
            } else {
                Cap::Butt
            };
            if width.is_nan() || width <= 0.0 || !width.is_finite() {
                let at = self.b.source_of(pc).map(|(f, l)| format!("{f}:{l}: ")).unwrap_or_default();
                let w = &mut self.out.stats.warnings;
                if !w.iter().any(|m| m.starts_with(&at) && m.contains("STROKE")) {
                    w.push(format!("{at}STROKE with width {width}: nothing drawn (the width must be above 0)"));
                }
                return;
            }
            if flags & bits::ISO != 0 {
                return self.paint_iso(&lines, &a, s, width, (join, cap), bone);
            }
            kernel::stroke(&lines, width, join, cap, &mut tris);
        }
        self.emit_path(&tris, &|p| world(&a, p), &a, s, bone);
    }

    /// A `STROKE … iso` (Context Free's `CF::IsoWidth`): the path (`lines`, in
    /// `base`'s plane `ab`) is taken through the adjusted frame `a` into the plane
    /// it is drawn in, whose own orthonormal axes (the image of x, and the part of
    /// the image of y across it) carry the stroke, `width · √(area scale)` wide: a
    /// round pen of the frame's mean size, as Context Free strokes after the
    /// transform with `w·√|det|`.
    #[allow(clippy::too_many_arguments)]
    fn paint_iso(
        &mut self,
        lines: &[(Vec<P2>, bool)],
        a: &Affine,
        s: &State,
        width: f64,
        (join, cap): (Join, Cap),
        bone: u32,
    ) {
        let o = world(a, [0.0, 0.0]);
        let (ex, ey) = (world(a, [1.0, 0.0]) - o, world(a, [0.0, 1.0]) - o);
        let area = f64::from(ex.cross(ey).length());
        let Some(u) = ex.try_normalize() else { return };
        let Some(v) = (ey - u * ey.dot(u)).try_normalize() else { return };
        let plane = |q: Vec3| -> P2 {
            let d = q - o;
            [f64::from(d.dot(u)), f64::from(d.dot(v))]
        };
        let moved: Vec<(Vec<P2>, bool)> =
            lines.iter().map(|(p, closed)| (p.iter().map(|q| plane(world(a, *q))).collect(), *closed)).collect();
        let mut tris = Vec::new();
        kernel::stroke(&moved, width * area.sqrt(), join, cap, &mut tris);
        let back = |p: P2| o + u * p[0] as f32 + v * p[1] as f32;
        self.emit_path(&tris, &back, a, s, bone);
    }

    /// A paint's triangles (`to_world` places their points), counted and drawn
    /// under `s` with the frame `a`'s normal.
    fn emit_path(&mut self, tris: &[[P2; 3]], to_world: &dyn Fn(P2) -> Vec3, a: &Affine, s: &State, bone: u32) {
        self.out.stats.paths += 1;
        if tris.is_empty() || !self.room_for(3 * tris.len()) {
            return;
        }
        self.out.stats.path_triangles += tris.len() as u64;
        let n = a.apply_normal(Vec3::from_array(self.b.settings.normal));
        let (color, mirrored) = (s.display_color(), s.mirrored());
        let m = &mut self.out.mesh;
        let first = m.n_vertices();
        for t in tris {
            let k = m.n_vertices() as u32;
            for p in t {
                m.push_vertex(to_world(*p), n, color, s.weight, bone);
            }
            m.push_triangle([k, k + 1, k + 2], mirrored);
        }
        // Flat art, like std `flat`'s primitives: no specular highlight.
        m.mark_matte(first..m.n_vertices());
        self.check_budgets();
    }
}
