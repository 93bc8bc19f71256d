//! Parts and slots: `part` entries, their joints and slots (mirrored pairs included).

use super::*;

/// A name for the mirror image of slot `name`: `_l` ↔ `_r`, else `NAME_r`.
fn mirror_name(name: &str) -> String {
    if let Some(b) = name.strip_suffix("_l") {
        format!("{b}_r")
    } else if let Some(b) = name.strip_suffix("_r") {
        format!("{b}_l")
    } else {
        format!("{name}_r")
    }
}

impl Builder<'_, '_> {
    pub(super) fn vec3(&mut self, e: &Entry) -> Option<[f32; 3]> {
        let v = self.nums(e, 3, "three numbers X Y Z")?;
        self.within_range(e, &v)?;
        Some([v[0] as f32, v[1] as f32, v[2] as f32])
    }

    /// E0815 unless every value is within ±[`MAX_COORDINATE`] (beyond it, f32
    /// geometry loses the precision normals and slots need, or overflows).
    pub(super) fn within_range(&mut self, e: &Entry, v: &[f64]) -> Option<()> {
        if let Some(i) = v.iter().position(|x| x.abs() > MAX_COORDINATE) {
            let span = e.values.get(i).map(|v| v.span()).unwrap_or(e.span);
            self.push(
                err("E0815", span, format!("`{}` values must be within ±{MAX_COORDINATE}", e.key.text))
                    .with_label(format!("{} is out of range", v[i])),
            );
            return None;
        }
        Some(())
    }

    pub(super) fn positive(&mut self, e: &Entry) -> Option<f32> {
        let v = self.nums(e, 1, "one number")?[0];
        self.within_range(e, &[v])?;
        if v <= 0.0 {
            let span = e.values.first().map(|v| v.span()).unwrap_or(e.span);
            self.push(
                err("E0815", span, format!("`{}` must be positive", e.key.text)).with_label(format!("{v} is not")),
            );
            return None;
        }
        Some(v as f32)
    }

    /// `joint { … }` or `slot NAME { … }`.
    pub(super) fn slot<'e>(&mut self, e: &'e Entry, name: String, is_slot: bool) -> Option<(Slot, Option<&'e Name>)> {
        let block = self.block(e, if is_slot { "slot's keys" } else { "joint's keys" })?;
        let allowed = if is_slot { SLOT_KEYS } else { JOINT_KEYS };
        let what = if is_slot { "a `slot`" } else { "a `joint`" };
        let es = known_entries(block, allowed, what, self.diags);
        at_most_once(&es, self.diags);
        let mut s = Slot {
            name,
            at: [0.0; 3],
            normal: [0.0; 3],
            up: [0.0; 3],
            size: 0.0,
            accepts: Vec::new(),
            mirror_of: None,
            partner: None,
            turn: [0.0; 3],
            spacing: 0.0,
        };
        let (mut have_at, mut have_normal, mut have_size, mut have_accepts) = (false, false, false, false);
        let mut up: Option<([f32; 3], Span)> = None;
        let mut normal_span = e.key.span;
        let mut symmetric = None;
        let mut ok = true;
        for x in &es {
            self.no_block(x);
            match x.key.text.as_str() {
                "at" => match self.vec3(x) {
                    Some(v) => (s.at, have_at) = (v, true),
                    None => ok = false,
                },
                "normal" => match self.vec3(x) {
                    Some(v) => {
                        (s.normal, have_normal) = (v, true);
                        normal_span = x.span;
                    }
                    None => ok = false,
                },
                "up" => match self.vec3(x) {
                    Some(v) => up = Some((v, x.span)),
                    None => ok = false,
                },
                "size" => match self.positive(x) {
                    Some(v) => (s.size, have_size) = (v, true),
                    None => ok = false,
                },
                "accepts" => {
                    self.no_block(x);
                    if !expect_count(x, 1, usize::MAX, "one or more part types", self.diags) {
                        ok = false;
                        continue;
                    }
                    match words(x, self.diags).and_then(|w| self.kinds(&w)) {
                        Some(ks) => {
                            have_accepts = true;
                            for k in ks {
                                for f in self.t.family(k) {
                                    if !s.accepts.contains(&f) {
                                        s.accepts.push(f);
                                    }
                                }
                            }
                        }
                        None => ok = false,
                    }
                }
                "symmetric" => match self.word(x, "the name of the mirror slot") {
                    Some(n) => symmetric = Some(n),
                    None => ok = false,
                },
                "turn" => match self.vec3(x) {
                    Some(v) => s.turn = v.map(|d| d.to_radians()),
                    None => ok = false,
                },
                "spacing" => match self.positive(x) {
                    Some(v) => s.spacing = v,
                    None => ok = false,
                },
                _ => {}
            }
        }
        let mut missing: Vec<&str> = Vec::new();
        if !have_at {
            missing.push("at");
        }
        if !have_normal {
            missing.push("normal");
        }
        if !have_size {
            missing.push("size");
        }
        if is_slot && !have_accepts {
            missing.push("accepts");
        }
        if !missing.is_empty() {
            self.push(
                err(
                    "E0808",
                    e.key.span,
                    format!(
                        "this {} is missing `{}`",
                        what.trim_start_matches("a ").trim_matches('`'),
                        missing.join("`, `")
                    ),
                )
                .with_note(format!(
                    "{what} needs `at X Y Z; normal X Y Z; size S;`{}",
                    if is_slot { " and `accepts TYPE…;`" } else { "" }
                )),
            );
            return None;
        }
        if !ok {
            return None;
        }
        let n = glam::Vec3::from(s.normal);
        if n.length() < 1e-6 {
            self.push(err("E0815", normal_span, "a slot's normal must not be zero"));
            return None;
        }
        let n = n.normalize();
        let up_v = match up {
            Some((u, _)) => glam::Vec3::from(u),
            None if n.z.abs() < 0.95 => glam::Vec3::Z,
            None => glam::Vec3::NEG_Y,
        };
        let u = up_v - n * up_v.dot(n);
        if u.length() < 1e-4 {
            let span = up.map(|u| u.1).unwrap_or(normal_span);
            self.push(
                err("E0815", span, "a slot's `up` must not be parallel to its normal")
                    .with_label("it fixes the twist about the normal"),
            );
            return None;
        }
        s.normal = n.to_array();
        s.up = u.normalize().to_array();
        Some((s, symmetric))
    }

    pub(super) fn part(&mut self, e: &Entry, name: &Name, resolve: &mut RuleResolver) -> Option<PartDef> {
        let block = self.block(e, "part's keys")?;
        let es = known_entries(block, PART_KEYS, "a `part`", self.diags);
        let singles: Vec<&Entry> = es.iter().filter(|x| x.key.text != "slot").copied().collect();
        at_most_once(&singles, self.diags);
        let mut kind = None;
        let mut category = None;
        let mut geometry: Option<(Geometry, Span)> = None;
        let mut color: Option<([f32; 4], Span)> = None;
        let mut scale = 1.0f32;
        let mut support = false;
        let mut joint = None;
        let mut slots: Vec<Slot> = Vec::new();
        let mut slot_spans: Vec<Span> = Vec::new();
        let mut ok = true;
        for x in &es {
            if !matches!(x.key.text.as_str(), "joint" | "slot") {
                self.no_block(x);
            }
            match x.key.text.as_str() {
                "type" => kind = self.word(x, "one part type").and_then(|w| self.t.kind(&w.text)),
                "category" => {
                    category = self
                        .word(x, "one category name")
                        .and_then(|w| self.t.categories.iter().position(|c| *c == w.text))
                        .map(|i| i as u32)
                }
                "rule" | "mesh" => {
                    if let Some((_, prev)) = &geometry {
                        self.push(
                            err("E0809", x.key.span, "a part has one geometry: `rule` or `mesh`, not both")
                                .with_secondary(*prev, "geometry given here"),
                        );
                        ok = false;
                        continue;
                    }
                    if x.key.text == "rule" {
                        let Some(w) = self.word(x, "the name of an MDG rule") else {
                            ok = false;
                            continue;
                        };
                        match resolve(w, self.ns, self.diags) {
                            Some(r) => geometry = Some((Geometry::Rule(r), x.key.span)),
                            None => ok = false,
                        }
                    } else {
                        if !expect_count(x, 1, 1, "a file name in quotes", self.diags) {
                            ok = false;
                            continue;
                        }
                        match x.values.first() {
                            Some(Value::Str(path, span))
                                if std::path::Path::new(path).is_absolute() || path.is_empty() =>
                            {
                                self.push(
                                    err("E0810", *span, format!("mesh path `{path}` must be relative"))
                                        .with_label("meshes are read relative to the file that names them")
                                        .with_note("a mesh must lie inside the project (the main file's directory) or the std directory"),
                                );
                                ok = false;
                            }
                            Some(Value::Str(path, span)) => {
                                let index = self.t.meshes.len() as u32;
                                self.t.meshes.push(PartMesh {
                                    path: path.clone(),
                                    positions: Vec::new(),
                                    triangles: Vec::new(),
                                    color: [0.8, 0.8, 0.8, 1.0],
                                });
                                let _ = span;
                                geometry = Some((Geometry::Mesh(index), x.key.span));
                            }
                            Some(v) => {
                                self.push(
                                    err("E0602", v.span(), "`mesh` takes a file name in quotes")
                                        .with_label("not a string"),
                                );
                                ok = false;
                            }
                            None => ok = false,
                        }
                    }
                }
                "color" => match self.nums(x, 3, "three numbers R G B") {
                    Some(v) => color = Some(([v[0] as f32, v[1] as f32, v[2] as f32, 1.0], x.span)),
                    None => ok = false,
                },
                "scale" => match self.positive(x) {
                    Some(v) => scale = v,
                    None => ok = false,
                },
                "support" if expect_count(x, 0, 0, "no values", self.diags) => support = true,
                "joint" => {
                    if !x.values.is_empty() {
                        self.push(err("E0602", x.values[0].span(), "`joint` takes only a `{ … }` block"));
                        ok = false;
                        continue;
                    }
                    match self.slot(x, "joint".into(), false) {
                        Some((j, _)) => joint = Some((j, x.key.span)),
                        None => ok = false,
                    }
                }
                "slot" => {
                    let Some(n) = self.entry_name(x) else {
                        ok = false;
                        continue;
                    };
                    let Some((s, sym)) = self.slot(x, n.text.clone(), true) else {
                        ok = false;
                        continue;
                    };
                    if let Some(i) = slots.iter().position(|o| o.name == s.name) {
                        let d = if slots[i].mirror_of.is_some() {
                            err("E0812", n.span, format!("slot `{}` is declared by `symmetric` already", n.text))
                                .with_secondary(slot_spans[i], "`symmetric` declares the mirror slot here")
                                .with_note(format!(
                                    "`symmetric {}` makes the mirror image of its slot: remove this `slot {} {{ … }}`",
                                    n.text, n.text
                                ))
                        } else {
                            err("E0812", n.span, format!("slot `{}` is defined twice in part `{}`", n.text, name.text))
                                .with_secondary(slot_spans[i], "first defined here")
                        };
                        self.push(d);
                        ok = false;
                        continue;
                    }
                    let orig = slots.len() as u32;
                    slots.push(s.clone());
                    slot_spans.push(n.span);
                    if let Some(m) = sym {
                        if m.text == n.text {
                            self.push(
                                err("E0812", m.span, format!("slot `{}` cannot be its own mirror slot", n.text))
                                    .with_label("`symmetric` names the mirror slot it declares")
                                    .with_note(format!(
                                        "give the mirror image its own name, e.g. `symmetric {}`",
                                        mirror_name(&n.text)
                                    )),
                            );
                            ok = false;
                            continue;
                        }
                        if let Some(i) = slots.iter().position(|o| o.name == m.text) {
                            if slots[i].mirror_of.is_none() && slots[i].partner.is_none() {
                                self.push(
                                    err("E0812", m.span, format!("`symmetric {}` declares a slot that exists", m.text))
                                        .with_secondary(slot_spans[i], "declared here already")
                                        .with_note(format!(
                                            "`symmetric {}` makes the mirror image of slot `{}` itself: remove the separate `slot {} {{ … }}`",
                                            m.text, n.text, m.text
                                        )),
                                );
                                ok = false;
                                continue;
                            }
                            self.push(
                                err(
                                    "E0812",
                                    m.span,
                                    format!("slot `{}` is defined twice in part `{}`", m.text, name.text),
                                )
                                .with_secondary(slot_spans[i], "first defined here"),
                            );
                            ok = false;
                            continue;
                        }
                        if s.at[0].abs() < 1e-6 && s.normal[0].abs() < 1e-6 {
                            self.push(
                                err("E0815", m.span, format!("slot `{}` is its own mirror image", n.text))
                                    .with_label("a symmetric slot must lie off the plane x = 0 or point away from it"),
                            );
                            ok = false;
                            continue;
                        }
                        let mx = |v: [f32; 3]| [-v[0], v[1], v[2]];
                        slots.push(Slot {
                            name: m.text.clone(),
                            at: mx(s.at),
                            normal: mx(s.normal),
                            up: mx(s.up),
                            mirror_of: Some(orig),
                            partner: Some(orig),
                            ..s.clone()
                        });
                        slot_spans.push(m.span);
                        slots[orig as usize].partner = Some(orig + 1);
                    }
                }
                _ => {}
            }
        }
        let mut missing = Vec::new();
        if !es.iter().any(|x| x.key.text == "type") {
            missing.push("type");
        }
        if !es.iter().any(|x| x.key.text == "category") {
            missing.push("category");
        }
        if !es.iter().any(|x| x.key.text == "rule" || x.key.text == "mesh") {
            missing.push("rule` or `mesh");
        }
        if !missing.is_empty() {
            self.push(
                err("E0808", name.span, format!("part `{}` is missing `{}`", name.text, missing.join("`, `")))
                    .with_note(
                    "a part needs `type TYPE; category NAME;` and its geometry: `rule RULE;` or `mesh \"FILE.obj\";`",
                ),
            );
            return None;
        }
        if let (Some((_, span)), Some(Geometry::Rule(_))) = (&color, geometry.as_ref().map(|g| &g.0)) {
            self.push(
                err("E0809", *span, "`color` is for `mesh` parts")
                    .with_label("a `rule` part has the colours its rule draws"),
            );
            ok = false;
        }
        let (kind, category, (geometry, _)) = (kind?, category?, geometry?);
        let is_torso = self.t.kinds.get(kind as usize).is_some_and(|k| k.torso);
        if !is_torso {
            if let Some(first) = slot_spans.first() {
                self.push(
                    err(
                        "E0811",
                        *first,
                        format!("only torsos have slots; `{}` is a `{}`", name.text, self.t.kinds[kind as usize].name),
                    )
                    .with_note("other parts attach to a torso by their `joint`"),
                );
                return None;
            }
            if joint.is_none() {
                self.push(
                    err("E0811", name.span, format!("part `{}` has no `joint`", name.text))
                        .with_label("every part but a torso attaches to a torso by its joint")
                        .with_note("add `joint { at X Y Z; normal X Y Z; size S; }` at the end that touches the torso"),
                );
                return None;
            }
        }
        if let (Some((_, span)), Geometry::Mesh(m)) = (&color, &geometry) {
            if let Some(mesh) = self.t.meshes.get_mut(*m as usize) {
                let c = color.map(|c| c.0).unwrap_or([0.8; 4]);
                if c[..3].iter().any(|v| !(0.0..=1.0).contains(v)) {
                    self.push(err("E0815", *span, "colour components must be in 0–1"));
                    return None;
                }
                mesh.color = c;
            }
        }
        if !ok {
            return None;
        }
        Some(PartDef {
            name: name.text.clone(),
            kind,
            category,
            geometry,
            joint: joint.map(|j| j.0),
            slots,
            support,
            scale,
        })
    }
}
