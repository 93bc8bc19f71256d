//! The `evolve` and `select` entries: evolution parameters and the selection keys.

use super::*;

impl Builder<'_, '_> {
    pub(super) fn select(&mut self, e: &Entry, seen: &mut Vec<(&'static str, Span)>) {
        self.no_block(e);
        if !expect_count(e, 2, 2, "`shapes` or `rules`, then `rank`, `uniform` or `roulette`", self.diags) {
            return;
        }
        let Some(ws) = words(e, self.diags) else { return };
        let what: &'static str = match ws[0].text.as_str() {
            "shapes" => "shapes",
            "rules" => "rules",
            _ => {
                self.push(
                    err("E0602", ws[0].span, "`select` takes `shapes` or `rules` first").with_label("what is selected"),
                );
                return;
            }
        };
        let Some((_, strategy)) = Strategy::NAMES.iter().find(|(n, _)| *n == ws[1].text) else {
            let mut d = err("E0602", ws[1].span, "the selection rule is `rank`, `uniform` or `roulette`");
            if let Some(s) = did_you_mean(&ws[1].text, Strategy::NAMES.iter().map(|(n, _)| *n)) {
                d = d.with_label(format!("did you mean `{s}`?")).with_suggestion(
                    format!("replace with `{s}`"),
                    ws[1].span,
                    s,
                );
            }
            self.push(d);
            return;
        };
        if let Some((_, prev)) = seen.iter().find(|(w, _)| *w == what) {
            self.push(
                err("E0603", e.key.span, format!("`select {what}` is given twice"))
                    .with_secondary(*prev, "first given here"),
            );
            return;
        }
        seen.push((what, e.key.span));
        if what == "shapes" {
            self.t.select_shapes = *strategy;
        } else {
            self.t.select_rules = *strategy;
        }
    }

    pub(super) fn evolve(&mut self, e: &Entry) {
        if !e.values.is_empty() {
            self.push(err("E0602", e.values[0].span(), "`evolve` takes only a `{ … }` block"));
        }
        let Some(block) = self.block(e, "evolution settings") else { return };
        let es = known_entries(block, EVOLVE_KEYS, "`evolve`", self.diags);
        at_most_once(&es, self.diags);
        let mut s = EvolveSettings::default();
        let mut offspring_given = false;
        for x in &es {
            self.no_block(x);
            let v = match x.key.text.as_str() {
                "population" | "background" => {
                    self.count(x, if x.key.text == "population" { 1 } else { 0 }, tb::MAX_POPULATION)
                }
                "generations" => self.count(x, 0, tb::MAX_GENERATIONS),
                "offspring" => self.count(x, 1, tb::MAX_POPULATION * 4),
                "steps" => self.count(x, 1, tb::MAX_STEPS),
                "attempts" => self.count(x, 1, tb::MAX_ATTEMPTS),
                "maxparts" => self.count(x, 2, tb::MAX_PARTS),
                "seed" => self.count(x, 0, u32::MAX),
                "stability" => {
                    match x.values.first() {
                        Some(Value::Word(w)) if x.values.len() == 1 && (w.text == "on" || w.text == "off") => {
                            s.stability = w.text == "on"
                        }
                        _ => self.push(err("E0602", x.span, "`stability` is `on` or `off`")),
                    }
                    None
                }
                _ => None,
            };
            let Some(v) = v else { continue };
            match x.key.text.as_str() {
                "population" => s.population = v,
                "background" => s.background = v,
                "generations" => s.generations = v,
                "offspring" => {
                    s.offspring = v;
                    offspring_given = true;
                }
                "steps" => s.steps = v,
                "attempts" => s.attempts = v,
                "maxparts" => s.maxparts = v,
                "seed" => s.seed = v as u64,
                _ => {}
            }
        }
        if !offspring_given {
            s.offspring = s.population * 3;
        }
        self.t.evolve = s;
    }
}
