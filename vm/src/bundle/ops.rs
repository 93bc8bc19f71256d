//! The opcode table. Every opcode is declared once in [`for_each_op!`] with typed
//! operands; the `Op` enum, its encoder, decoder, the verifier's range checks and
//! the disassembly are generated from it (the interpreter matches on `Op`), so they
//! cannot drift apart.
//!
//! Notation: `start` is the frame an item starts from (the body's frame, the
//! iterator run's frame, or the continuation state after `\`); `X[x]` is transform
//! `x`; `last` is the continuation register (the frame of the last drawable).
//! Operand kinds, each its own type ([`index_operands!`]: the range check the
//! verifier makes and the text the disassembler writes come with the type): `r`
//! [`RuleId`], `x` [`TransformId`], `k` [`Drawable`], `n` [`NsId`], `p` [`Profile`]
//! (a rule or NONE), `i` [`IsoId`], `e` [`ExprId`], `s` [`SlotId`], `j` [`OpIndex`]
//! (a jump target or the other end of a block), `P` [`ProtoId`] (the ordinal of its
//! `INST` op in the code), `n` [`OpCount`], `c` a count (u64), `f` flags (u8).
//! Flags bit 0 (`CONT_NEXT`): the item is followed by `\`, so `last` is set to the
//! item's own frame before it runs (a drawable inside it then overrides it).

use super::Bundle;

/// Flag: the item is followed by `\`.
pub const CONT_NEXT: u8 = 1;

/// `DRAW` flag bit: a `MOVETO`/`LINETO` of a flat path (a rule definition that
/// paints a path, reference §9 "Flat paths"), not of the pen's 3D lines.
pub const PATH_OP: u8 = 2;

/// `CALL` flag bit: a call of a path from a path (Context Free's `path NAME`
/// subpath): the callee's points join the calling path, and its implied `FILL`
/// (one with [`path_bits::IMPLIED`]) does not paint.
pub const SUBPATH: u8 = 2;

/// The flat path options a path drawable's last argument carries, as bits (the
/// words after the drawable, `ARCTO(…) large_cw {}`); [`PATH_WORDS`] names them.
pub mod path_bits {
    pub const LARGE: u32 = 1;
    pub const CW: u32 = 2;
    pub const SMOOTH: u32 = 4;
    pub const ALIGN: u32 = 8;
    pub const EVENODD: u32 = 16;
    pub const ROUNDJOIN: u32 = 32;
    pub const BEVELJOIN: u32 = 64;
    pub const ROUNDCAP: u32 = 128;
    pub const SQUARECAP: u32 = 256;
    /// (Set by the compiler, not a word) a `CURVETO` with a second control point.
    pub const CUBIC: u32 = 512;
    /// (Set by the compiler for `MOVEREL`, `LINEREL`, `ARCREL`, `CURVEREL`, not a
    /// word) the point and a curve's control points are offsets from the current
    /// point, in the drawable's frame.
    pub const REL: u32 = 1024;
    /// (Set by the compiler, not a word) the `FILL` a path that paints nothing gets
    /// at its end: it does not paint when the path runs as a subpath of another.
    pub const IMPLIED: u32 = 2048;
    /// `STROKE … iso`: the pen is round in the drawn plane, `w·√(area scale)`
    /// wide, however the frame stretches it (Context Free's `CF::IsoWidth`).
    pub const ISO: u32 = 4096;
}

/// The option words of the path drawables, their bits and the drawable that takes
/// each (`miterjoin` and `buttcap` are the defaults and set no bit).
pub const PATH_WORDS: &[(&str, u32, &str)] = &[
    ("large", path_bits::LARGE, "ARCTO"),
    ("cw", path_bits::CW, "ARCTO"),
    ("smooth", path_bits::SMOOTH, "CURVETO"),
    ("align", path_bits::ALIGN, "CLOSEPOLY"),
    ("evenodd", path_bits::EVENODD, "FILL"),
    ("miterjoin", 0, "STROKE"),
    ("roundjoin", path_bits::ROUNDJOIN, "STROKE"),
    ("beveljoin", path_bits::BEVELJOIN, "STROKE"),
    ("buttcap", 0, "STROKE"),
    ("roundcap", path_bits::ROUNDCAP, "STROKE"),
    ("squarecap", path_bits::SQUARECAP, "STROKE"),
    ("iso", path_bits::ISO, "STROKE"),
];

/// How many `ARG`s a path drawable takes (the compiler always passes them all,
/// defaults filled in; the last is the option bits), or `None` for a drawable that
/// takes none: `MOVETO`/`LINETO` of a path (x, y), `ARCTO` (x, y, rx, ry, angle),
/// `CURVETO` (x, y, x1, y1, x2, y2), `CLOSEPOLY`, `FILL`, `STROKE` (width).
pub fn path_arity(kind: Drawable, flags: u8) -> Option<usize> {
    Some(match kind {
        Drawable::MoveTo | Drawable::LineTo if flags & PATH_OP != 0 => 3,
        Drawable::ArcTo => 6,
        Drawable::CurveTo => 7,
        Drawable::ClosePoly | Drawable::Fill => 1,
        Drawable::Stroke => 2,
        _ => return None,
    })
}

/// `LOOP`/`LOOPN` flag bit: the runs chain through `last` (`M * {T} \ ITEM`).
pub const LOOP_CHAIN: u8 = 1;
/// `LOOPN` flag bit: the first run is under the start frame itself and the step is
/// applied between runs (Context Free's `loop`), not before the first run too.
pub const LOOP_FIRST_PLAIN: u8 = 2;

/// Sentinel for "no rule" in `p` operands.
pub const NONE: u32 = u32::MAX;

/// Calls `$m!` with the whole opcode table:
/// `(byte, Variant, "MNEMONIC", { field: type, … }, "meaning")`.
#[macro_export]
macro_rules! for_each_op {
    ($m:ident) => {
        $m! {
            (0x01, Call, "CALL", { rule: RuleId, xf: TransformId, flags: u8 },
                "r x f    push frame; S := start ∘ X[x]; run the definition of rule r its selector picks");
            (0x02, Draw, "DRAW", { kind: Drawable, xf: TransformId, ns: NsId, profile: Profile, flags: u8 },
                "k x n p f  S := start ∘ X[x]; drawable k on namespace n's pen (profile rule p or NONE); last := S");
            (0x03, Iso, "ISO", { iso: IsoId, xf: TransformId, flags: u8 },
                "i x f    S := start ∘ X[x]; place an instance of isosurface i; last := S");
            (0x04, Loop, "LOOP", { count: u64, step: TransformId, end: OpIndex, chain: u8 },
                "c x j f  iterator: run the body up to ENDLOOP c times, run k under start ∘ X[x]^k; f=1 chains runs through last; if c = 0 jump past j");
            (0x05, EndLoop, "ENDLOOP", { begin: OpIndex },
                "j        next run of the LOOP at op j, or leave it");
            (0x06, Cont, "CONT", { },
                "         the next item starts from last (continuation)");
            (0x07, Ret, "RET", { },
                "         pop frame; return to the caller");
            (0x08, Arg, "ARG", { expr: ExprId },
                "e        push the value of e (in the caller's frame) as the next argument of the CALL that follows");
            (0x09, Set, "SET", { slot: SlotId, expr: ExprId },
                "s e      slot s := e (a `let` binding or a loop variable)");
            (0x0A, Jump, "JUMP", { target: OpIndex },
                "j        continue at op j (forward, within the definition and its loop)");
            (0x0B, JumpIfNot, "JUMPZ", { expr: ExprId, target: OpIndex },
                "e j      if e is 0 (false) or NaN, continue at op j (`if`/`else`)");
            (0x0C, LoopN, "LOOPN", { count: ExprId, step: TransformId, end: OpIndex, chain: u8 },
                "e x j f  LOOP whose count is expression e, evaluated once on entry (negative or NaN: 0 runs); f bit 1: the first run is under start itself");
            (0x0D, Inst, "INST", { proto: ProtoId, count: OpCount },
                "P n      the next n ops (VERTEX/FACENORMALS, constant transforms) are prototype P: one instance of P under start, skipping them; or run them one by one");
            (0x0E, Seed, "SEED", { expr: ExprId },
                "e        the CALL that follows (right after) runs its whole sub-derivation on the random stream of (run seed, e); the caller's stream resumes as if it drew nothing");
        }
    };
}

macro_rules! define_ops {
    ($( ($byte:expr, $name:ident, $mn:expr, { $($f:ident : $t:ty),* }, $doc:expr); )*) => {
        /// One decoded instruction.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum Op {
            $(
                #[doc = $doc]
                $name { $($f: $t),* },
            )*
        }

        impl Op {
            /// The opcode byte.
            pub fn byte(&self) -> u8 {
                match self { $(Op::$name { .. } => $byte,)* }
            }

            /// The mnemonic.
            pub fn mnemonic(&self) -> &'static str {
                match self { $(Op::$name { .. } => $mn,)* }
            }

            /// Appends the encoding (opcode byte, then operands little-endian).
            pub fn encode(&self, out: &mut Vec<u8>) {
                match *self {
                    $(Op::$name { $($f),* } => {
                        out.push($byte);
                        $( Operand::write($f, out); )*
                    })*
                }
            }

            /// Decodes one instruction at `pos`; returns it and its length.
            pub fn decode(code: &[u8], pos: usize) -> Result<(Op, usize), DecodeError> {
                let byte = *code.get(pos).ok_or(DecodeError::Truncated { at: pos })?;
                let mut at = pos + 1;
                #[allow(unused_macros)]
                macro_rules! read {
                    ($ty:ty) => {{
                        let (v, n) = <$ty as Operand>::read(code, at).ok_or(DecodeError::Truncated { at: pos })??;
                        at += n;
                        v
                    }};
                }
                let op = match byte {
                    $($byte => Op::$name { $($f: read!($t)),* },)*
                    other => return Err(DecodeError::UnknownOpcode { byte: other, at: pos }),
                };
                Ok((op, at - pos))
            }

            /// The operands as `name=value` pairs (numbers as stored).
            pub fn operands(&self) -> Vec<(&'static str, u64)> {
                match *self {
                    $(Op::$name { $($f),* } => vec![$((stringify!($f), Operand::value($f))),*],)*
                }
            }

            /// The operands as the disassembler writes them (rule names, `X3`, `@12`…).
            pub fn operand_texts(&self, b: &Bundle) -> Vec<String> {
                match *self {
                    $(Op::$name { $($f),* } => vec![$(Operand::show($f, stringify!($f), b)),*],)*
                }
            }

            /// Checks that every operand names an entry `b` has (a rule, a transform,
            /// an expression …): the verifier's range checks, one per operand type.
            pub fn check_operands(&self, b: &Bundle) -> Result<(), OperandError> {
                match *self {
                    $(Op::$name { $($f),* } => { $( Operand::check($f, b)?; )* Ok(()) })*
                }
            }
        }

        /// Every opcode: (byte, mnemonic, meaning), for documentation and tests.
        pub const OPCODES: &[(u8, &str, &str)] = &[$(($byte, $mn, $doc)),*];
    };
}

for_each_op!(define_ops);

/// An operand that names no entry of its table (the verifier's error).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OperandError {
    /// What the operand indexes (`rule`, `transform`, `namespace` …).
    pub what: &'static str,
    pub index: u64,
}

impl std::fmt::Display for OperandError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {} out of range", self.what, self.index)
    }
}

/// Why the bytes at a position are not an instruction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// The code ends inside the instruction that starts at byte `at`.
    Truncated { at: usize },
    /// The byte at `at` is no opcode.
    UnknownOpcode { byte: u8, at: usize },
    /// A drawable operand at byte `at` names no kind.
    UnknownDrawable { kind: u8, at: usize },
}

impl std::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            DecodeError::Truncated { at } => write!(f, "code ends inside an instruction at byte {at}"),
            DecodeError::UnknownOpcode { byte, at } => write!(f, "unknown opcode 0x{byte:02x} at byte {at}"),
            DecodeError::UnknownDrawable { kind, at } => write!(f, "unknown drawable kind {kind} at byte {at}"),
        }
    }
}

impl std::error::Error for DecodeError {}

/// An operand of the op table: little-endian bytes in the code, a range check
/// against the bundle's tables, and its disassembly.
pub trait Operand: Copy {
    /// Appends the encoding.
    fn write(self, out: &mut Vec<u8>);
    /// Decodes the operand at `at`: `None` when the code ends first, `Some(Err)` when
    /// the bytes are not a value of the type; else the value and its length.
    fn read(code: &[u8], at: usize) -> Option<Result<(Self, usize), DecodeError>>;
    /// The value as a number.
    fn value(self) -> u64;
    /// Whether the operand names an entry `b` has (the verifier's check; an error
    /// says what is out of range). Plain numbers are always in range.
    fn check(self, _b: &Bundle) -> Result<(), OperandError> {
        Ok(())
    }
    /// The operand as the disassembler writes it; `name` is its field's.
    fn show(self, name: &str, _b: &Bundle) -> String {
        format!("{name}={}", self.value())
    }
}

macro_rules! int_operands {
    ($($t:ty),*) => {$(
        impl Operand for $t {
            #[inline]
            fn write(self, out: &mut Vec<u8>) {
                out.extend_from_slice(&self.to_le_bytes());
            }
            #[inline]
            fn read(code: &[u8], at: usize) -> Option<Result<(Self, usize), DecodeError>> {
                const N: usize = std::mem::size_of::<$t>();
                let bytes: [u8; N] = code.get(at..at + N)?.try_into().ok()?;
                Some(Ok((<$t>::from_le_bytes(bytes), N)))
            }
            fn value(self) -> u64 {
                u64::from(self)
            }
        }
    )*};
}
int_operands!(u8, u16, u32, u64);

/// Declares the index operands: a newtype over the stored integer for each table an
/// op points into, with its range check and its disassembly (`$show` formats the
/// index, `$table` is the length of the table it indexes, if checked).
macro_rules! index_operands {
    ($( $(#[$doc:meta])* $name:ident($t:ty) $what:literal, |$b:ident, $v:ident| $table:expr, $show:expr; )*) => {$(
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub struct $name(pub $t);

        impl $name {
            /// The index into its table.
            #[inline(always)]
            pub fn index(self) -> usize {
                self.0 as usize
            }
        }

        impl Operand for $name {
            #[inline]
            fn write(self, out: &mut Vec<u8>) {
                self.0.write(out)
            }
            #[inline]
            fn read(code: &[u8], at: usize) -> Option<Result<(Self, usize), DecodeError>> {
                Some(<$t as Operand>::read(code, at)?.map(|(v, n)| ($name(v), n)))
            }
            fn value(self) -> u64 {
                u64::from(self.0)
            }
            #[allow(unused_variables)]
            fn check(self, $b: &Bundle) -> Result<(), OperandError> {
                let $v = self.0;
                let len: Option<usize> = $table;
                match len {
                    Some(n) if self.index() >= n => Err(OperandError { what: $what, index: u64::from(self.0) }),
                    _ => Ok(()),
                }
            }
            #[allow(unused_variables)]
            fn show(self, _name: &str, $b: &Bundle) -> String {
                let $v = self.0;
                $show
            }
        }
    )*};
}

index_operands! {
    /// A rule (`r`): an index into [`Bundle::rules`].
    RuleId(u32) "rule", |b, v| Some(b.rules.len()), b.string(b.rules.get(v as usize).map_or(0, |r| r.name)).to_string();
    /// A transform (`x`): an index into [`Bundle::transforms`].
    TransformId(u32) "transform", |b, v| Some(b.transforms.len()), format!("X{v}");
    /// An expression (`e`): an index into [`Bundle::exprs`].
    ExprId(u32) "expression", |b, v| Some(b.exprs.len()), format!("E{v}");
    /// A namespace (`n`): an index into the settings' namespaces (its pen).
    NsId(u32) "namespace", |b, v| Some(b.settings.namespaces.len()), format!("ns={v}");
    /// An isosurface (`i`): an index into [`Bundle::isosurfaces`].
    IsoId(u32) "isosurface", |b, v| Some(b.isosurfaces.len()), format!("iso={v}");
    /// A prototype (`P`): the ordinal of its `INST` op in the code (the verifier
    /// checks the order).
    ProtoId(u32) "prototype", |b, v| None, format!("P{v}");
    /// An op (`j`): a jump target or the other end of an iterator block.
    OpIndex(u32) "op", |b, v| Some(b.code.len()), format!("@{v}");
    /// A slot of the running rule's frame (`s`; the verifier checks it per body
    /// against the frame's size).
    SlotId(u16) "slot", |b, v| None, format!("s{v}");
    /// A number of ops (`n`): the items an `INST` covers.
    OpCount(u32) "op count", |b, v| None, format!("n={v}");
    /// A profile rule (`p`), or [`NONE`] for none.
    Profile(u32) "profile rule", |b, v| (v != NONE).then_some(b.rules.len()),
        if v == NONE { "-".to_string() } else { format!("profile={}", b.string(b.rules.get(v as usize).map_or(0, |r| r.name))) };
}

impl Profile {
    /// The profile rule, if any.
    #[inline]
    pub fn rule(self) -> Option<RuleId> {
        (self.0 != NONE).then_some(RuleId(self.0))
    }
}

/// Declares [`Drawable`] and [`DRAWABLE_KINDS`] from one list.
macro_rules! drawables {
    ($( $(#[$doc:meta])* $v:ident = $name:expr ),* $(,)?) => {
        /// The drawable a `DRAW` emits (operand `k`; one byte in the code).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        #[repr(u8)]
        pub enum Drawable {
            $( $(#[$doc])* $v, )*
        }

        /// Drawable names by kind byte, as the language spells them.
        pub const DRAWABLE_KINDS: &[&str] = &[$($name),*];

        impl Drawable {
            /// Every drawable, in kind-byte order.
            pub const ALL: &[Drawable] = &[$(Drawable::$v),*];

            /// The name in the language (`VERTEX`, `LINETO`, …).
            pub fn name(self) -> &'static str {
                DRAWABLE_KINDS[self as usize]
            }

            /// The drawable called `name` in the language.
            pub fn from_name(name: &str) -> Option<Drawable> {
                DRAWABLE_KINDS.iter().position(|n| *n == name).map(|i| Drawable::ALL[i])
            }
        }
    };
}

drawables! {
    /// A vertex at the frame's origin; every third closes a triangle.
    Vertex = "VERTEX",
    /// Recomputes the normals of the last three vertices (flat).
    FaceNormals = "FACENORMALS",
    /// Puts the pen down at the frame (a new polyline starts there).
    MoveTo = "MOVETO",
    /// A straight line (and a sweep of the profile) to the frame.
    LineTo = "LINETO",
    /// LINETO interpolating position, orientation and scale along a spline.
    BlendTo = "BLENDTO",
    /// LINETO with the profile orthogonal to the segment.
    SLineTo = "SLINETO",
    /// LINETO whose profile averages the two ends' orientations.
    ALineTo = "ALINETO",
    /// Lifts the pen: the next line starts a new polyline.
    NewLine = "NEWLINE",
    /// A frame sample of a transform rule (nothing in a model).
    Frame = "FRAME",
    /// Returns the transform to the namespace's last MOVETO/LINETO frame.
    Reset = "RESET",
    /// Reports the frame (position, scale, colour) in the run's debug lines.
    Debug = "DEBUG",
    /// A flat path's elliptical arc to the point (x, y).
    ArcTo = "ARCTO",
    /// A flat path's quadratic or cubic Bézier curve to the point (x, y).
    CurveTo = "CURVETO",
    /// Closes the flat path's current subpath.
    ClosePoly = "CLOSEPOLY",
    /// Paints the flat path's inside (non-zero or even-odd) as triangles.
    Fill = "FILL",
    /// Paints the flat path's outline with a width, as triangles.
    Stroke = "STROKE",
}

impl Operand for Drawable {
    fn show(self, _name: &str, _b: &Bundle) -> String {
        self.name().to_string()
    }
    fn write(self, out: &mut Vec<u8>) {
        out.push(self as u8);
    }
    fn read(code: &[u8], at: usize) -> Option<Result<(Self, usize), DecodeError>> {
        let k = *code.get(at)?;
        Some(match Drawable::ALL.get(k as usize) {
            Some(d) => Ok((*d, 1)),
            None => Err(DecodeError::UnknownDrawable { kind: k, at }),
        })
    }
    fn value(self) -> u64 {
        self as u64
    }
}
