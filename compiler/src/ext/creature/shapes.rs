//! Shapes: the regular creatures assembled from parts, and whether each can stand.

use super::*;

impl Builder<'_, '_> {
    /// W0801: a regular creature subject to the stability test that cannot pass it
    /// (none of its parts is a `support` part, so it has no support points).
    pub(super) fn cannot_stand(&mut self, shape_names: &[(String, Span)]) {
        // Not after errors: a shape missing a bad attach is no evidence.
        if !self.t.evolve.stability || self.diags.iter().any(|d| d.is_error()) {
            return;
        }
        let mut found = Vec::new();
        for s in &self.t.shapes {
            if s.floats {
                continue;
            }
            let support = |p: u32| self.t.parts.get(p as usize).is_some_and(|p| p.support);
            if support(s.torso) || s.attach.iter().any(|a| support(a.part)) {
                continue;
            }
            let Some((_, span)) = shape_names.iter().find(|(n, _)| *n == s.name) else { continue };
            let d = Diagnostic::warning(
                "W0801",
                *span,
                format!("regular creature `{}` cannot pass the stability test", s.name),
            )
            .with_label("none of its parts is a `support` part: it has nothing to stand on")
            .with_note("a swimmer or a flier says `floats;` in its shape (or the grammar `stability off;` in `evolve`); a walker needs `support;` parts (legs)");
            found.push(d);
        }
        self.diags.extend(found);
    }

    pub(super) fn shape(&mut self, e: &Entry, name: &Name, names: &Names) -> Option<ShapeDef> {
        let block = self.block(e, "creature's torso and attachments")?;
        let es = known_entries(block, SHAPE_KEYS, "a `shape`", self.diags);
        let torsos: Vec<&Entry> = es.iter().filter(|x| x.key.text == "torso").copied().collect();
        at_most_once(&torsos, self.diags);
        let Some(te) = torsos.first() else {
            self.push(
                err("E0808", name.span, format!("shape `{}` has no `torso`", name.text)).with_note("add `torso PART;`"),
            );
            return None;
        };
        self.no_block(te);
        let tn = self.word(te, "one part name")?;
        let torso = self.part_index(tn, names)?;
        let tp = self.t.parts.get(torso as usize)?.clone();
        if !self.t.kinds[tp.kind as usize].torso {
            self.push(
                err("E0807", tn.span, format!("`{}` is not a torso", tn.text))
                    .with_label(format!("its type is `{}`", self.t.kinds[tp.kind as usize].name)),
            );
            return None;
        }
        let mut attach: Vec<AttachDef> = Vec::new();
        let mut used: Vec<(u32, Span)> = Vec::new();
        for x in es.iter().filter(|x| x.key.text == "attach") {
            self.no_block(x);
            if !expect_count(x, 2, 4, "SLOT PART [COUNT [MODE]]", self.diags) {
                continue;
            }
            let (Some(Value::Word(sn)), Some(Value::Word(pn))) = (x.values.first(), x.values.get(1)) else {
                let bad =
                    x.values.iter().take(2).find(|v| !matches!(v, Value::Word(_))).map(|v| v.span()).unwrap_or(x.span);
                self.push(err("E0602", bad, "`attach` takes SLOT PART [COUNT [MODE]]").with_label("not a name"));
                continue;
            };
            let Some(mut slot) = tp.slots.iter().position(|s| s.name == sn.text).map(|i| i as u32) else {
                let mut d = err("E0802", sn.span, format!("part `{}` has no slot `{}`", tp.name, sn.text));
                d = match did_you_mean(&sn.text, tp.slots.iter().map(|s| s.name.as_str())) {
                    Some(s) => d.with_label(format!("did you mean `{s}`?")).with_suggestion(
                        format!("replace with `{s}`"),
                        sn.span,
                        s,
                    ),
                    None => d.with_note(format!(
                        "its slots: {}",
                        tp.slots.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", ")
                    )),
                };
                self.push(d);
                continue;
            };
            if let Some(m) = tp.slots[slot as usize].mirror_of {
                slot = m;
            }
            let Some(part) = self.part_index(pn, names) else {
                continue;
            };
            let pk = self.t.parts[part as usize].kind;
            let sl = &tp.slots[slot as usize];
            if !sl.accepts.contains(&pk) || self.t.kinds[pk as usize].torso {
                let accepts: Vec<&str> = sl.accepts.iter().map(|k| self.t.kinds[*k as usize].name.as_str()).collect();
                self.push(
                    err("E0807", pn.span, format!("slot `{}` does not accept `{}`", sn.text, pn.text))
                        .with_label(format!("a `{}`", self.t.kinds[pk as usize].name))
                        .with_note(format!("slot `{}` accepts: {}", sn.text, accepts.join(", "))),
                );
                continue;
            }
            if let Some((_, prev)) = used.iter().find(|(s, _)| *s == slot) {
                self.push(
                    err("E0812", sn.span, format!("slot `{}` is filled twice", sn.text))
                        .with_secondary(*prev, "filled here (or by its mirror slot)"),
                );
                continue;
            }
            used.push((slot, sn.span));
            let count = match x.values.get(2) {
                Some(v) => match crate::ext::number(self.ex, v) {
                    Some(c) if c.fract() == 0.0 && (1.0..=tb::MAX_COUNT as f64).contains(&c) => c as u32,
                    _ => {
                        self.push(err(
                            "E0815",
                            v.span(),
                            format!("COUNT must be a whole number from 1 to {}", tb::MAX_COUNT),
                        ));
                        continue;
                    }
                },
                None => 1,
            };
            let mode = match x.values.get(3) {
                Some(v) => match self.mode(v) {
                    Some(m) => m,
                    None => {
                        continue;
                    }
                },
                None if count > 1 => Mode::Row,
                None => Mode::Def,
            };
            attach.push(AttachDef { slot, part, count, mode });
        }
        let floats = match es.iter().find(|x| x.key.text == "floats") {
            Some(x) => {
                self.no_block(x);
                expect_count(x, 0, 0, "no values", self.diags)
            }
            None => false,
        };
        // An attach in error is left out (and reported); the others stay, so rules
        // on the parts they attach are not reported as never matching.
        Some(ShapeDef { name: name.text.clone(), torso, attach, floats })
    }
}
