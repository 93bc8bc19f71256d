//! The creature table: what a program's `creature` section compiles to (part
//! library, allelic families, regular creatures, structure rules, selection and
//! evolution settings), and its verifier.
//!
//! Indices are plain `u32`s into the table's own lists (`kinds`, `categories`,
//! `parts`, `meshes`) or into the bundle's rules; [`CreatureTable::verify`] checks
//! every one of them, so the evolution code can index without panicking.

use super::cond::CondOp;
use super::error::{Place, Problem, TableError};
use serde::{Deserialize, Serialize};

/// What a program's `creature` section compiles to.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CreatureTable {
    /// The section's name (`creature monsters { … }`), or empty.
    pub name: String,
    /// Part types (meta-part types m0): `torso`, `head`, `arm`, …
    pub kinds: Vec<Kind>,
    /// Categories of regular creatures: `humanoid`, `bird`, `quadruped`, …
    pub categories: Vec<String>,
    /// The meta-part geometry library.
    pub parts: Vec<PartDef>,
    /// Allelic families: kinds whose super-parts can replace each other.
    pub families: Vec<Vec<u32>>,
    /// The regular creatures the evolution starts from.
    pub shapes: Vec<ShapeDef>,
    /// Structure rules.
    pub rules: Vec<RuleDef>,
    /// How base and assist shapes are selected.
    pub select_shapes: Strategy,
    /// How a structure rule is selected among the applicable ones.
    pub select_rules: Strategy,
    pub evolve: EvolveSettings,
    /// Meshes imported from OBJ files, embedded so the bundle is self-contained.
    pub meshes: Vec<PartMesh>,
}

/// A part type.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Kind {
    pub name: String,
    /// Torso kinds carry slots; every other kind attaches to a torso by its joint.
    pub torso: bool,
}

/// Where a part's geometry comes from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Geometry {
    /// An MDG rule (bundle rule index), evaluated once per run.
    Rule(u32),
    /// An embedded mesh (index into [`CreatureTable::meshes`]).
    Mesh(u32),
}

/// A meta-part in the library: one geometry instance with its slots.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PartDef {
    pub name: String,
    /// Index into [`CreatureTable::kinds`].
    pub kind: u32,
    /// Index into [`CreatureTable::categories`].
    pub category: u32,
    pub geometry: Geometry,
    /// Where the part attaches to a torso (every non-torso part has one; a torso
    /// has one when it can ride on another torso, as in a Centaur).
    pub joint: Option<Slot>,
    /// Where other parts attach (torsos only). Mirror slots follow their originals.
    pub slots: Vec<Slot>,
    /// The part stands on the ground (legs): its lowest points are support points.
    pub support: bool,
    /// Extra uniform scale applied after scaling to the slot (the paper's S_s).
    pub scale: f32,
}

/// A slot: a place on a part's surface where another part attaches.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Slot {
    pub name: String,
    /// Centre, in the part's own coordinates.
    pub at: [f32; 3],
    /// Outward unit normal.
    pub normal: [f32; 3],
    /// Unit vector orthogonal to `normal` fixing the twist about it.
    pub up: [f32; 3],
    /// Slot size (diameter); a part is scaled so its joint size matches.
    pub size: f32,
    /// Kinds that may attach here (the slot's own kinds and their allelic families).
    pub accepts: Vec<u32>,
    /// This slot is the mirror image (across x = 0) of slot `i` of the same part;
    /// parts attached here are mirrored copies of those attached there.
    pub mirror_of: Option<u32>,
    /// The mirror partner of this slot, either direction (symmetry group).
    pub partner: Option<u32>,
    /// Fine rotation applied in the slot frame, radians about x, y, z (in that order).
    pub turn: [f32; 3],
    /// Distance between copies in an arrangement, in the part's units; 0 = from
    /// the attached part's own width.
    pub spacing: f32,
}

/// How the meta-parts of a super-part are arranged around its slot.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Mode {
    /// One meta-part at the slot (`def`).
    #[default]
    Def,
    /// Side by side across the slot (`midl_midr` for two, `l_m_r` for three).
    Row,
    /// One above the other along the slot's up vector (`top_bottom`, `t_m_b`).
    Stack,
    /// Spread by angle about the slot's up vector from one point (`fan`).
    Fan,
}

impl Mode {
    /// All modes with their source names.
    pub const NAMES: [(&'static str, Mode); 4] =
        [("def", Mode::Def), ("row", Mode::Row), ("stack", Mode::Stack), ("fan", Mode::Fan)];

    /// The arrangement's name for `n` meta-parts, in the paper's style (`def`,
    /// `midl_midr`, `l_m_r`, `top_bottom`, …).
    pub fn label(self, n: usize) -> String {
        match (self, n) {
            (_, 0 | 1) => "def".into(),
            (Mode::Row | Mode::Def, 2) => "midl_midr".into(),
            (Mode::Row | Mode::Def, 3) => "l_m_r".into(),
            (Mode::Row | Mode::Def, n) => format!("row{n}"),
            (Mode::Stack, 2) => "top_bottom".into(),
            (Mode::Stack, 3) => "t_m_b".into(),
            (Mode::Stack, n) => format!("stack{n}"),
            (Mode::Fan, n) => format!("fan{n}"),
        }
    }

    /// The position name of meta-part `k` of `n` (the paper's `midl`, `midr`, …).
    pub fn position(self, k: usize, n: usize) -> String {
        match (self, n, k) {
            (_, 0 | 1, _) => "def".into(),
            (Mode::Row | Mode::Def, 2, 0) => "midl".into(),
            (Mode::Row | Mode::Def, 2, _) => "midr".into(),
            (Mode::Row | Mode::Def, 3, 0) => "left".into(),
            (Mode::Row | Mode::Def, 3, 1) => "mid".into(),
            (Mode::Row | Mode::Def, 3, _) => "right".into(),
            (Mode::Stack, 2, 0) => "top".into(),
            (Mode::Stack, 2, _) => "bottom".into(),
            (m, _, k) => format!("{}{k}", m.label(1).replace("def", "p")),
        }
    }
}

/// A regular creature: a torso and the parts attached to its slots.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShapeDef {
    pub name: String,
    /// Part index of the torso.
    pub torso: u32,
    pub attach: Vec<AttachDef>,
    /// `floats`: the creature does not stand (a swimmer, a flier): it and the
    /// monsters evolved from it are not subject to the stability test.
    #[serde(default)]
    pub floats: bool,
}

/// `attach SLOT PART [COUNT [MODE]]` in a regular creature.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AttachDef {
    /// Slot index in the torso part (an original slot; its mirror partner is filled too).
    pub slot: u32,
    pub part: u32,
    pub count: u32,
    pub mode: Mode,
}

/// The four kinds of structure rules.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum RuleKind {
    /// Add copies of the meta-part to a super-part and re-arrange it.
    Increase,
    /// Add a super-part of a new type to a free torso slot.
    Insert,
    /// Exchange a super-part's meta-parts for those of an allelic type.
    Replace,
    /// Replace part of the shape with a torso and its parts from the assist shape.
    Combine,
}

impl RuleKind {
    pub const NAMES: [(&'static str, RuleKind); 4] = [
        ("increase", RuleKind::Increase),
        ("insert", RuleKind::Insert),
        ("replace", RuleKind::Replace),
        ("combine", RuleKind::Combine),
    ];

    /// The source name.
    pub fn name(self) -> &'static str {
        match self {
            RuleKind::Increase => "increase",
            RuleKind::Insert => "insert",
            RuleKind::Replace => "replace",
            RuleKind::Combine => "combine",
        }
    }
}

/// Expression code over [`VARIABLES`] (see [`super::cond`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Code(pub Vec<CondOp>);

/// A structure rule: `PRIORITY n  id : predecessor : cond → successor : p | predecessor : 1 − p`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RuleDef {
    /// The unique identifier (the rule's name in the source).
    pub id: String,
    pub kind: RuleKind,
    /// Higher priorities are tried first in every derivation step.
    pub priority: i32,
    /// Kinds of the super-parts the rule rewrites (for `insert`: the torso kinds it
    /// inserts into; for `combine`: the kinds it removes).
    pub predecessor: Vec<u32>,
    /// Only matches super-parts whose meta-parts come from this category.
    pub category: Option<u32>,
    /// All must be non-zero for the rule to apply.
    pub conditions: Vec<Code>,
    /// Probability of the function branch (else the identity branch).
    pub probability: Code,
    /// `increase`: copies added per application.
    pub add: u32,
    /// `increase`: the arrangement of the grown super-part.
    pub arrange: Mode,
    /// `increase`: at most this many meta-parts in one super-part.
    pub max: u32,
    /// `insert`: the kinds inserted; `replace`: the kinds replaced with (empty =
    /// any other kind of the predecessor's allelic family).
    pub successor: Vec<u32>,
    /// `insert` / `replace` / `combine`: the category the new parts come from.
    pub from: Option<u32>,
    /// `combine`: the kinds taken with the assist shape's torso.
    pub take: Vec<u32>,
}

/// A selection strategy (paper §3.2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Strategy {
    /// Linear ranking by the metric: the best is the most likely.
    Rank,
    /// Every member equally likely.
    Uniform,
    /// Likelihood proportional to the metric.
    #[default]
    Roulette,
}

impl Strategy {
    pub const NAMES: [(&'static str, Strategy); 3] =
        [("rank", Strategy::Rank), ("uniform", Strategy::Uniform), ("roulette", Strategy::Roulette)];

    /// The source name.
    pub fn name(self) -> &'static str {
        match self {
            Strategy::Rank => "rank",
            Strategy::Uniform => "uniform",
            Strategy::Roulette => "roulette",
        }
    }
}

/// `evolve { … }`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvolveSettings {
    /// Monsters presented per generation.
    pub population: u32,
    pub generations: u32,
    /// Size of the background set.
    pub background: u32,
    /// Offspring created per generation before diversity control.
    pub offspring: u32,
    /// Derivation steps (passes over the priority tiers) per offspring.
    pub steps: u32,
    /// Tries per offspring until one passes the stability test.
    pub attempts: u32,
    /// Offspring with more meta-parts than this are rejected.
    pub maxparts: u32,
    /// Seed of the evolution (overridden by `--seed`).
    pub seed: u64,
    /// `stability on|off`: whether offspring must pass the stability test.
    #[serde(default = "stability_default")]
    pub stability: bool,
}

fn stability_default() -> bool {
    true
}

impl Default for EvolveSettings {
    fn default() -> Self {
        EvolveSettings {
            population: 18,
            generations: 5,
            background: 36,
            offspring: 54,
            steps: 2,
            attempts: 24,
            maxparts: 24,
            seed: 1,
            stability: true,
        }
    }
}

/// Upper bounds the compiler and the verifier enforce (they also bound the
/// compile-time probability check, which evaluates every generation up to
/// [`MAX_GENERATIONS`]).
pub const MAX_GENERATIONS: u32 = 1000;
pub const MAX_POPULATION: u32 = 1000;
pub const MAX_PARTS: u32 = 64;
pub const MAX_STEPS: u32 = 16;
pub const MAX_ATTEMPTS: u32 = 1000;
/// Most meta-parts one super-part can hold.
pub const MAX_COUNT: u32 = 8;

/// An imported mesh (from an OBJ file), in the part's own coordinates.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PartMesh {
    /// The path as written in the source (for messages).
    pub path: String,
    pub positions: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
    /// RGBA colour of the whole mesh.
    pub color: [f32; 4],
}

fn finite(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl mdg_vm::bundle::Section for CreatureTable {
    const KIND: mdg_vm::bundle::SectionKind = mdg_vm::bundle::SectionKind::Creatures;
    fn check(&self, bundle: &mdg_vm::bundle::Bundle) -> Result<(), String> {
        self.verify(bundle).map_err(|e| e.to_string())
    }
}

impl CreatureTable {
    /// Checks every index against the table and the bundle, and every number for
    /// finiteness (called by `Section::from_bundle`).
    pub fn verify(&self, bundle: &mdg_vm::bundle::Bundle) -> Result<(), TableError> {
        let nk = self.kinds.len() as u32;
        let np = self.parts.len() as u32;
        let nc = self.categories.len() as u32;
        let kind_ok = |k: u32, at: &Place| {
            if k < nk {
                Ok(())
            } else {
                Err(TableError::at(at.clone(), Problem::KindOutOfRange(k)))
            }
        };
        if self.parts.is_empty() {
            return Err(TableError::NoParts);
        }
        if self.shapes.is_empty() {
            return Err(TableError::NoRegularCreatures);
        }
        for (i, m) in self.meshes.iter().enumerate() {
            let n = m.positions.len() as u32;
            if !m.positions.iter().all(|p| finite(p)) || !finite(&m.color) {
                return Err(TableError::at(Place::Mesh(i), Problem::NonFinite));
            }
            if m.triangles.iter().flatten().any(|&v| v >= n) {
                return Err(TableError::at(Place::Mesh(i), Problem::VertexOutOfRange));
            }
        }
        for p in &self.parts {
            let what = Place::Part(p.name.clone());
            let bad = |problem| Err(TableError::at(what.clone(), problem));
            kind_ok(p.kind, &what)?;
            if p.category >= nc {
                return bad(Problem::CategoryOutOfRange);
            }
            match p.geometry {
                Geometry::Rule(r) if (r as usize) < bundle.rules.len() => {}
                Geometry::Mesh(m) if (m as usize) < self.meshes.len() => {}
                _ => return bad(Problem::GeometryOutOfRange),
            }
            if !(p.scale.is_finite() && p.scale > 0.0) {
                return bad(Problem::BadScale);
            }
            let is_torso = self.kinds[p.kind as usize].torso;
            if !is_torso && p.joint.is_none() {
                return bad(Problem::NoJoint);
            }
            if !is_torso && !p.slots.is_empty() {
                return bad(Problem::SlotsOnNonTorso);
            }
            let ns = p.slots.len() as u32;
            for s in p.joint.iter().chain(&p.slots) {
                let sw = Place::Slot { part: p.name.clone(), slot: s.name.clone() };
                let bad = |problem| Err(TableError::at(sw.clone(), problem));
                if !(finite(&s.at) && finite(&s.normal) && finite(&s.up) && finite(&s.turn)) {
                    return bad(Problem::NonFinite);
                }
                if !(s.size.is_finite() && s.size > 0.0 && s.spacing.is_finite() && s.spacing >= 0.0) {
                    return bad(Problem::BadSizeOrSpacing);
                }
                let (n, u) = (glam::Vec3::from(s.normal), glam::Vec3::from(s.up));
                if (n.length() - 1.0).abs() > 1e-3 || (u.length() - 1.0).abs() > 1e-3 || n.dot(u).abs() > 1e-3 {
                    return bad(Problem::NotOrthonormal);
                }
                for &k in &s.accepts {
                    kind_ok(k, &sw)?;
                }
                if s.mirror_of.is_some_and(|m| m >= ns) || s.partner.is_some_and(|m| m >= ns) {
                    return bad(Problem::MirrorOutOfRange);
                }
            }
            for (i, s) in p.slots.iter().enumerate() {
                if let Some(m) = s.mirror_of {
                    let orig = &p.slots[m as usize];
                    if orig.mirror_of.is_some() || orig.partner != Some(i as u32) {
                        return bad(Problem::MirrorUnpaired { slot: s.name.clone() });
                    }
                }
            }
        }
        for f in &self.families {
            for &k in f {
                kind_ok(k, &Place::Family)?;
            }
        }
        for s in &self.shapes {
            let bad = |problem| TableError::at(Place::Shape(s.name.clone()), problem);
            let torso = self.parts.get(s.torso as usize).ok_or_else(|| bad(Problem::TorsoOutOfRange))?;
            if !self.kinds[torso.kind as usize].torso {
                return Err(bad(Problem::NotATorso));
            }
            for a in &s.attach {
                if a.slot as usize >= torso.slots.len() || a.part >= np {
                    return Err(bad(Problem::AttachOutOfRange));
                }
                if a.count == 0 || a.count > MAX_COUNT {
                    return Err(bad(Problem::BadCount));
                }
            }
        }
        for r in &self.rules {
            let what = Place::Rule(r.id.clone());
            let bad = |problem| TableError::at(what.clone(), problem);
            for &k in r.predecessor.iter().chain(&r.successor).chain(&r.take) {
                kind_ok(k, &what)?;
            }
            if r.category.is_some_and(|c| c >= nc) || r.from.is_some_and(|c| c >= nc) {
                return Err(bad(Problem::CategoryOutOfRange));
            }
            if r.max > MAX_COUNT || r.add > MAX_COUNT {
                return Err(bad(Problem::CountOutOfRange));
            }
            for c in r.conditions.iter().chain(std::iter::once(&r.probability)) {
                super::cond::verify(&c.0, nk).map_err(|e| bad(Problem::Condition(e)))?;
            }
        }
        let e = &self.evolve;
        if e.population == 0
            || e.population > MAX_POPULATION
            || e.generations > MAX_GENERATIONS
            || e.background > MAX_POPULATION
            || e.offspring == 0
            || e.offspring > MAX_POPULATION * 4
            || e.steps == 0
            || e.steps > MAX_STEPS
            || e.attempts == 0
            || e.attempts > MAX_ATTEMPTS
            || e.maxparts == 0
            || e.maxparts > MAX_PARTS
        {
            return Err(TableError::EvolveOutOfRange);
        }
        Ok(())
    }

    /// The index of a kind by name.
    pub fn kind(&self, name: &str) -> Option<u32> {
        self.kinds.iter().position(|k| k.name == name).map(|i| i as u32)
    }

    /// The allelic family of kind `k` (the kind alone when it is in none).
    pub fn family(&self, k: u32) -> Vec<u32> {
        self.families.iter().find(|f| f.contains(&k)).cloned().unwrap_or_else(|| vec![k])
    }
}
