//! Conditions and probabilities: expressions lowered to creature condition code,
//! probabilities that can leave [0, 1] (E0805), rules that can never match (E0804)
//! and conditions that can never hold (W0802).

use super::*;
use crate::ast::Number;
use crate::consteval::{self, Call, Leaves};
use mdg_vm::expr::Func;

/// Evaluations [`cond::never_hold`] may spend on one rule's conditions.
const NEVER_HOLD_BUDGET: u64 = 4_000_000;

impl Builder<'_, '_> {
    /// Compiles a condition or probability value.
    pub(super) fn code(&mut self, v: &Value, condition: bool) -> Option<Code> {
        let mut out = Vec::new();
        match v {
            Value::Num(n) => {
                if n.unit.is_some() {
                    self.push(
                        err("E0814", n.span, "a probability is a plain number").with_label("no unit suffix here"),
                    );
                    return None;
                }
                out.push(CondOp::Push(n.value));
            }
            Value::Neg(n) => out.push(CondOp::Push(-n.value)),
            Value::Expr(e) => {
                if !self.expr(e, condition, &mut out) {
                    return None;
                }
            }
            Value::Word(w) => {
                let mut tmp = Vec::new();
                let e = Expr { kind: ExprKind::Var(w.clone()), span: w.span };
                if !self.expr(&e, condition, &mut tmp) {
                    return None;
                }
                out = tmp;
            }
            Value::Str(_, span) => {
                self.push(
                    err("E0602", *span, "expected a number or an expression in parentheses").with_label("not a string"),
                );
                return None;
            }
        }
        Some(Code(out))
    }

    /// Lowers `e` in the creature condition language ([`Condition`]).
    pub(super) fn expr(&mut self, e: &Expr, condition: bool, out: &mut Vec<CondOp>) -> bool {
        consteval::lower(&mut Condition { b: self, condition }, e, out)
    }

    /// E0805: a probability that leaves [0, 1] at some generation (up to
    /// [`tb::MAX_GENERATIONS`]) and count (up to `maxparts`).
    pub(super) fn probabilities(&mut self, rules: &[(usize, &Entry)]) {
        for (ri, e) in rules {
            let Some(r) = self.t.rules.get(*ri) else { continue };
            let Some(pe) = e.block.iter().flat_map(|(b, _)| b).find(|x| x.key.text == "probability") else { continue };
            let span = pe.values.first().map(|v| v.span()).unwrap_or(pe.span);
            if let Some((at, p)) =
                cond::probability_escape(&r.probability.0, tb::MAX_GENERATIONS, self.t.evolve.maxparts)
            {
                let value = if p.is_nan() { "not a number".to_string() } else { format!("{p:.4}") };
                let label = if at.is_empty() { format!("it is {value}") } else { format!("at {at} it is {value}") };
                self.push(
                    err("E0805", span, format!("the probability of rule `{}` can leave [0, 1]", r.id))
                        .with_label(label)
                        .with_note(format!(
                            "checked at every generation g = 0..{} and every count 1..{} (maxparts)",
                            tb::MAX_GENERATIONS,
                            self.t.evolve.maxparts
                        )),
                );
            }
        }
    }

    /// E0804: rules whose predecessor no evolved shape can ever present; W0802:
    /// rules whose conditions hold for no shape.
    pub(super) fn never_match(&mut self, rules: &[(usize, &Entry)]) {
        let t = &self.t;
        let is_torso = |k: u32| t.kinds.get(k as usize).is_some_and(|k| k.torso);
        let parts_of = |k: u32, cat: Option<u32>| {
            t.parts.iter().filter(move |p| p.kind == k && cat.is_none_or(|c| p.category == c)).count()
        };
        // Kinds some shape can have: the regular creatures', then what rules add.
        let mut reach: Vec<u32> = Vec::new();
        for s in &t.shapes {
            if let Some(p) = t.parts.get(s.torso as usize) {
                reach.push(p.kind);
            }
            for a in &s.attach {
                if let Some(p) = t.parts.get(a.part as usize) {
                    reach.push(p.kind);
                }
            }
        }
        loop {
            let before = reach.len();
            for r in &t.rules {
                if !r.predecessor.iter().any(|k| reach.contains(k)) {
                    continue;
                }
                match r.kind {
                    RuleKind::Insert => {
                        for &k in &r.successor {
                            let slot_ok = t.parts.iter().any(|p| {
                                r.predecessor.contains(&p.kind)
                                    && reach.contains(&p.kind)
                                    && p.slots.iter().any(|s| s.accepts.contains(&k))
                            });
                            if slot_ok && parts_of(k, r.from) > 0 {
                                reach.push(k);
                            }
                        }
                    }
                    RuleKind::Replace => {
                        let live: Vec<u32> = r.predecessor.iter().copied().filter(|k| reach.contains(k)).collect();
                        for pk in live {
                            let succ = if r.successor.is_empty() { t.family(pk) } else { r.successor.clone() };
                            reach.extend(succ.into_iter().filter(|&k| parts_of(k, r.from) > 0));
                        }
                    }
                    _ => {}
                }
            }
            reach.sort_unstable();
            reach.dedup();
            if reach.len() == before {
                break;
            }
        }
        let mut found = Vec::new();
        for (ri, e) in rules {
            let Some(r) = t.rules.get(*ri) else { continue };
            let name = |k: u32| t.kinds.get(k as usize).map(|k| k.name.as_str()).unwrap_or("?");
            let preds: Vec<u32> = r.predecessor.clone();
            let live: Vec<u32> = preds.iter().copied().filter(|k| reach.contains(k)).collect();
            let why: Option<String> = if live.is_empty() {
                Some(format!(
                    "no creature can have a `{}`: no regular creature has one and no rule adds one",
                    preds.iter().map(|&k| name(k)).collect::<Vec<_>>().join("` or `")
                ))
            } else if let Some(c) = r.category.filter(|&c| live.iter().all(|&k| parts_of(k, Some(c)) == 0)) {
                Some(format!(
                    "no `{}` part is in category `{}`",
                    live.iter().map(|&k| name(k)).collect::<Vec<_>>().join("` or `"),
                    t.categories.get(c as usize).map(|s| s.as_str()).unwrap_or("?")
                ))
            } else {
                match r.kind {
                    RuleKind::Increase if live.iter().all(|&k| is_torso(k)) => {
                        Some("increase rules copy parts attached to a torso, never a torso".to_string())
                    }
                    RuleKind::Increase if r.max < 1 + r.add => {
                        Some(format!("`max {}` leaves no room to add {} to a part", r.max, r.add))
                    }
                    RuleKind::Insert if !live.iter().any(|&k| is_torso(k)) => {
                        Some("insert rules add parts to a torso: the predecessor must be `torso`".to_string())
                    }
                    RuleKind::Insert => {
                        let fits = r.successor.iter().any(|&k| {
                            !is_torso(k)
                                && parts_of(k, r.from) > 0
                                && t.parts.iter().any(|p| {
                                    live.contains(&p.kind)
                                        && r.category.is_none_or(|c| p.category == c)
                                        && p.slots.iter().any(|s| s.accepts.contains(&k))
                                })
                        });
                        (!fits).then(|| {
                            format!(
                                "no slot of a `{}` part accepts `{}`{}",
                                live.iter().map(|&k| name(k)).collect::<Vec<_>>().join("` or `"),
                                r.successor.iter().map(|&k| name(k)).collect::<Vec<_>>().join("` or `"),
                                if r.from.is_some() { " from that category" } else { "" }
                            )
                        })
                    }
                    RuleKind::Replace => {
                        let alternatives = live.iter().any(|&pk| {
                            let succ = if r.successor.is_empty() { t.family(pk) } else { r.successor.clone() };
                            let n: usize = succ.iter().map(|&k| parts_of(k, r.from)).sum();
                            // Replacing a part by itself is no replacement.
                            n > usize::from(succ.contains(&pk) && r.from.is_none_or(|c| parts_of(pk, Some(c)) > 0))
                                || n > 1
                        });
                        (!alternatives).then(|| {
                            format!(
                                "`{}` has no allelic alternative to be replaced with",
                                live.iter().map(|&k| name(k)).collect::<Vec<_>>().join("` or `")
                            )
                        })
                    }
                    RuleKind::Combine => {
                        let slot_for_torso = t.parts.iter().enumerate().any(|(i, p)| {
                            is_torso(p.kind)
                                && p.slots.iter().any(|s| s.partner.is_none() && s.accepts.iter().any(|&k| is_torso(k)))
                                && t.parts
                                    .iter()
                                    .enumerate()
                                    .any(|(j, q)| j != i && is_torso(q.kind) && q.joint.is_some())
                        });
                        let removable = t.parts.iter().any(|p| {
                            is_torso(p.kind) && p.slots.iter().any(|s| s.accepts.iter().any(|k| live.contains(k)))
                        });
                        if !slot_for_torso {
                            Some(
                                "no torso has a slot accepting a torso that another torso's joint could fill"
                                    .to_string(),
                            )
                        } else if !removable {
                            Some("no torso carries these parts to remove".to_string())
                        } else {
                            None
                        }
                    }
                    _ => None,
                }
            };
            if let Some(why) = why {
                let pe = e.block.iter().flat_map(|(b, _)| b).find(|x| x.key.text == "predecessor");
                let span = pe.map(|p| p.span).unwrap_or(e.key.span);
                found.push(err("E0804", span, format!("rule `{}` can never match", r.id)).with_label(why));
            } else if !r.conditions.is_empty() {
                // W0802: its predecessor can match, but its conditions hold together
                // for no shape (every generation and count the evolution allows;
                // kinds no creature can have count 0).
                let absent: Vec<u32> = (0..t.kinds.len() as u32).filter(|k| !reach.contains(k)).collect();
                let bounds = cond::Bounds { max_g: tb::MAX_GENERATIONS, max_parts: t.evolve.maxparts, absent };
                let codes: Vec<&[CondOp]> = r.conditions.iter().map(|c| c.0.as_slice()).collect();
                if cond::never_hold(&codes, &bounds, NEVER_HOLD_BUDGET) == Some(true) {
                    let ce: Vec<&Entry> =
                        e.block.iter().flat_map(|(b, _)| b).filter(|x| x.key.text == "condition").collect();
                    let span = ce.first().map(|c| c.span).unwrap_or(e.key.span);
                    let mut d = Diagnostic::warning("W0802", span, format!("rule `{}` can never match", r.id))
                        .with_label(if ce.len() > 1 {
                            "these conditions hold together for no shape"
                        } else {
                            "this condition holds for no shape"
                        })
                        .with_note(format!(
                            "checked at every generation g = 1..{} and every count a shape of at most {} meta-parts (maxparts) can have{}",
                            tb::MAX_GENERATIONS,
                            t.evolve.maxparts,
                            if bounds.absent.is_empty() { "" } else { "; parts(…) of a type no creature can have is 0" }
                        ));
                    for c in ce.iter().skip(1) {
                        d = d.with_secondary(c.span, "and this one");
                    }
                    found.push(d);
                }
            }
        }
        self.diags.extend(found);
    }
}

/// The creature condition language (`docs/creatures.md`): the creature variables,
/// named constants, `parts(TYPE)`, deterministic built-ins; numbers without units.
/// A probability (`condition` false) may not read `complexity`.
struct Condition<'b, 'a, 'd> {
    b: &'b mut Builder<'a, 'd>,
    condition: bool,
}

impl Leaves<CondOp> for Condition<'_, '_, '_> {
    fn num(&mut self, n: &Number, out: &mut Vec<CondOp>) -> bool {
        if n.unit.is_some() {
            self.b.push(err("E0814", n.span, "numbers in creature expressions take no unit suffix"));
            return false;
        }
        out.push(CondOp::Push(n.value));
        true
    }

    fn var(&mut self, v: &Name, out: &mut Vec<CondOp>) -> bool {
        let condition = self.condition;
        if let Some(i) = VARIABLES.iter().position(|x| *x == v.text) {
            if i as u8 == cond::COMPLEXITY && !condition {
                self.b.push(
                    err("E0814", v.span, "a probability cannot read `complexity`")
                        .with_label("only conditions may")
                        .with_note(
                            "probabilities are checked at every value of their variables; C_s is not a whole number",
                        ),
                );
                return false;
            }
            out.push(CondOp::Var(i as u8));
            return true;
        }
        if let Some(c) = self.b.ex.constant(&v.text) {
            out.push(CondOp::Push(c));
            return true;
        }
        let allowed: Vec<&str> = VARIABLES.iter().copied().filter(|n| condition || *n != "complexity").collect();
        let mut d = err("E0814", v.span, format!("unknown name `{}` in a creature expression", v.text));
        d = match did_you_mean(&v.text, allowed.iter().copied()) {
            Some(s) => {
                d.with_label(format!("did you mean `{s}`?")).with_suggestion(format!("replace with `{s}`"), v.span, s)
            }
            None => d.with_note(format!("variables: {}; and `parts(TYPE)`", allowed.join(", "))),
        };
        self.b.push(d);
        false
    }

    fn call(&mut self, e: &Expr, f: &Name, args: &[Expr], out: &mut Vec<CondOp>) -> Call {
        if f.text == "parts" {
            return Call::Done(match args {
                [Expr { kind: ExprKind::Var(k), .. }] => match self.b.kind_index(k) {
                    Some(k) => {
                        out.push(CondOp::Parts(k));
                        true
                    }
                    None => false,
                },
                _ => {
                    self.b.push(err("E0814", e.span, "`parts` takes one part type: `parts(wing)`"));
                    false
                }
            });
        }
        let Some(func) = Func::from_name(&f.text) else {
            let names = Func::ALL.iter().filter(|f| !f.is_random()).map(|f| f.name()).chain(["parts"]);
            let mut d = err("E0814", f.span, format!("unknown function `{}`", f.text));
            if let Some(s) = did_you_mean(&f.text, names) {
                d = d.with_label(format!("did you mean `{s}`?"));
            }
            self.b.push(d);
            return Call::Done(false);
        };
        let (fname, arity) = (func.name(), func.arity());
        if func.is_random() {
            self.b.push(
                err("E0814", f.span, format!("`{fname}` is not allowed in a rule's condition or probability"))
                    .with_label("the evolution draws the branch itself")
                    .with_note("write the chance of the function branch as the probability"),
            );
            return Call::Done(false);
        }
        if args.len() != arity {
            self.b.push(err(
                "E0814",
                e.span,
                format!("`{fname}` takes {arity} argument{}", if arity == 1 { "" } else { "s" }),
            ));
            return Call::Done(false);
        }
        Call::Builtin(func)
    }
}
