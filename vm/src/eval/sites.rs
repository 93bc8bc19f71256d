//! Source sites: which rule and line an op belongs to, for warnings and `--sites`;
//! the recorded derivation tree (`record_derivation`).

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
    /// With `record_sites` or `record_derivation`, before the op at `pc` (of an
    /// activation at `depth`, of derivation node `node`) runs: the triangles and
    /// instances made since the last note were made by the op that ran last.
    #[inline]
    pub(super) fn note_site(&mut self, pc: u32, depth: u32, node: u32) {
        let o = &self.out;
        if o.mesh.triangles.len() != self.site_mark
            || o.sweeps.triangles.len() != self.sweep_mark
            || o.instances.len() != self.inst_mark
        {
            self.attribute();
        }
        self.site_pc = pc;
        self.site_depth = depth;
        self.site_node = node;
    }

    /// Gives what was made since the last note to the op that ran last: runs of its
    /// site and depth, and triangles to its derivation node.
    fn attribute(&mut self) {
        let (t, s, i) = (self.out.mesh.triangles.len(), self.out.sweeps.triangles.len(), self.out.instances.len());
        let (depth, node) = (self.site_depth, self.site_node);
        if self.opts.record_sites {
            let site = self.site_index(self.site_pc);
            let sites = &mut self.out.sites;
            for (runs, mark, now) in [
                (&mut sites.runs, self.site_mark, t),
                (&mut sites.sweep_runs, self.sweep_mark, s),
                (&mut sites.instance_runs, self.inst_mark, i),
            ] {
                if now != mark && runs.last().is_none_or(|r| r[1..] != [site, depth, node]) {
                    runs.push([mark as u32, site, depth, node]);
                }
            }
        }
        if let Some(tree) = self.tree.as_mut() {
            let shared = &self.out.shared_meshes;
            let instanced: usize = self
                .out
                .instances
                .range(self.inst_mark..i)
                .map(|inst| shared.get(inst.mesh as usize).map_or(0, |m| m.mesh.triangles.len()))
                .sum();
            let drawn = (t - self.site_mark) + (s - self.sweep_mark) + instanced;
            if let Some(n) = tree.nodes.get_mut(node as usize) {
                n.triangles += drawn as u64;
            }
        }
        (self.site_mark, self.sweep_mark, self.inst_mark) = (t, s, i);
    }

    /// The index in `out.sites.sites` of the op at `pc` (ops of one line of one
    /// rule, the VERTEXes of a face, are one site).
    fn site_index(&mut self, pc: u32) -> u32 {
        if let Some(&i) = self.site_ids.get(&pc) {
            return i;
        }
        let new = self.site_of(pc);
        let sites = &mut self.out.sites.sites;
        let i = sites.iter().rposition(|s| *s == new).unwrap_or_else(|| {
            sites.push(new);
            sites.len() - 1
        }) as u32;
        self.site_ids.insert(pc, i);
        i
    }

    /// With `record_derivation`, in a model run: the node of a call of `rule` at
    /// `depth` from node `parent` (`NONE` for a run's first call), counting the call.
    pub(super) fn call_node(&mut self, parent: u32, rule: u32, depth: u32) -> u32 {
        match self.tree.as_mut() {
            Some(t) => t.call(parent, rule, depth),
            None => 0,
        }
    }
}

/// A derivation being recorded ([`crate::output::Derivation`]).
#[derive(Default)]
pub(super) struct TreeRec {
    /// The nodes, with the bundle's rule index in `rule` until [`TreeRec::finish`].
    nodes: Vec<crate::output::DerivNode>,
    /// Per node, its children as (rule, node); `roots` for the runs' first calls.
    /// (A node has a few distinct callees: a scan beats hashing on every call.)
    children: Vec<Vec<(u32, u32)>>,
    roots: Vec<(u32, u32)>,
    cut: bool,
}

impl TreeRec {
    /// Counts a call of `rule` at `depth` from node `parent`; its node.
    fn call(&mut self, parent: u32, rule: u32, depth: u32) -> u32 {
        let known = match parent {
            NONE => &self.roots,
            p => match self.children.get(p as usize) {
                Some(c) => c,
                None => return 0,
            },
        };
        let n = match known.iter().find(|c| c.0 == rule) {
            // (A call below a node that counts deeper calls is at a depth past its
            // children's: counted in `parent` too.)
            Some(&(_, n)) if parent == NONE || self.nodes[n as usize].depth == depth => n,
            found => {
                let deeper = parent != NONE && self.nodes[parent as usize].depth + 1 != depth;
                if deeper || found.is_some() || depth > DERIVATION_MAX_DEPTH || self.nodes.len() >= DERIVATION_MAX_NODES
                {
                    // No node of its own: counted in `parent`.
                    self.cut = true;
                    if let Some(p) = self.nodes.get_mut(parent as usize) {
                        p.deeper += 1;
                    }
                    return parent;
                }
                let n = self.nodes.len() as u32;
                let up = (parent != NONE).then_some(parent);
                self.nodes.push(crate::output::DerivNode { rule, parent: up, depth, ..Default::default() });
                self.children.push(Vec::new());
                match parent {
                    NONE => self.roots.push((rule, n)),
                    p => self.children[p as usize].push((rule, n)),
                }
                n
            }
        };
        self.nodes[n as usize].calls += 1;
        n
    }

    /// The tree with subtree totals and a table of its rules.
    pub(super) fn finish(mut self, b: &Bundle) -> crate::output::Derivation {
        let mut rules: Vec<crate::output::Site> = Vec::new();
        let mut index: HashMap<u32, u32> = HashMap::new();
        for n in &mut self.nodes {
            n.total = n.triangles;
            let r = n.rule;
            n.rule = *index.entry(r).or_insert_with(|| {
                let def = b.rules.get(r as usize).and_then(|d| d.defs.first()).and_then(|d| b.source_of(d.start));
                let (file, line) = def.map(|(f, l)| (f.to_string(), l)).unwrap_or_default();
                let name = b.rules.get(r as usize).map_or("", |d| b.string(d.name)).to_string();
                rules.push(crate::output::Site { rule: name, file, line });
                rules.len() as u32 - 1
            });
        }
        // Children come after their parents: one backward pass sums the subtrees.
        for i in (0..self.nodes.len()).rev() {
            if let Some(p) = self.nodes[i].parent {
                let t = self.nodes[i].total;
                self.nodes[p as usize].total += t;
            }
        }
        let triangles = self.nodes.iter().filter(|n| n.parent.is_none()).map(|n| n.total).sum();
        crate::output::Derivation { rules, nodes: self.nodes, cut: self.cut, triangles }
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
