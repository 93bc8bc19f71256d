//! Abstract shapes (paper §3.1): meta-parts grouped in super-parts attached to
//! torso super-parts, their structure graph, the structure complexity C_s and the
//! structure vector used for diversity control.

use super::error::ShapeError;
use super::table::{CreatureTable, Mode, ShapeDef};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A meta-part M(m0, m1, m2, m3, m4).
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct MetaPart {
    /// m0: its type (index into [`CreatureTable::kinds`]).
    pub kind: u32,
    /// m1: its id in the abstract shape.
    pub id: u32,
    /// m2: its geometry instance (index into [`CreatureTable::parts`]).
    pub geometry: u32,
}

/// Where a super-part is attached: a slot of a torso super-part.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Attachment {
    /// Index of the torso super-part in [`Shape::supers`] (m4 of its meta-parts).
    pub parent: u32,
    /// Slot index in the parent torso's part.
    pub slot: u32,
}

/// A super-part S(s0, s1, s2): meta-parts of one type in one region.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SuperPart {
    /// s0: the type.
    pub kind: u32,
    /// s1: the meta-parts, in arrangement order (m3 is the index here).
    pub metas: Vec<MetaPart>,
    /// s2: the arrangement mode.
    pub mode: Mode,
    /// `None` for the root torso.
    pub attach: Option<Attachment>,
    /// Symmetry group: super-parts with the same group are rewritten together.
    pub sym: u32,
}

/// An abstract shape: the 3D layout of a creature as super-parts.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Shape {
    /// Super-parts; index 0 is the root torso, and a parent always comes before
    /// the super-parts attached to it.
    pub supers: Vec<SuperPart>,
    /// The next free meta-part id.
    pub next_id: u32,
    /// The next free symmetry group id.
    pub next_sym: u32,
    /// Not subject to the stability test (from a `floats` regular creature, the
    /// base shape of every offspring passing it on).
    #[serde(default)]
    pub floats: bool,
}

/// ω in C_s = ω·n_e + Σ(v_i − v̄)².
pub const OMEGA: f64 = 0.95;

impl Shape {
    /// The abstract shape of a regular creature. Attaching to a slot with a mirror
    /// partner fills the partner too (one symmetry group).
    pub fn from_def(t: &CreatureTable, def: &ShapeDef) -> Shape {
        let mut s = Shape { supers: Vec::new(), next_id: 0, next_sym: 0, floats: def.floats };
        let torso_kind = t.parts.get(def.torso as usize).map(|p| p.kind).unwrap_or(0);
        let root_sym = s.new_sym();
        let torso_meta = s.new_meta(torso_kind, def.torso);
        s.supers.push(SuperPart {
            kind: torso_kind,
            metas: vec![torso_meta],
            mode: Mode::Def,
            attach: None,
            sym: root_sym,
        });
        for a in &def.attach {
            let kind = t.parts.get(a.part as usize).map(|p| p.kind).unwrap_or(0);
            let sym = s.new_sym();
            for slot in slot_and_partner(t, def.torso, a.slot) {
                let metas = (0..a.count).map(|_| s.new_meta(kind, a.part)).collect();
                let mode = if a.count > 1 { a.mode } else { Mode::Def };
                s.supers.push(SuperPart { kind, metas, mode, attach: Some(Attachment { parent: 0, slot }), sym });
            }
        }
        s
    }

    /// Checks a shape read from outside (a run's record) against the table: every
    /// index in range, parents before the super-parts attached to them, torsos
    /// with one meta-part, ids below `next_id`.
    pub fn check(&self, t: &CreatureTable) -> Result<(), ShapeError> {
        if self.supers.is_empty() {
            return Err(ShapeError::NoSuperParts);
        }
        for (i, sp) in self.supers.iter().enumerate() {
            let kind = t.kinds.get(sp.kind as usize).ok_or(ShapeError::NoKind { sup: i, kind: sp.kind })?;
            if sp.metas.is_empty() || (kind.torso && sp.metas.len() != 1) {
                return Err(ShapeError::MetaParts { sup: i, n: sp.metas.len() });
            }
            for m in &sp.metas {
                let part = t.parts.get(m.geometry as usize).ok_or(ShapeError::NoPart { sup: i, part: m.geometry })?;
                if m.kind != sp.kind || m.id >= self.next_id || (i > 0 && part.joint.is_none()) {
                    return Err(ShapeError::MetaDoesNotFit { sup: i, id: m.id });
                }
            }
            match sp.attach {
                None if i == 0 => {}
                Some(a) if (a.parent as usize) < i => {
                    let parent = &self.supers[a.parent as usize];
                    let torso = parent.metas.first().and_then(|m| t.parts.get(m.geometry as usize));
                    if !t.kinds.get(parent.kind as usize).is_some_and(|k| k.torso)
                        || torso.is_none_or(|p| a.slot as usize >= p.slots.len())
                    {
                        return Err(ShapeError::NotOnATorsoSlot { sup: i });
                    }
                }
                _ => return Err(ShapeError::BadAttachment { sup: i }),
            }
        }
        Ok(())
    }

    /// A fresh meta-part id.
    pub fn new_meta(&mut self, kind: u32, geometry: u32) -> MetaPart {
        let id = self.next_id;
        self.next_id += 1;
        MetaPart { kind, id, geometry }
    }

    /// A fresh symmetry group id.
    pub fn new_sym(&mut self) -> u32 {
        self.next_sym += 1;
        self.next_sym - 1
    }

    /// Number of meta-parts (nodes of the structure graph).
    pub fn n_metas(&self) -> usize {
        self.supers.iter().map(|s| s.metas.len()).sum()
    }

    /// Number of torso super-parts.
    pub fn n_torsos(&self, t: &CreatureTable) -> usize {
        self.supers.iter().filter(|s| t.kinds.get(s.kind as usize).is_some_and(|k| k.torso)).count()
    }

    /// The structure graph's edges as pairs of meta-part ids: every meta-part of
    /// an attached super-part is joined to the (first) torso meta-part of the
    /// super-part it is attached to.
    pub fn edges(&self) -> Vec<(u32, u32)> {
        let mut e = Vec::new();
        for sp in &self.supers {
            let Some(a) = sp.attach else { continue };
            let Some(parent) = self.supers.get(a.parent as usize).and_then(|p| p.metas.first()) else { continue };
            for m in &sp.metas {
                e.push((parent.id, m.id));
            }
        }
        e
    }

    /// Node valencies of the structure graph, in meta-part order.
    pub fn valencies(&self) -> Vec<u32> {
        let mut v: BTreeMap<u32, u32> = self.supers.iter().flat_map(|s| s.metas.iter().map(|m| (m.id, 0))).collect();
        for (a, b) in self.edges() {
            *v.entry(a).or_default() += 1;
            *v.entry(b).or_default() += 1;
        }
        v.into_values().collect()
    }

    /// Structure complexity C_s = ω·n_e + Σ_i (v_i − v̄)² (paper eq. 1, ω = 0.95).
    pub fn complexity(&self) -> f64 {
        let v = self.valencies();
        if v.is_empty() {
            return 0.0;
        }
        let n_e = self.edges().len() as f64;
        let mean = v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
        OMEGA * n_e + v.iter().map(|&x| (x as f64 - mean).powi(2)).sum::<f64>()
    }

    /// The structure vector: meta-part counts by (type, position), where the
    /// position is the slot (and, through the torso chain, the torso) it is at.
    /// Two shapes with equal vectors have the same structure.
    pub fn structure_vector(&self, t: &CreatureTable) -> BTreeMap<String, u32> {
        let mut v = BTreeMap::new();
        for i in 0..self.supers.len() {
            let sp = &self.supers[i];
            let key = format!("{}@{}", kind_name(t, sp.kind), self.position(t, i));
            *v.entry(key).or_default() += sp.metas.len() as u32;
        }
        v
    }

    /// Where super-part `i` is: `root`, or the slot names from the root torso down.
    pub fn position(&self, t: &CreatureTable, i: usize) -> String {
        let mut names = Vec::new();
        let mut at = i;
        let mut guard = 0;
        while let Some(a) = self.supers.get(at).and_then(|s| s.attach) {
            let parent = &self.supers[a.parent as usize];
            let torso_part = parent.metas.first().and_then(|m| t.parts.get(m.geometry as usize));
            names.push(torso_part.and_then(|p| p.slots.get(a.slot as usize)).map(|s| s.name.as_str()).unwrap_or("?"));
            at = a.parent as usize;
            guard += 1;
            if guard > self.supers.len() {
                break;
            }
        }
        if names.is_empty() {
            return "root".into();
        }
        names.reverse();
        names.join(".")
    }

    /// The abstract shape as text in the paper's notation, one super-part per
    /// term: `S0 torso[h_torso] def ; S1 head[h_head,h_head] midl_midr @neck→S0 ; …`.
    pub fn describe(&self, t: &CreatureTable) -> String {
        let mut out = Vec::new();
        for (i, sp) in self.supers.iter().enumerate() {
            let geo: Vec<&str> = sp
                .metas
                .iter()
                .map(|m| t.parts.get(m.geometry as usize).map(|p| p.name.as_str()).unwrap_or("?"))
                .collect();
            let mut term =
                format!("S{i} {}[{}] {}", kind_name(t, sp.kind), geo.join(","), sp.mode.label(sp.metas.len()));
            if sp.attach.is_some() {
                let at = self.position(t, i);
                let slot = at.rsplit('.').next().unwrap_or(&at);
                let parent = sp.attach.map(|a| a.parent).unwrap_or(0);
                term.push_str(&format!(" @{slot}→S{parent}"));
            }
            out.push(term);
        }
        out.join(" ; ")
    }

    /// Super-part indices attached (directly) to torso super-part `torso`.
    pub fn children(&self, torso: u32) -> impl Iterator<Item = usize> + '_ {
        self.supers.iter().enumerate().filter(move |(_, s)| s.attach.is_some_and(|a| a.parent == torso)).map(|(i, _)| i)
    }

    /// Removes super-parts `remove` (indices) and renumbers parents. Super-parts
    /// attached to a removed one are removed too.
    pub fn remove(&mut self, remove: &[usize]) {
        let mut gone = vec![false; self.supers.len()];
        for &i in remove {
            if let Some(g) = gone.get_mut(i) {
                *g = true;
            }
        }
        // Parents come first, so one forward pass propagates removal downwards.
        for i in 0..self.supers.len() {
            if let Some(a) = self.supers[i].attach {
                if gone.get(a.parent as usize).copied().unwrap_or(true) {
                    gone[i] = true;
                }
            }
        }
        let mut new_index = vec![u32::MAX; self.supers.len()];
        let mut kept = Vec::new();
        for (i, sp) in self.supers.drain(..).enumerate() {
            if !gone[i] {
                new_index[i] = kept.len() as u32;
                kept.push(sp);
            }
        }
        for sp in &mut kept {
            if let Some(a) = &mut sp.attach {
                a.parent = new_index[a.parent as usize];
            }
        }
        self.supers = kept;
    }
}

/// A kind's name ("?" when out of range).
pub fn kind_name(t: &CreatureTable, k: u32) -> &str {
    t.kinds.get(k as usize).map(|k| k.name.as_str()).unwrap_or("?")
}

/// The slot and its mirror partner (if any), original first.
pub fn slot_and_partner(t: &CreatureTable, part: u32, slot: u32) -> Vec<u32> {
    let mut v = vec![slot];
    if let Some(p) = t.parts.get(part as usize).and_then(|p| p.slots.get(slot as usize)).and_then(|s| s.partner) {
        v.push(p);
    }
    v.sort_unstable();
    v
}
