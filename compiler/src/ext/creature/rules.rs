//! Rules: `increase`, `insert`, `replace`, `combine` and the keys each kind takes.

use super::*;

impl Builder<'_, '_> {
    pub(super) fn rule(&mut self, e: &Entry, name: &Name) -> Option<RuleDef> {
        let block = self.block(e, "rule's keys")?;
        let es = known_entries(block, RULE_KEYS, "a structure `rule`", self.diags);
        let singles: Vec<&Entry> = es.iter().filter(|x| x.key.text != "condition").copied().collect();
        at_most_once(&singles, self.diags);
        let find = |k: &str| es.iter().find(|x| x.key.text == k).copied();
        let Some(ke) = find("kind") else {
            self.push(
                err("E0808", name.span, format!("rule `{}` has no `kind`", name.text))
                    .with_note("add `kind increase;`, `kind insert;`, `kind replace;` or `kind combine;`"),
            );
            return None;
        };
        let kw = self.word(ke, "`increase`, `insert`, `replace` or `combine`")?;
        let Some((_, kind)) = RuleKind::NAMES.iter().find(|(n, _)| *n == kw.text) else {
            let mut d = err("E0602", kw.span, "a rule's `kind` is `increase`, `insert`, `replace` or `combine`");
            if let Some(s) = did_you_mean(&kw.text, RuleKind::NAMES.iter().map(|(n, _)| *n)) {
                d = d.with_label(format!("did you mean `{s}`?")).with_suggestion(
                    format!("replace with `{s}`"),
                    kw.span,
                    s,
                );
            }
            self.push(d);
            return None;
        };
        let kind = *kind;
        // Keys that belong to other kinds of rule.
        let mut ok = true;
        for x in &es {
            let belongs = match x.key.text.as_str() {
                "add" | "arrange" | "max" => kind == RuleKind::Increase,
                "successor" => matches!(kind, RuleKind::Insert | RuleKind::Replace),
                "from" => kind != RuleKind::Increase,
                "take" => kind == RuleKind::Combine,
                _ => true,
            };
            if !belongs {
                self.push(
                    err(
                        "E0809",
                        x.key.span,
                        format!(
                            "`{}` does not belong in {} `{}` rule",
                            x.key.text,
                            if kind == RuleKind::Increase { "an" } else { "a" },
                            kind.name()
                        ),
                    )
                    .with_note(key_kinds(&x.key.text)),
                );
                ok = false;
            }
        }
        let mut r = RuleDef {
            id: name.text.clone(),
            kind,
            priority: 0,
            predecessor: Vec::new(),
            category: None,
            conditions: Vec::new(),
            probability: Code(vec![CondOp::Push(1.0)]),
            add: 1,
            arrange: Mode::Row,
            max: 3,
            successor: Vec::new(),
            from: None,
            take: Vec::new(),
        };
        let Some(pe) = find("predecessor") else {
            self.push(
                err("E0808", name.span, format!("rule `{}` has no `predecessor`", name.text))
                    .with_note("add `predecessor TYPE…;`: the super-part types it rewrites"),
            );
            return None;
        };
        if kind == RuleKind::Insert && find("successor").is_none() {
            self.push(
                err("E0808", name.span, format!("insert rule `{}` has no `successor`", name.text))
                    .with_note("add `successor TYPE…;`: the part types it inserts"),
            );
            ok = false;
        }
        for x in &es {
            self.no_block(x);
            match x.key.text.as_str() {
                "priority" => {
                    if let Some(v) = self.nums(x, 1, "one whole number") {
                        if v[0].fract() != 0.0 || v[0].abs() > 1e6 {
                            self.push(err("E0815", x.values[0].span(), "a priority is a whole number"));
                            ok = false;
                        } else {
                            r.priority = v[0] as i32;
                        }
                    } else {
                        ok = false;
                    }
                }
                "predecessor" | "successor" | "take" => {
                    if !expect_count(x, 1, usize::MAX, "one or more part types", self.diags) {
                        ok = false;
                        continue;
                    }
                    match words(x, self.diags).and_then(|w| self.kinds(&w)) {
                        Some(ks) => match x.key.text.as_str() {
                            "predecessor" => r.predecessor = ks,
                            "successor" => r.successor = ks,
                            _ => r.take = ks,
                        },
                        None => ok = false,
                    }
                }
                "category" | "from" => match self.word(x, "one category name").and_then(|w| self.category_index(w)) {
                    Some(c) if x.key.text == "category" => r.category = Some(c),
                    Some(c) => r.from = Some(c),
                    None => ok = false,
                },
                "condition" => {
                    if !expect_count(x, 1, 1, "one expression in parentheses", self.diags) {
                        ok = false;
                        continue;
                    }
                    match self.code(&x.values[0], true) {
                        Some(c) => r.conditions.push(c),
                        None => ok = false,
                    }
                }
                "probability" => {
                    if !expect_count(x, 1, 1, "a number or an expression in parentheses", self.diags) {
                        ok = false;
                        continue;
                    }
                    match self.code(&x.values[0], false) {
                        Some(c) => {
                            // Keeps the exhaustive range check (E0805) small: g and one count.
                            let (vars, parts) = cond::reads(&c.0);
                            let counts: Vec<&str> = vars
                                .iter()
                                .filter(|&&v| v != 0)
                                .map(|&v| VARIABLES[v as usize])
                                .chain(parts.then_some("parts(…)"))
                                .collect();
                            if counts.len() > 1 {
                                self.push(
                                    err(
                                        "E0814",
                                        x.values[0].span(),
                                        "a probability may read `g` and at most one count",
                                    )
                                    .with_label(format!("it reads {}", counts.join(", ")))
                                    .with_note("move the other tests into a `condition`"),
                                );
                                ok = false;
                            } else {
                                r.probability = c;
                            }
                        }
                        None => ok = false,
                    }
                }
                "add" => match self.count(x, 1, tb::MAX_COUNT - 1) {
                    Some(v) => r.add = v,
                    None => ok = false,
                },
                "max" => match self.count(x, 2, tb::MAX_COUNT) {
                    Some(v) => r.max = v,
                    None => ok = false,
                },
                "arrange" => {
                    if !expect_count(x, 1, 1, "`row`, `stack` or `fan`", self.diags) {
                        ok = false;
                        continue;
                    }
                    match self.mode(&x.values[0]) {
                        Some(m) => r.arrange = m,
                        None => ok = false,
                    }
                }
                _ => {}
            }
        }
        let _ = pe;
        ok.then_some(r)
    }
}

/// Which rule kinds a kind-specific key belongs to (for E0809 notes).
fn key_kinds(key: &str) -> String {
    match key {
        "add" | "arrange" | "max" => format!("`{key}` is for `increase` rules"),
        "successor" => "`successor` is for `insert` and `replace` rules".into(),
        "from" => "`from` is for `insert`, `replace` and `combine` rules".into(),
        "take" => "`take` is for `combine` rules".into(),
        _ => String::new(),
    }
}
