//! Rule-local retirement (`rule R maxdepth N > S { … }`, reference §4): Structure
//! Synth's `md N > S`. A definition with `maxdepth N` runs at most N times on one
//! call's path (its ancestors and itself); a further call that picks it runs S in its
//! place, at the same depth and state (S's parameters take their defaults), or
//! nothing without `> S`.
//!
//! Depth first, the path is the activation stack: each activation of a retiring
//! definition counts once while it runs (`open` records which to uncount on its
//! `RET`). Breadth first, a queued call carries the counts of its path. Only
//! bundles with such a definition pay for this (`any`); they never take the fast
//! path.

use super::*;

/// A retiring definition: its first op, `N` and the rule it retires into.
struct RetiringDef {
    start: u32,
    depth: u32,
    to: u32,
}

#[derive(Default)]
pub(super) struct Retirement {
    /// Whether any definition retires.
    pub(super) any: bool,
    /// The retiring definitions, by first op.
    defs: Vec<RetiringDef>,
    /// Runs of each retiring definition on the current path.
    pub(super) counts: Vec<u32>,
    /// Depth first: (activation level, definition) of each counted activation, and
    /// `u32::MAX` marks where a run (a nested one too) began.
    open: Vec<(u32, u32)>,
    /// Calls that retired with no rule to run instead, and the first one's `CALL`.
    pub(super) ended: u64,
    pub(super) first_ended: Option<u32>,
}

const RUN_MARK: (u32, u32) = (u32::MAX, u32::MAX);

impl Retirement {
    pub(super) fn new(b: &Bundle) -> Retirement {
        let mut defs: Vec<RetiringDef> = b
            .rules
            .iter()
            .flat_map(|r| &r.defs)
            .filter(|d| d.retire_depth > 0)
            .map(|d| RetiringDef { start: d.start, depth: d.retire_depth, to: d.retire_to })
            .collect();
        defs.sort_by_key(|d| d.start);
        Retirement { any: !defs.is_empty(), counts: vec![0; defs.len()], defs, ..Retirement::default() }
    }

    /// The retiring definition that starts at `pc`, if any.
    fn find(&self, pc: u32) -> Option<usize> {
        self.defs.binary_search_by_key(&pc, |d| d.start).ok()
    }

    /// A run begins: its counted activations are recorded above this mark.
    pub(super) fn begin_run(&mut self) {
        self.open.push(RUN_MARK);
    }

    /// A run ends (its last activation returned, or a limit stopped it): every
    /// activation it counted is uncounted.
    pub(super) fn end_run(&mut self) {
        while let Some(e) = self.open.pop() {
            if e == RUN_MARK {
                break;
            }
            self.counts[e.1 as usize] = self.counts[e.1 as usize].saturating_sub(1);
        }
    }

    /// An activation at `level` (its callers on the stack) runs the definition at
    /// `pc`: counted if it retires.
    pub(super) fn enter(&mut self, pc: u32, level: usize) {
        if let Some(i) = self.find(pc) {
            self.counts[i] += 1;
            self.open.push((level as u32, i as u32));
        }
    }

    /// The activation at `level` returns: uncounted if it was counted.
    pub(super) fn leave(&mut self, level: usize) {
        if let Some(&(l, i)) = self.open.last() {
            if l == level as u32 && (l, i) != RUN_MARK {
                self.open.pop();
                self.counts[i as usize] = self.counts[i as usize].saturating_sub(1);
            }
        }
    }
}

impl<'b> Eval<'b> {
    /// A call of `rule` that picked the definition at `pc`, in state `child` at
    /// `depth`, its arguments at `slots[args..]`: the rule and definition it runs
    /// once retirement is applied, or `None` when it runs nothing. A retired call's
    /// replacement takes its parameters' defaults. `call_pc` is the `CALL` (for the
    /// warning).
    pub(super) fn retired(
        &mut self,
        mut rule: RuleId,
        mut pc: u32,
        child: &State,
        depth: u32,
        args: usize,
        call_pc: u32,
    ) -> Option<(RuleId, u32)> {
        // (Each step retires a definition whose count is full; a cycle of retired
        // definitions runs nothing.)
        for _ in 0..=self.retire.defs.len() {
            let Some(i) = self.retire.find(pc) else { return Some((rule, pc)) };
            let d = &self.retire.defs[i];
            if self.retire.counts[i] < d.depth {
                return Some((rule, pc));
            }
            if d.to == NONE {
                break;
            }
            rule = RuleId(d.to);
            let r = &self.b.rules[rule];
            self.slots.truncate(args);
            self.slots.extend(r.params.iter().map(|d| d.unwrap_or(0.0)));
            pc = match r.defs.as_slice() {
                [only] => only.start,
                _ => self.select(rule, child, depth, args),
            };
        }
        self.retire.ended += 1;
        self.retire.first_ended.get_or_insert(call_pc);
        None
    }
}
