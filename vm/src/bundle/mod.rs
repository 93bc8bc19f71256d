//! The bundle (`.mdgb`): a compiled grammar as deterministic bytes.
//!
//! Layout: header (magic `MDGB`, format version, flags, FNV-1a 64 checksum of the
//! payload, payload length), then the payload: sections in a fixed order — strings,
//! settings, transforms, expressions, rules, code, isosurfaces, shaders (GLSL and
//! SPIR-V), program, uniforms, params, source map. All integers little-endian; lists are a u32 count then elements.
//! [`decode`] checks every length against the remaining bytes and [`verify`] every
//! index and jump, so a corrupt or hostile bundle is rejected with an error, never
//! a panic.

mod codec;
mod disasm;
pub mod ops;
pub mod proto;
mod section;
pub mod spirv;
mod verify;

pub use codec::{decode, encode};
pub use disasm::{disassemble, expr_text};
pub use ops::{
    Drawable, ExprId, IsoId, NsId, Op, OpCount, OpIndex, Profile, ProtoId, RuleId, SlotId, TransformId, CONT_NEXT,
    NONE, PATH_OP, SUBPATH,
};
pub use section::{Extensions, Section, SectionError, SectionKind};
pub use verify::verify;

use crate::expr::ExprOp;

/// File magic.
pub const MAGIC: [u8; 4] = *b"MDGB";
/// Format version; bumped on any change to the layout.
pub const VERSION: u16 = 10;

/// A precomputed adjustment list: thesis eqs. 4.1–4.9 folded into (q, q̂, u) plus
/// colour, weight and fps deltas (SPEC §4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Composite {
    /// x, y, z, w.
    pub q: [f32; 4],
    pub qh: [f32; 4],
    pub u: [f32; 3],
    pub color: [f32; 4],
    pub weight: [f32; 4],
    pub fps: f32,
    /// The world-side general linear factor of a list with a non-uniform scale
    /// (`s X Y Z`), column-major; `None` for the identity (see `geom::quat`).
    pub n: Option<[f32; 9]>,
    /// Hue, saturation and brightness adjustments (`hue`, `sat`, `b`), applied after
    /// the RGBA deltas: `[hue degrees, sat ×, sat +, bright ×, bright +]` (saturation
    /// and brightness changes are affine maps of the channel, so a list of them folds
    /// into one). `None` when the list has none.
    pub hsb: Option<[f32; 5]>,
    /// A colour value (`#ff8800`) in the list: the colour is set to this RGBA before
    /// the deltas and the HSB part are applied (those written before it are dropped,
    /// as the value replaces what they did). `None` when the list has none.
    pub set: Option<[f32; 4]>,
}

/// The identity of [`Composite::hsb`].
pub const HSB_IDENTITY: [f32; 5] = [0.0, 1.0, 0.0, 1.0, 0.0];

impl Composite {
    /// The identity transform with no deltas.
    pub const IDENTITY: Composite = Composite {
        q: [0.0, 0.0, 0.0, 1.0],
        qh: [0.0, 0.0, 0.0, 1.0],
        u: [0.0; 3],
        color: [0.0; 4],
        weight: [0.0; 4],
        fps: 0.0,
        n: None,
        hsb: None,
        set: None,
    };
}

/// What a run-time adjustment does (one byte in the bundle).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u8)]
pub enum AdjOp {
    /// Translate along one axis, or by (X, Y, Z) with axis 3.
    Translate = 0,
    /// Rotate about one axis, or about x, then y, then z with axis 3.
    Rotate = 1,
    /// Scale: one argument uniform; two or three per axis (`s X Y [Z]`).
    Scale = 2,
    /// Mirror across the plane normal to an axis, or to the arguments' vector (axis 3).
    Flip = 3,
    /// Add to the colour component `axis` (R, G, B, A).
    Color = 4,
    /// Add to the weight component `axis`.
    Weight = 5,
    /// Add to the frames per second of the subtree.
    Fps = 6,
    /// Hue (axis 0), saturation (1) or brightness (2), Context Free's meaning.
    Hsb = 7,
    /// Set the colour to the four constant arguments (R, G, B, A): a colour value.
    Paint = 8,
    /// Skew by the angles X and Y (radians), Context Free's `skew`: x += tan X · y,
    /// y += tan Y · x.
    Skew = 9,
}

impl AdjOp {
    /// Every op, in byte order.
    pub const ALL: [AdjOp; 10] = [
        AdjOp::Translate,
        AdjOp::Rotate,
        AdjOp::Scale,
        AdjOp::Flip,
        AdjOp::Color,
        AdjOp::Weight,
        AdjOp::Fps,
        AdjOp::Hsb,
        AdjOp::Paint,
        AdjOp::Skew,
    ];

    /// The op of a bundle byte.
    pub fn from_byte(b: u8) -> Option<AdjOp> {
        AdjOp::ALL.get(b as usize).copied()
    }

    /// The most arguments the op takes.
    pub fn max_args(self) -> usize {
        match self {
            AdjOp::Translate | AdjOp::Rotate | AdjOp::Scale | AdjOp::Flip => 3,
            AdjOp::Color | AdjOp::Weight | AdjOp::Fps | AdjOp::Hsb => 1,
            AdjOp::Paint => 4,
            AdjOp::Skew => 2,
        }
    }

    /// The op's name without an axis (`translate`, `hsb`).
    pub fn family(self) -> &'static str {
        ["translate", "rotate", "scale", "flip", "color", "weight", "fps", "hsb", "paint", "skew"][self as usize]
    }

    /// The op and axis as the disassembler prints them (`translate.x`, `hue`).
    pub fn name(self, axis: u8) -> String {
        let ax = ["x", "y", "z", "xyz"].get(axis as usize).copied().unwrap_or("?");
        match self {
            AdjOp::Translate => format!("translate.{ax}"),
            AdjOp::Rotate => format!("rotate.{ax}"),
            AdjOp::Scale => "scale".into(),
            AdjOp::Flip => format!("flip.{}", if axis == 3 { "normal" } else { ax }),
            AdjOp::Color => format!("color.{}", ["r", "g", "b", "a"].get(axis as usize).unwrap_or(&"?")),
            AdjOp::Weight => format!("weight.{axis}"),
            AdjOp::Fps => "fps".into(),
            AdjOp::Hsb => ["hue", "sat", "b"].get(axis as usize).unwrap_or(&"hsb?").to_string(),
            AdjOp::Paint => "paint".into(),
            AdjOp::Skew => "skew".into(),
        }
    }
}

/// A primitive adjustment evaluated at run time (when an argument draws random numbers).
#[derive(Clone, Debug, PartialEq)]
pub struct PrimAdj {
    pub kind: AdjOp,
    /// For translate/rotate: 0..2 a single axis, 3 all three (`x X Y Z`, `r X Y Z`);
    /// for flip: 0..2 axis, 3 a normal from the arguments; for colour/weight: component;
    /// for HSB: 0 hue, 1 saturation, 2 brightness.
    pub axis: u8,
    /// Argument values: constants or expression indices.
    pub args: Vec<Arg>,
}

/// A run-time adjustment argument.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Arg {
    Const(f32),
    /// Index into [`Bundle::exprs`]; angles already converted to radians by the
    /// expression (the compiler multiplies by the angle unit).
    Expr(u32),
}

/// A transform operand: a constant composite or a list evaluated per use.
#[derive(Clone, Debug, PartialEq)]
pub enum Transform {
    Const(Composite),
    /// Primitive adjustments in written order; angles in radians; every argument is
    /// divided by `divisor` (scale: the divisor-th root) for iterator steps.
    Dynamic {
        adjs: Vec<PrimAdj>,
        divisor: f32,
    },
}

/// How a rule's definitions are chosen (SPEC §5 and resolved semantics 5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Selector {
    Random,
    Depth,
    Scale,
    Sequential,
    Pattern,
    /// Value of expression `e` selects like depth selection.
    Function(u32),
}

/// One definition of a rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Def {
    pub weight: f32,
    /// An expression over the rule's parameters that gives the weight per call
    /// (`rule leaf(int n) (1 / (n + 1))`), or [`NONE`] for the constant `weight`.
    pub weight_expr: u32,
    /// Index of its first op in [`Bundle::code`] (op index, not byte offset).
    pub start: u32,
    /// Rule-local retirement (`rule R maxdepth N > S`): with N (0 = none) runs of
    /// this definition on a call's path, a call that picks it runs `retire_to`
    /// instead (a rule index, or [`NONE`]: nothing).
    pub retire_depth: u32,
    pub retire_to: u32,
}

/// A rule with all its definitions.
#[derive(Clone, Debug, PartialEq)]
pub struct Rule {
    /// String index of the full name (`ns.NAME`).
    pub name: u32,
    pub selector: Selector,
    pub defs: Vec<Def>,
    /// Transform rules (`: X1 : X2`), rule indices.
    pub transforms: Vec<u32>,
    /// Iterator rule (`* I`), or [`NONE`].
    pub iter: u32,
    /// One entry per parameter (`rule tree(int n, float len = 1)`): its default value,
    /// if it has one. A call passes exactly this many `ARG`s; a run that starts at the
    /// rule (start shape, profile, transform or iterator rule) uses the defaults (the
    /// compiler requires them there; a missing one reads 0).
    pub params: Vec<Option<f64>>,
    /// Slots in an activation of the rule: the parameters, then the `let` bindings and
    /// loop variables of its largest definition. Expressions read them with
    /// `ExprOp::Slot`; the verifier checks every slot index against this.
    pub frame: u16,
}

/// An isosurface declaration.
#[derive(Clone, Debug, PartialEq)]
pub struct Isosurface {
    pub name: u32,
    pub min: [f32; 3],
    pub max: [f32; 3],
    pub res: [u32; 3],
    /// Expression over x, y, z.
    pub function: u32,
}

/// A shader block: its GLSL source and the SPIR-V the compiler made of it.
#[derive(Clone, Debug, PartialEq)]
pub struct Shader {
    /// Vertex (`@vertexshader`) or fragment (`@fragmentshader`) stage.
    pub vertex: bool,
    pub name: u32,
    /// String index of the GLSL source, kept for tools and error messages.
    pub source: u32,
    /// SPIR-V words (first word [`SPIRV_MAGIC`]); empty when the compiler did not
    /// compile it (a bundle lowered without the shader stage, in unit tests).
    pub spirv: Vec<u32>,
}

/// The first word of every SPIR-V module.
pub const SPIRV_MAGIC: u32 = 0x0723_0203;

/// The `program` directive: which shaders draw the model. A stage left out
/// ([`NONE`]) uses the viewer's default (std Phong) shader for that stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Program {
    /// Index into [`Bundle::shaders`] of a vertex shader, or [`NONE`].
    pub vertex: u32,
    /// Index into [`Bundle::shaders`] of a fragment shader, or [`NONE`].
    pub fragment: u32,
}

/// What a `uniform` directive reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum UniformSource {
    /// `uniform NAME x [y [z [w]]]`: missing components are 0.
    Const([f32; 4]),
    /// `uniform NAME RULE PROP`: the current frame of transform rule `rule`;
    /// `prop` indexes [`UNIFORM_PROPS`].
    Frame { rule: u32, prop: u8 },
}

/// The frame properties a `uniform NAME RULE PROP` can read, by index.
pub const UNIFORM_PROPS: [&str; 6] = ["pos", "dir", "conj", "color", "weight", "normal"];

/// A `uniform` directive, in the order written.
#[derive(Clone, Debug, PartialEq)]
pub struct Uniform {
    pub name: u32,
    pub source: UniformSource,
}

/// A `@param` with the value compiled in.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    pub name: u32,
    /// 0 int, 1 float, 2 bool.
    pub ty: u8,
    pub value: f64,
    pub min: f64,
    pub max: f64,
}

/// Where an op came from: (op index, file string index, 1-based line).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SourceLoc {
    pub op: u32,
    pub file: u32,
    pub line: u32,
}

/// Global settings from directives.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub startshape: u32,
    /// 0 = unlimited.
    pub maxdepth: u32,
    pub minsize: f32,
    /// 0 = the evaluator's default.
    pub maxiter: u64,
    /// 0 = the evaluator's default.
    pub stacksize: u32,
    pub randseed: u64,
    pub normal: [f32; 3],
    pub background: [f32; 4],
    pub fps: f32,
    pub duration: f32,
    pub camerafov: f32,
    pub near: f32,
    pub far: f32,
    /// Rule indices or [`NONE`].
    pub linerule: u32,
    pub camerarule: u32,
    /// Namespace names (string indices); index 0 is the global namespace "".
    pub namespaces: Vec<u32>,
    /// The `flat` directive: Context Free's flat-art mode (black shapes from the start,
    /// painted in derivation order, unlit; reference §3).
    pub flat: bool,
    /// `breadthfirst`: calls run generation by generation (a queue) instead of depth
    /// first (reference §3, "Breadth first").
    pub breadth: bool,
    /// `maxobjects N` (0 = none; only with `breadth`): the run ends after the
    /// generation in which the N-th object was drawn.
    pub maxobjects: u64,
}

/// A whole compiled grammar.
#[derive(Clone, Debug, PartialEq)]
pub struct Bundle {
    pub strings: Vec<String>,
    pub settings: Settings,
    pub transforms: Vec<Transform>,
    pub exprs: Vec<Vec<ExprOp>>,
    pub rules: Vec<Rule>,
    /// Decoded ops (stored encoded; see [`ops`]).
    pub code: Vec<Op>,
    pub isosurfaces: Vec<Isosurface>,
    pub shaders: Vec<Shader>,
    /// The `program` directive, if any.
    pub program: Option<Program>,
    /// `uniform` directives in source order.
    pub uniforms: Vec<Uniform>,
    pub params: Vec<Param>,
    pub source_map: Vec<SourceLoc>,
    /// The SPEC §11 extension tables, as sections their crates decode (see [`Section`]).
    pub extensions: Extensions,
}

impl Bundle {
    /// A bundle with no rules and the default settings of an empty program (used to
    /// render outputs that were not made by one bundle, e.g. assembled creatures).
    pub fn empty() -> Bundle {
        Bundle {
            strings: vec![String::new()],
            settings: Settings {
                startshape: 0,
                maxdepth: 0,
                minsize: 0.0,
                maxiter: 0,
                stacksize: 0,
                randseed: 0,
                normal: [0.0, 0.0, 1.0],
                background: [0.12, 0.12, 0.14, 1.0],
                fps: 30.0,
                duration: 10.0,
                camerafov: 40.0,
                near: 0.1,
                far: 1000.0,
                linerule: NONE,
                camerarule: NONE,
                namespaces: vec![0],
                flat: false,
                breadth: false,
                maxobjects: 0,
            },
            transforms: vec![],
            exprs: vec![],
            rules: vec![],
            code: vec![],
            isosurfaces: vec![],
            shaders: vec![],
            program: None,
            uniforms: vec![],
            params: vec![],
            source_map: vec![],
            extensions: Extensions::default(),
        }
    }

    /// A string by index ("?" if out of range; verified bundles are always in range).
    pub fn string(&self, i: u32) -> &str {
        self.strings.get(i as usize).map(|s| s.as_str()).unwrap_or("?")
    }

    /// The source location of op `op`: the nearest entry at or before it.
    pub fn source_of(&self, op: u32) -> Option<(&str, u32)> {
        let i = self.source_map.partition_point(|s| s.op <= op);
        let loc = self.source_map.get(i.checked_sub(1)?)?;
        Some((self.string(loc.file), loc.line))
    }

    /// The `@param` declarations as one line of JSON, for editors (the live
    /// preview's sliders): `[{"name", "type": "int"|"float"|"bool", "value", "min",
    /// "max"}]` in declaration order; `value` is the one in force (the default or a
    /// `--param` override); `min`/`max` are `null` where the line declares no range.
    pub fn params_json(&self) -> String {
        let list: Vec<serde_json::Value> = self
            .params
            .iter()
            .map(|p| {
                let ty = match p.ty {
                    0 => "int",
                    1 => "float",
                    _ => "bool",
                };
                let ranged = p.ty != 2 && !(p.min == 0.0 && p.max == 0.0);
                let num = |v: f64| serde_json::Number::from_f64(v).map(serde_json::Value::Number);
                serde_json::json!({
                    "name": self.string(p.name),
                    "type": ty,
                    "value": num(p.value),
                    "min": if ranged { num(p.min) } else { None },
                    "max": if ranged { num(p.max) } else { None },
                })
            })
            .collect();
        serde_json::Value::Array(list).to_string()
    }
}

/// Why a bundle could not be loaded.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LoadError(pub String);

impl std::fmt::Display for LoadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "invalid bundle: {}", self.0)
    }
}

impl std::error::Error for LoadError {}

/// FNV-1a 64-bit hash (the payload check value).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= *b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Decodes and verifies: the only way the VM accepts bytes.
pub fn load(bytes: &[u8]) -> Result<Bundle, LoadError> {
    let b = decode(bytes)?;
    verify(&b)?;
    Ok(b)
}

/// Declares `table[id]` for the tables an op operand indexes, so the interpreter and
/// the verifier index with the operand itself.
macro_rules! typed_index {
    ($($id:ty => $item:ty),* $(,)?) => {$(
        impl std::ops::Index<$id> for Vec<$item> {
            type Output = $item;
            #[inline(always)]
            fn index(&self, id: $id) -> &$item {
                &self[id.index()]
            }
        }
    )*};
}

typed_index! {
    RuleId => Rule,
    TransformId => Transform,
    ExprId => Vec<ExprOp>,
    IsoId => Isosurface,
}

#[cfg(test)]
mod params_tests {
    use super::*;

    #[test]
    fn params_json_lists_declarations_in_order_with_ranges() {
        let mut b = Bundle::empty();
        for n in ["levels", "spread", "leafy", "free"] {
            b.strings.push(n.into());
        }
        b.params = vec![
            Param { name: 1, ty: 0, value: 5.0, min: 1.0, max: 7.0 },
            Param { name: 2, ty: 1, value: 32.5, min: 5.0, max: 60.0 },
            Param { name: 3, ty: 2, value: 1.0, min: 0.0, max: 0.0 },
            Param { name: 4, ty: 1, value: -2.0, min: 0.0, max: 0.0 },
        ];
        assert_eq!(
            b.params_json(),
            r#"[{"max":7.0,"min":1.0,"name":"levels","type":"int","value":5.0},{"max":60.0,"min":5.0,"name":"spread","type":"float","value":32.5},{"max":null,"min":null,"name":"leafy","type":"bool","value":1.0},{"max":null,"min":null,"name":"free","type":"float","value":-2.0}]"#
        );
        assert_eq!(Bundle::empty().params_json(), "[]");
    }
}
