//! The guides being edited: picking a control point or a curve by its distance on
//! screen, dragging a point in the view plane, drawing a new guide as a stroke
//! (fitted with [`super::fit`]), deleting one, tuning the selected guide's cost
//! parameters, undo and redo, the JSON that `mdg-run --guides` reads, and the
//! overlay lines that show all of it.
//!
//! Plain Rust: positions on screen come in as pixels with the [`ScreenView`] they
//! were seen in; nothing here knows about windows or the GPU.

use super::fit::{self, fit_stroke};
use super::project::{distance_to_segment, ScreenView};
use glam::{DVec2, DVec3};
use mdg_guided::{Guide, DEFAULT_SCALE_D, MAX_GUIDE_COORD};
use mdg_vm::output::Polyline;

/// How near (pixels) the cursor must be to a control point to pick it.
pub const PICK_POINT_PX: f64 = 10.0;
/// How near (pixels) the cursor must be to a curve to select its guide.
pub const PICK_CURVE_PX: f64 = 6.0;
/// A stroke's points are kept this far apart (pixels) at least.
pub const STROKE_SPACING_PX: f64 = 3.0;
/// A stroke shorter than this (pixels, along its points) draws nothing.
pub const MIN_STROKE_PX: f64 = 12.0;
/// How far (pixels) the fitted guide may be from the stroke's points.
pub const STROKE_TOLERANCE_PX: f64 = 6.0;
/// The most cubic segments a drawn guide gets (the tolerance is relaxed until it
/// fits): guides are meant to be coarse (paper §4.2).
pub const MAX_STROKE_SEGMENTS: usize = 6;
/// Undo snapshots kept.
pub const MAX_UNDO: usize = 200;
/// Points per cubic segment in the overlay (as `mdg-run` draws guides).
pub const CURVE_POINTS: usize = 24;

/// Why an edit was not made (said in the log; the guides are unchanged).
#[derive(Clone, Debug, PartialEq)]
pub enum EditError {
    /// No guide is selected.
    NothingSelected,
    /// The last guide cannot be deleted: a search needs one.
    LastGuide,
    /// [`Editor::end_stroke`] without a stroke being drawn.
    NoStroke,
    /// The stroke is shorter than [`MIN_STROKE_PX`] (its length in pixels).
    StrokeTooShort { length_px: f64 },
    /// No chain of at most [`MAX_STROKE_SEGMENTS`] curves fits the stroke.
    NotFitted,
    /// The guide an edit would make is not valid: the guide's label (`None`: a
    /// drawn one) and why.
    Invalid { label: Option<String>, why: String },
}

impl std::fmt::Display for EditError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EditError::NothingSelected => write!(f, "no guide is selected (Tab or a click selects one)"),
            EditError::LastGuide => write!(f, "the last guide cannot be deleted: the search needs one"),
            EditError::NoStroke => write!(f, "no stroke is being drawn"),
            EditError::StrokeTooShort { length_px } => {
                write!(f, "the stroke is too short ({length_px:.0} px; draw at least {MIN_STROKE_PX:.0} px)")
            }
            EditError::NotFitted => write!(f, "the stroke could not be fitted with a curve"),
            EditError::Invalid { label: None, why } => write!(f, "the drawn guide is not valid: {why}"),
            EditError::Invalid { label: Some(label), why } => write!(f, "{label}: {why}"),
        }
    }
}

impl std::error::Error for EditError {}

/// Overlay namespace of the guides that are not selected (amber in the viewer).
pub const NS_GUIDES: &str = "guides";
/// Overlay namespace of the selected guide and a stroke being drawn.
pub const NS_SELECTED: &str = "guide_selected";
/// Overlay namespace of the control-point markers and the selected guide's handles.
pub const NS_POINTS: &str = "guide_points";

/// A cost parameter of a guide that the keys tune.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Param {
    DeltaA,
    ScaleA,
    ScaleD,
    ScaleU,
    Segment,
}

impl Param {
    /// In the order `T` cycles through them (and keys `1`–`5` choose).
    pub const ALL: [Param; 5] = [Param::DeltaA, Param::ScaleA, Param::ScaleD, Param::ScaleU, Param::Segment];

    /// The key's name in guide files.
    pub fn name(self) -> &'static str {
        match self {
            Param::DeltaA => "delta_a",
            Param::ScaleA => "scale_a",
            Param::ScaleD => "scale_d",
            Param::ScaleU => "scale_u",
            Param::Segment => "segment",
        }
    }

    /// The next (or, with `back`, previous) parameter, cyclically.
    pub fn cycled(self, back: bool) -> Param {
        let i = Param::ALL.iter().position(|p| *p == self).unwrap_or(0);
        let n = Param::ALL.len();
        Param::ALL[if back { (i + n - 1) % n } else { (i + 1) % n }]
    }

    /// `name value` for the title bar.
    pub fn describe(self, g: &Guide) -> String {
        let v = match self {
            Param::DeltaA => format!("{:.2}", g.delta_a),
            Param::ScaleA => format!("{:.3}", g.scale_a),
            Param::ScaleD => format!("{:.3} {:.3} {:.3}", g.scale_d[0], g.scale_d[1], g.scale_d[2]),
            Param::ScaleU => format!("{:.3}", g.scale_u),
            Param::Segment => format!("{:.3}", g.segment),
        };
        format!("{} {v}", self.name())
    }

    /// `g` with this parameter moved by `steps` steps: `delta_a` by 0.05 within
    /// [−1, 1]; the multipliers (`scale_a`, `scale_u`, all three `scale_d` terms) and
    /// `segment` by a factor of 1.1 per step — a multiplier that is 0 starts again at
    /// a tenth of its default, one below 0.001 becomes 0, and `segment` stays within
    /// [0.02, 100].
    pub fn stepped(self, g: &Guide, steps: f64) -> Guide {
        let factor = 1.1f64.powf(steps);
        let scaled = |v: f64, default: f64| {
            if v == 0.0 {
                if steps > 0.0 {
                    default * 0.1
                } else {
                    0.0
                }
            } else {
                let w = v * factor;
                if w.abs() < 1e-3 {
                    0.0
                } else {
                    w
                }
            }
        };
        let mut out = g.clone();
        match self {
            Param::DeltaA => out.delta_a = ((g.delta_a + 0.05 * steps) * 100.0).round().clamp(-100.0, 100.0) / 100.0,
            Param::ScaleA => out.scale_a = scaled(g.scale_a, mdg_guided::DEFAULT_SCALE_A),
            Param::ScaleU => out.scale_u = scaled(g.scale_u, mdg_guided::DEFAULT_SCALE_U),
            Param::ScaleD => {
                if g.scale_d.iter().all(|v| *v == 0.0) {
                    if steps > 0.0 {
                        out.scale_d = DEFAULT_SCALE_D.map(|d| d * 0.1);
                    }
                } else {
                    out.scale_d = g.scale_d.map(|d| if (d * factor).abs() < 1e-3 { 0.0 } else { d * factor });
                }
            }
            Param::Segment => out.segment = (g.segment * factor).clamp(0.02, 100.0),
        }
        out
    }
}

/// What is under the cursor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pick {
    /// A control point (guide and point indices).
    Point { guide: usize, point: usize },
    /// A guide's curve, away from its control points.
    Curve { guide: usize },
}

/// A gesture in progress.
#[derive(Clone, Debug)]
enum Gesture {
    None,
    /// Dragging a control point: where the cursor grabbed it relative to the point
    /// (so the point does not jump under the cursor), and whether it moved.
    Drag {
        guide: usize,
        point: usize,
        grab: DVec3,
        moved: bool,
    },
    /// Drawing a stroke on the view plane through `plane`.
    Stroke {
        points: Vec<DVec3>,
        pixels: Vec<DVec2>,
        plane: DVec3,
    },
}

/// The guides being edited.
#[derive(Clone, Debug)]
pub struct Editor {
    guides: Vec<Guide>,
    selected: Option<usize>,
    param: Param,
    undo: Vec<Vec<Guide>>,
    redo: Vec<Vec<Guide>>,
    gesture: Gesture,
    /// Bumped by every change of the guides (not of the selection).
    revision: u64,
    /// Guides drawn so far (for their names).
    drawn: usize,
}

fn v(p: [f64; 3]) -> DVec3 {
    DVec3::from_array(p)
}

/// Points along a guide's Bézier chain, `per` per segment plus the last.
pub fn curve_points(g: &Guide, per: usize) -> Vec<DVec3> {
    let per = per.max(1);
    let mut pts = Vec::new();
    for w in g.points.windows(4).step_by(3) {
        let c = [v(w[0]), v(w[1]), v(w[2]), v(w[3])];
        for k in 0..per {
            pts.push(fit::point_at(&c, k as f64 / per as f64));
        }
    }
    if let Some(last) = g.points.last() {
        pts.push(v(*last));
    }
    pts
}

impl Editor {
    /// Editing `guides` (valid ones: from a `guide` section or a checked file).
    pub fn new(guides: Vec<Guide>) -> Editor {
        Editor {
            guides,
            selected: None,
            param: Param::DeltaA,
            undo: Vec::new(),
            redo: Vec::new(),
            gesture: Gesture::None,
            revision: 0,
            drawn: 0,
        }
    }

    pub fn guides(&self) -> &[Guide] {
        &self.guides
    }

    /// The selected guide's index.
    pub fn selected(&self) -> Option<usize> {
        self.selected
    }

    /// The parameter the keys tune.
    pub fn param(&self) -> Param {
        self.param
    }

    /// Changes with every edit of the guides.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    pub fn is_dragging(&self) -> bool {
        matches!(self.gesture, Gesture::Drag { .. })
    }

    pub fn is_drawing(&self) -> bool {
        matches!(self.gesture, Gesture::Stroke { .. })
    }

    /// Saves the guides for undo (before a change) and forgets the redo history.
    fn checkpoint(&mut self) {
        self.undo.push(self.guides.clone());
        if self.undo.len() > MAX_UNDO {
            self.undo.remove(0);
        }
        self.redo.clear();
    }

    fn changed(&mut self) {
        self.revision += 1;
        if self.selected.is_some_and(|s| s >= self.guides.len()) {
            self.selected = None;
        }
    }

    /// Where guide `guide`'s control point `point` is drawn in `view`.
    pub fn point_on_screen(&self, view: &ScreenView, guide: usize, point: usize) -> Option<DVec2> {
        let p = self.guides.get(guide)?.points.get(point)?;
        view.to_screen(v(*p))
    }

    /// The control point nearest to `px` within [`PICK_POINT_PX`] (the selected
    /// guide's first on ties), else the guide whose curve passes within
    /// [`PICK_CURVE_PX`].
    pub fn pick(&self, view: &ScreenView, px: DVec2) -> Option<Pick> {
        let mut best: Option<(f64, Pick)> = None;
        let order = self.selected.into_iter().chain((0..self.guides.len()).filter(|i| Some(*i) != self.selected));
        for gi in order {
            for (pi, p) in self.guides[gi].points.iter().enumerate() {
                if let Some(s) = view.to_screen(v(*p)) {
                    let d = (s - px).length();
                    if d <= PICK_POINT_PX && best.is_none_or(|(b, _)| d < b) {
                        best = Some((d, Pick::Point { guide: gi, point: pi }));
                    }
                }
            }
        }
        if best.is_some() {
            return best.map(|(_, p)| p);
        }
        for (gi, g) in self.guides.iter().enumerate() {
            let screen: Vec<Option<DVec2>> =
                curve_points(g, CURVE_POINTS).into_iter().map(|p| view.to_screen(p)).collect();
            for w in screen.windows(2) {
                if let (Some(a), Some(b)) = (w[0], w[1]) {
                    let d = distance_to_segment(px, a, b);
                    if d <= PICK_CURVE_PX && best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, Pick::Curve { guide: gi }));
                    }
                }
            }
        }
        best.map(|(_, p)| p)
    }

    /// Selects a guide (or none).
    pub fn select(&mut self, guide: Option<usize>) {
        self.selected = guide.filter(|g| *g < self.guides.len());
    }

    /// Selects the next guide (the first when none is).
    pub fn select_next(&mut self) {
        let n = self.guides.len();
        if n > 0 {
            self.selected = Some(self.selected.map_or(0, |s| (s + 1) % n));
        }
    }

    /// Starts dragging `guide`'s control point `point`, grabbed at pixel `px`
    /// (it selects the guide). Returns false if there is no such point or the
    /// view plane cannot be reached.
    pub fn begin_drag(&mut self, view: &ScreenView, px: DVec2, guide: usize, point: usize) -> bool {
        let Some(p) = self.guides.get(guide).and_then(|g| g.points.get(point)).map(|p| v(*p)) else {
            return false;
        };
        let Some(under) = view.on_view_plane(px, p) else { return false };
        self.checkpoint();
        self.selected = Some(guide);
        self.gesture = Gesture::Drag { guide, point, grab: p - under, moved: false };
        true
    }

    /// Moves the dragged point to follow the cursor at `px` in the view plane
    /// through the point. Returns whether the guides changed.
    pub fn drag_to(&mut self, view: &ScreenView, px: DVec2) -> bool {
        let Gesture::Drag { guide, point, grab, moved } = &mut self.gesture else { return false };
        let Some(current) = self.guides.get(*guide).and_then(|g| g.points.get(*point)).map(|p| v(*p)) else {
            return false;
        };
        let Some(under) = view.on_view_plane(px, current) else { return false };
        let new = under + *grab;
        if !new.is_finite() || new.abs().max_element() > MAX_GUIDE_COORD || new == current {
            return false;
        }
        *moved = true;
        let (g, i) = (*guide, *point);
        self.guides[g].points[i] = new.to_array();
        self.changed();
        true
    }

    /// Ends a drag. Returns whether the point moved (if it did not, the undo
    /// snapshot taken at its start is dropped).
    pub fn end_drag(&mut self) -> bool {
        let Gesture::Drag { moved, .. } = std::mem::replace(&mut self.gesture, Gesture::None) else { return false };
        if !moved {
            self.undo.pop();
        }
        moved
    }

    /// Starts drawing a stroke at `px` on the view plane through `plane`.
    pub fn begin_stroke(&mut self, view: &ScreenView, px: DVec2, plane: DVec3) -> bool {
        let Some(p) = view.on_view_plane(px, plane) else { return false };
        self.gesture = Gesture::Stroke { points: vec![p], pixels: vec![px], plane };
        true
    }

    /// Adds the cursor position `px` to the stroke (if it is far enough from the
    /// last point). Returns whether it was added.
    pub fn extend_stroke(&mut self, view: &ScreenView, px: DVec2) -> bool {
        let Gesture::Stroke { points, pixels, plane } = &mut self.gesture else { return false };
        if pixels.last().is_some_and(|l| (*l - px).length() < STROKE_SPACING_PX) {
            return false;
        }
        let Some(p) = view.on_view_plane(px, *plane) else { return false };
        points.push(p);
        pixels.push(px);
        true
    }

    /// Ends the stroke: fits it with a Bézier chain (within
    /// [`STROKE_TOLERANCE_PX`] pixels, at most [`MAX_STROKE_SEGMENTS`] segments) and
    /// adds it as a new guide with the default parameters, selected. Returns its
    /// index, or why nothing was added.
    pub fn end_stroke(&mut self, view: &ScreenView) -> Result<usize, EditError> {
        let Gesture::Stroke { points, pixels, plane } = std::mem::replace(&mut self.gesture, Gesture::None) else {
            return Err(EditError::NoStroke);
        };
        let length_px: f64 = pixels.windows(2).map(|w| (w[1] - w[0]).length()).sum();
        if length_px < MIN_STROKE_PX {
            return Err(EditError::StrokeTooShort { length_px });
        }
        let mut tolerance = STROKE_TOLERANCE_PX * view.world_per_pixel(plane).max(1e-9);
        let mut fitted = None;
        for _ in 0..16 {
            match fit_stroke(&points, tolerance) {
                Some(cps) if (cps.len() - 1) / 3 <= MAX_STROKE_SEGMENTS => {
                    fitted = Some(cps);
                    break;
                }
                Some(_) => tolerance *= 2.0,
                None => break,
            }
        }
        let Some(cps) = fitted else { return Err(EditError::NotFitted) };
        self.drawn += 1;
        let mut name = format!("drawn {}", self.drawn);
        while self.guides.iter().any(|g| g.name == name) {
            self.drawn += 1;
            name = format!("drawn {}", self.drawn);
        }
        let guide = Guide::new(&name, cps.iter().map(|p| p.to_array()).collect());
        guide.validate().map_err(|why| EditError::Invalid { label: None, why: why.to_string() })?;
        self.checkpoint();
        self.guides.push(guide);
        self.selected = Some(self.guides.len() - 1);
        self.changed();
        Ok(self.guides.len() - 1)
    }

    /// The stroke's points so far (empty when not drawing).
    pub fn stroke(&self) -> &[DVec3] {
        match &self.gesture {
            Gesture::Stroke { points, .. } => points,
            _ => &[],
        }
    }

    /// Abandons a drag (restoring the point) or a stroke. Returns whether there was
    /// one.
    pub fn cancel_gesture(&mut self) -> bool {
        match std::mem::replace(&mut self.gesture, Gesture::None) {
            Gesture::None => false,
            Gesture::Stroke { .. } => true,
            Gesture::Drag { moved, .. } => {
                if let Some(before) = self.undo.pop() {
                    if moved {
                        self.guides = before;
                        self.changed();
                    }
                }
                true
            }
        }
    }

    /// Deletes the selected guide (not the last one: a search needs a guide).
    /// Returns a message saying what happened.
    pub fn delete_selected(&mut self) -> Result<String, EditError> {
        let Some(s) = self.selected else { return Err(EditError::NothingSelected) };
        if self.guides.len() <= 1 {
            return Err(EditError::LastGuide);
        }
        self.checkpoint();
        let g = self.guides.remove(s);
        self.selected = None;
        self.changed();
        Ok(format!("deleted {}", g.label(s)))
    }

    /// Chooses the parameter the keys tune.
    pub fn set_param(&mut self, p: Param) {
        self.param = p;
    }

    /// Moves the selected guide's parameter by `steps` steps ([`Param::stepped`]).
    /// Returns a message with the new value.
    pub fn step_param(&mut self, steps: f64) -> Result<String, EditError> {
        let Some(s) = self.selected else { return Err(EditError::NothingSelected) };
        let new = self.param.stepped(&self.guides[s], steps);
        if new == self.guides[s] {
            return Ok(format!("{}: {} (unchanged)", new.label(s), self.param.describe(&new)));
        }
        new.validate().map_err(|why| EditError::Invalid { label: Some(new.label(s)), why: why.to_string() })?;
        self.checkpoint();
        self.guides[s] = new;
        self.changed();
        Ok(format!("{}: {}", self.guides[s].label(s), self.param.describe(&self.guides[s])))
    }

    /// Undoes the last change. Returns whether there was one.
    pub fn undo(&mut self) -> bool {
        self.cancel_gesture();
        let Some(before) = self.undo.pop() else { return false };
        self.redo.push(std::mem::replace(&mut self.guides, before));
        self.changed();
        true
    }

    /// Redoes the last undone change. Returns whether there was one.
    pub fn redo(&mut self) -> bool {
        self.cancel_gesture();
        let Some(after) = self.redo.pop() else { return false };
        self.undo.push(std::mem::replace(&mut self.guides, after));
        self.changed();
        true
    }

    /// Replaces every guide (a guide file changed, or the grammar's own guides were
    /// edited in its source); undoable. Returns false when they are the same.
    pub fn replace(&mut self, guides: Vec<Guide>) -> bool {
        if guides == self.guides {
            return false;
        }
        self.cancel_gesture();
        self.checkpoint();
        self.guides = guides;
        self.changed();
        true
    }

    /// The guides as a guide file (`{"guides": [...]}`, every key written, a
    /// control point per `[x, y, z]`, laid out as `std/examples/guides/*.json` are),
    /// the format `mdg-run --guides` and `mdg-view --guides` read.
    pub fn to_json(&self) -> String {
        let num = |v: f64| serde_json::to_string(&v).unwrap_or_else(|_| "0".into());
        let mut out = String::from("{\n  \"guides\": [\n");
        for (i, g) in self.guides.iter().enumerate() {
            let name = serde_json::to_string(&g.name).unwrap_or_else(|_| "\"\"".into());
            let points: Vec<String> =
                g.points.iter().map(|p| format!("[{}, {}, {}]", num(p[0]), num(p[1]), num(p[2]))).collect();
            let d = g.scale_d.map(num);
            out.push_str(&format!(
                "    {{\n      \"name\": {name},\n      \"points\": [{}],\n      \"scale_d\": [{}, {}, {}], \"scale_a\": {}, \
                 \"delta_a\": {}, \"scale_u\": {}, \"segment\": {}\n    }}{}\n",
                points.join(", "),
                d[0],
                d[1],
                d[2],
                num(g.scale_a),
                num(g.delta_a),
                num(g.scale_u),
                num(g.segment),
                if i + 1 < self.guides.len() { "," } else { "" }
            ));
        }
        out.push_str("  ]\n}\n");
        out
    }

    /// The overlay: the guides that are not selected (namespace [`NS_GUIDES`]); the
    /// selected guide and a stroke being drawn ([`NS_SELECTED`]); a cross of
    /// half-size `marker` at every control point and the selected guide's handles
    /// ([`NS_POINTS`]).
    pub fn overlay(&self, marker: f64) -> Vec<Polyline> {
        let f = |p: DVec3| [p.x as f32, p.y as f32, p.z as f32];
        let line = |ns: &str, pts: Vec<DVec3>| Polyline {
            namespace: ns.to_string(),
            points: pts.into_iter().map(f).collect(),
            bones: vec![],
        };
        let mut lines = Vec::new();
        for (i, g) in self.guides.iter().enumerate() {
            let ns = if Some(i) == self.selected { NS_SELECTED } else { NS_GUIDES };
            lines.push(line(ns, curve_points(g, CURVE_POINTS)));
        }
        if let Some(g) = self.selected.and_then(|s| self.guides.get(s)) {
            // The handles: each end point to its neighbouring inner control point.
            for w in g.points.windows(4).step_by(3) {
                lines.push(line(NS_POINTS, vec![v(w[0]), v(w[1])]));
                lines.push(line(NS_POINTS, vec![v(w[2]), v(w[3])]));
            }
        }
        for g in &self.guides {
            for p in &g.points {
                let p = v(*p);
                for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
                    lines.push(line(NS_POINTS, vec![p - axis * marker, p + axis * marker]));
                }
            }
        }
        if let Gesture::Stroke { points, .. } = &self.gesture {
            if points.len() >= 2 {
                lines.push(line(NS_SELECTED, points.clone()));
            }
        }
        lines
    }

    /// A marker size for [`Editor::overlay`]: 1.5% of the guides' extent.
    pub fn marker_size(&self) -> f64 {
        let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
        for p in self.guides.iter().flat_map(|g| &g.points) {
            lo = lo.min(v(*p));
            hi = hi.max(v(*p));
        }
        if lo.x > hi.x {
            return 0.05;
        }
        ((hi - lo).length() * 0.015).max(1e-3)
    }

    /// The selected guide and the parameter the keys tune, for the title bar.
    pub fn status(&self) -> String {
        match self.selected.and_then(|s| self.guides.get(s).map(|g| (s, g))) {
            Some((s, g)) => format!("{}: {}", g.label(s), self.param.describe(g)),
            None => format!("{} guides, none selected", self.guides.len()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Looking along +y at the xz-plane (the std guides' plane), 800 × 600.
    fn front() -> ScreenView {
        crate::guided::project::tests::front_view().0
    }

    fn two_guides() -> Vec<Guide> {
        vec![
            Guide::new("trunk", vec![[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 2.0], [0.0, 0.0, 3.0]]),
            Guide::new("arm", vec![[0.0, 0.0, 2.0], [1.0, 0.0, 2.5], [2.0, 0.0, 3.0], [3.0, 0.0, 4.0]]),
        ]
    }

    #[test]
    fn a_point_is_picked_by_its_screen_distance_and_a_curve_between_points() {
        let view = front();
        let e = Editor::new(two_guides());
        let p = e.point_on_screen(&view, 1, 3).expect("visible");
        assert_eq!(e.pick(&view, p + DVec2::new(4.0, -3.0)), Some(Pick::Point { guide: 1, point: 3 }));
        assert_eq!(e.pick(&view, p + DVec2::new(40.0, 0.0)), None);
        // Halfway between the trunk's points 1 and 2 (z = 1.5): on the curve only.
        let mid = view.to_screen(DVec3::new(0.0, 0.0, 1.5)).expect("visible");
        assert_eq!(e.pick(&view, mid + DVec2::new(3.0, 0.0)), Some(Pick::Curve { guide: 0 }));
        // Points shared by two guides: the selected guide's is taken.
        let mut e = Editor::new(two_guides());
        let shared = e.point_on_screen(&view, 0, 2).expect("visible");
        assert_eq!(e.pick(&view, shared), Some(Pick::Point { guide: 0, point: 2 }));
        e.select(Some(1));
        assert_eq!(e.pick(&view, shared), Some(Pick::Point { guide: 1, point: 0 }));
    }

    #[test]
    fn a_drag_moves_the_point_in_the_view_plane_and_undo_restores_it() {
        let view = front();
        let mut e = Editor::new(two_guides());
        let before = e.guides().to_vec();
        let p = e.point_on_screen(&view, 1, 3).expect("visible");
        // Grab it 2 px off centre: the point keeps that offset from the cursor.
        assert!(e.begin_drag(&view, p + DVec2::new(2.0, 0.0), 1, 3));
        assert_eq!(e.selected(), Some(1));
        assert!(e.drag_to(&view, p + DVec2::new(52.0, -30.0)));
        assert!(e.drag_to(&view, p + DVec2::new(102.0, 0.0)));
        assert!(e.end_drag());
        let moved = DVec3::from_array(e.guides()[1].points[3]);
        // In the view plane (y unchanged), 100 px to the right of where it was.
        assert!((moved.y - 0.0).abs() < 1e-9);
        let now = view.to_screen(moved).expect("visible");
        assert!((now - (p + DVec2::new(100.0, 0.0))).length() < 1e-6, "{now:?} vs {p:?}");
        // Nothing else moved.
        for (g, (a, b)) in before.iter().zip(e.guides()).enumerate() {
            for (i, (pa, pb)) in a.points.iter().zip(&b.points).enumerate() {
                if (g, i) != (1, 3) {
                    assert_eq!(pa, pb);
                }
            }
        }
        let rev = e.revision();
        assert!(e.undo());
        assert_eq!(e.guides(), &before[..]);
        assert!(e.revision() > rev);
        assert!(e.redo());
        assert_eq!(DVec3::from_array(e.guides()[1].points[3]), moved);
        // A press without a move leaves nothing to undo.
        let mut e = Editor::new(two_guides());
        assert!(e.begin_drag(&view, p, 1, 3));
        assert!(!e.end_drag());
        assert!(!e.undo());
    }

    #[test]
    fn a_stroke_becomes_a_selected_guide_on_the_view_plane() {
        let view = front();
        let mut e = Editor::new(two_guides());
        let plane = DVec3::new(0.0, 0.5, 2.0);
        assert!(e.begin_stroke(&view, DVec2::new(300.0, 400.0), plane));
        for k in 1..=40 {
            let t = k as f64 / 40.0;
            e.extend_stroke(&view, DVec2::new(300.0 + 200.0 * t, 400.0 - 250.0 * t * t));
        }
        assert!(!e.stroke().is_empty());
        let i = e.end_stroke(&view).expect("a guide");
        assert_eq!(i, 2);
        assert_eq!(e.selected(), Some(2));
        let g = &e.guides()[2];
        assert_eq!(g.name, "drawn 1");
        g.validate().expect("valid");
        assert!(g.points.len() >= 4 && (g.points.len() - 1).is_multiple_of(3));
        for p in &g.points {
            // On the plane through `plane` facing the camera: y = 0.5.
            assert!((p[1] - 0.5).abs() < 1e-9, "{p:?}");
        }
        // Its ends are where the stroke started and ended.
        let start = view.to_screen(DVec3::from_array(g.points[0])).expect("visible");
        assert!((start - DVec2::new(300.0, 400.0)).length() < 1e-6);
        // A click is not a stroke.
        assert!(e.begin_stroke(&view, DVec2::new(10.0, 10.0), plane));
        assert!(matches!(e.end_stroke(&view), Err(EditError::StrokeTooShort { .. })));
        assert_eq!(e.end_stroke(&view), Err(EditError::NoStroke));
        assert_eq!(e.guides().len(), 3);
    }

    #[test]
    fn delete_parameters_json_and_overlay() {
        let mut e = Editor::new(two_guides());
        assert_eq!(e.delete_selected(), Err(EditError::NothingSelected));
        e.select_next();
        assert_eq!(e.selected(), Some(0));
        e.set_param(Param::DeltaA);
        assert_eq!(e.step_param(1.0).expect("stepped"), "trunk: delta_a 0.65");
        for _ in 0..20 {
            let _ = e.step_param(1.0);
        }
        assert_eq!(e.guides()[0].delta_a, 1.0, "clamped");
        e.set_param(Param::Segment);
        let _ = e.step_param(-100.0);
        assert_eq!(e.guides()[0].segment, 0.02);
        e.set_param(Param::ScaleU);
        let _ = e.step_param(-200.0);
        assert_eq!(e.guides()[0].scale_u, 0.0);
        let _ = e.step_param(1.0);
        assert!((e.guides()[0].scale_u - 0.1).abs() < 1e-12, "a zero multiplier restarts at a tenth");
        let d = Param::ScaleD.stepped(&e.guides()[0], 1.0).scale_d;
        assert!(d[0] == 0.0 && (d[1] - 0.55).abs() < 1e-12 && (d[2] - 1.1).abs() < 1e-12, "{d:?}");
        assert_eq!(Param::Segment.cycled(false), Param::DeltaA);
        assert_eq!(Param::DeltaA.cycled(true), Param::Segment);

        let json = e.to_json();
        let back = mdg_guided::guides_from_json(&json).expect("mdg-run reads it");
        assert_eq!(back, e.guides());
        assert!(
            json.contains(r#""points": [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 2.0], [0.0, 0.0, 3.0]]"#),
            "{json}"
        );
        let mut odd = Editor::new(vec![Guide::new("a \"quoted\" name", two_guides()[1].points.clone())]);
        odd.guides[0].points[1] = [0.1 + 0.2, -1e-7, 12345.678];
        let back = mdg_guided::guides_from_json(&odd.to_json()).expect("reads");
        assert_eq!(back, odd.guides(), "names are escaped and numbers round-trip exactly");

        let overlay = e.overlay(0.1);
        let count = |ns: &str| overlay.iter().filter(|l| l.namespace == ns).count();
        assert_eq!(count(NS_GUIDES), 1);
        assert_eq!(count(NS_SELECTED), 1);
        assert_eq!(count(NS_POINTS), 3 * 8 + 2, "a three-line cross per control point, the selected guide's handles");

        assert_eq!(e.delete_selected().expect("deleted"), "deleted trunk");
        assert_eq!(e.guides().len(), 1);
        e.select_next();
        assert_eq!(e.delete_selected(), Err(EditError::LastGuide), "the last guide stays");
        assert!(e.undo());
        assert_eq!(e.guides().len(), 2);
        assert!(!e.replace(e.guides().to_vec()));
        assert!(e.replace(two_guides()[..1].to_vec()));
        assert_eq!(e.guides().len(), 1);
    }
}
