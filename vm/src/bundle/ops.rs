//! The opcode table. Every opcode is declared once in [`for_each_op!`]; the `Op`
//! enum, its encoder, decoder, size and disassembly are generated from it, so they
//! cannot drift apart.
//!
//! Notation: `start` is the frame an item starts from (the body's frame, the
//! iterator run's frame, or the continuation state after `\`); `X[x]` is transform
//! `x`; `last` is the continuation register (the frame of the last drawable).
//! Operand kinds: `r` rule, `x` transform, `k` drawable kind, `n` namespace, `p` rule
//! or NONE, `i` isosurface, `c` count (u64), `j` op index (jump), `f` flags, `P`
//! prototype (the ordinal of its `INST` op in the code).
//! Flags bit 0 (`CONT_NEXT`): the item is followed by `\`, so `last` is set to the
//! item's own frame before it runs (a drawable inside it then overrides it).

/// Flag: the item is followed by `\`.
pub const CONT_NEXT: u8 = 1;

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
            (0x01, Call, "CALL", { rule: u32, xf: u32, flags: u8 },
                "r x f    push frame; S := start ∘ X[x]; run the definition of rule r its selector picks");
            (0x02, Draw, "DRAW", { kind: Drawable, xf: u32, ns: u32, profile: u32, flags: u8 },
                "k x n p f  S := start ∘ X[x]; drawable k on namespace n's pen (profile rule p or NONE); last := S");
            (0x03, Iso, "ISO", { iso: u32, xf: u32, flags: u8 },
                "i x f    S := start ∘ X[x]; place an instance of isosurface i; last := S");
            (0x04, Loop, "LOOP", { count: u64, step: u32, end: u32, chain: u8 },
                "c x j f  iterator: run the body up to ENDLOOP c times, run k under start ∘ X[x]^k; f=1 chains runs through last; if c = 0 jump past j");
            (0x05, EndLoop, "ENDLOOP", { begin: u32 },
                "j        next run of the LOOP at op j, or leave it");
            (0x06, Cont, "CONT", { },
                "         the next item starts from last (continuation)");
            (0x07, Ret, "RET", { },
                "         pop frame; return to the caller");
            (0x08, Arg, "ARG", { expr: u32 },
                "e        push the value of e (in the caller's frame) as the next argument of the CALL that follows");
            (0x09, Set, "SET", { slot: u16, expr: u32 },
                "s e      slot s := e (a `let` binding or a loop variable)");
            (0x0A, Jump, "JUMP", { target: u32 },
                "j        continue at op j (forward, within the definition and its loop)");
            (0x0B, JumpIfNot, "JUMPZ", { expr: u32, target: u32 },
                "e j      if e is 0 (false) or NaN, continue at op j (`if`/`else`)");
            (0x0C, LoopN, "LOOPN", { count: u32, step: u32, end: u32, chain: u8 },
                "e x j f  LOOP whose count is expression e, evaluated once on entry (negative or NaN: 0 runs); f bit 1: the first run is under start itself");
            (0x0D, Inst, "INST", { proto: u32, count: u32 },
                "P n      the next n ops (VERTEX/FACENORMALS, constant transforms) are prototype P: one instance of P under start, skipping them; or run them one by one");
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
            pub fn decode(code: &[u8], pos: usize) -> Result<(Op, usize), String> {
                let byte = *code.get(pos).ok_or_else(|| format!("code ends inside an instruction at byte {pos}"))?;
                let mut at = pos + 1;
                #[allow(unused_macros)]
                macro_rules! read {
                    ($ty:ty) => {{
                        let (v, n) = <$ty as Operand>::read(code, at).ok_or_else(|| format!("code ends inside an instruction at byte {pos}"))??;
                        at += n;
                        v
                    }};
                }
                let op = match byte {
                    $($byte => Op::$name { $($f: read!($t)),* },)*
                    other => return Err(format!("unknown opcode 0x{other:02x} at byte {pos}")),
                };
                Ok((op, at - pos))
            }

            /// The operands as `name=value` text, for the disassembler.
            pub fn operands(&self) -> Vec<(&'static str, u64)> {
                match *self {
                    $(Op::$name { $($f),* } => vec![$((stringify!($f), Operand::value($f))),*],)*
                }
            }
        }

        /// Every opcode: (byte, mnemonic, meaning), for documentation and tests.
        pub const OPCODES: &[(u8, &str, &str)] = &[$(($byte, $mn, $doc)),*];
    };
}

for_each_op!(define_ops);

/// An operand of the op table: little-endian bytes in the code.
pub trait Operand: Copy {
    /// Appends the encoding.
    fn write(self, out: &mut Vec<u8>);
    /// Decodes the operand at `at`: `None` when the code ends first, `Some(Err)` when
    /// the bytes are not a value of the type; else the value and its length.
    fn read(code: &[u8], at: usize) -> Option<Result<(Self, usize), String>>;
    /// The value as a number, for the disassembler.
    fn value(self) -> u64;
}

macro_rules! int_operands {
    ($($t:ty),*) => {$(
        impl Operand for $t {
            fn write(self, out: &mut Vec<u8>) {
                out.extend_from_slice(&self.to_le_bytes());
            }
            fn read(code: &[u8], at: usize) -> Option<Result<(Self, usize), String>> {
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
}

impl Operand for Drawable {
    fn write(self, out: &mut Vec<u8>) {
        out.push(self as u8);
    }
    fn read(code: &[u8], at: usize) -> Option<Result<(Self, usize), String>> {
        let k = *code.get(at)?;
        Some(match Drawable::ALL.get(k as usize) {
            Some(d) => Ok((*d, 1)),
            None => Err(format!("unknown drawable kind {k} at byte {at}")),
        })
    }
    fn value(self) -> u64 {
        self as u64
    }
}
