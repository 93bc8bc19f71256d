//! Source sites: which rule and line an op belongs to, for warnings and `--sites`.

use super::*;

impl<'b> Eval<'b> {
    /// The rule holding op `pc` (see [`rule_in`]).
    pub(super) fn rule_of(&mut self, pc: u32) -> Option<&'b str> {
        let b = self.b;
        rule_in(self.def_starts.get_or_insert_with(|| def_starts(b)), b, pc)
    }

    /// The rule and source line of the op at `pc`.
    pub(super) fn site_of(&mut self, pc: u32) -> crate::output::Site {
        let (file, line) = self.b.source_of(pc).map(|(f, l)| (f.to_string(), l)).unwrap_or_default();
        crate::output::Site { rule: self.rule_of(pc).unwrap_or_default().to_string(), file, line }
    }
}

impl<'b> Eval<'b> {
    /// With `record_sites`, before the op at `pc` runs: the triangles made since the
    /// last note were drawn by the op that ran last.
    pub(super) fn note_site(&mut self, pc: u32) {
        let t = self.out.mesh.triangles.len();
        if t != self.site_mark {
            let site = match self.site_ids.get(&self.site_pc) {
                Some(&i) => i,
                None => {
                    // Ops of one line of one rule (the VERTEXes of a face) are one site.
                    let new = self.site_of(self.site_pc);
                    let sites = &mut self.out.sites.sites;
                    let i = sites.iter().rposition(|s| *s == new).unwrap_or_else(|| {
                        sites.push(new);
                        sites.len() - 1
                    }) as u32;
                    self.site_ids.insert(self.site_pc, i);
                    i
                }
            };
            let runs = &mut self.out.sites.runs;
            if runs.last().is_none_or(|r| r[1] != site) {
                runs.push([self.site_mark as u32, site]);
            }
            self.site_mark = t;
        }
        self.site_pc = pc;
    }
}

impl<'b> Eval<'b> {
    /// "FILE:LINE: " of a rule's first definition, or "".
    pub(super) fn rule_at(&self, rule: u32) -> String {
        let b = self.b;
        b.rules[rule as usize]
            .defs
            .first()
            .and_then(|d| b.source_of(d.start))
            .map(|(f, l)| format!("{f}:{l}: "))
            .unwrap_or_default()
    }
}

/// The name of the rule whose definition holds the op at `pc`.
pub(super) fn rule_of_op(b: &Bundle, pc: u32) -> Option<&str> {
    rule_in(&def_starts(b), b, pc)
}

/// Every rule definition's first op and the rule's name, sorted by op.
pub(super) fn def_starts(b: &Bundle) -> Vec<(u32, u32)> {
    let mut v: Vec<(u32, u32)> = b.rules.iter().flat_map(|r| r.defs.iter().map(move |d| (d.start, r.name))).collect();
    v.sort_unstable();
    v
}

/// The name of the rule whose definition holds op `pc`: the definition starting
/// last at or before it.
pub(super) fn rule_in<'b>(starts: &[(u32, u32)], b: &'b Bundle, pc: u32) -> Option<&'b str> {
    let i = starts.partition_point(|&(s, _)| s <= pc);
    starts.get(i.checked_sub(1)?).map(|&(_, n)| b.string(n))
}

/// " in rule `NAME` (FILE:LINE)" for the op at `pc`: the rule whose definition holds
/// it and the source line of the op, or "" when the bundle has no such information.
pub(super) fn where_op(b: &Bundle, pc: u32) -> String {
    let name = rule_of_op(b, pc).map(str::to_string);
    match (name, b.source_of(pc)) {
        (Some(n), Some((f, l))) => format!(" in rule `{n}` ({f}:{l})"),
        (Some(n), None) => format!(" in rule `{n}`"),
        (None, Some((f, l))) => format!(" at {f}:{l}"),
        (None, None) => String::new(),
    }
}
