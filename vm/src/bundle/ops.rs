//! The opcode table. Every opcode is declared once in [`for_each_op!`]; the `Op`
//! enum, its encoder, decoder, size and disassembly are generated from it, so they
//! cannot drift apart.
//!
//! Notation: `start` is the frame an item starts from (the body's frame, the
//! iterator run's frame, or the continuation state after `\`); `X[x]` is transform
//! `x`; `last` is the continuation register (the frame of the last drawable).
//! Operand kinds: `r` rule, `x` transform, `k` drawable kind, `n` namespace, `p` rule
//! or NONE, `i` isosurface, `c` count (u64), `j` op index (jump), `f` flags.
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
            (0x02, Draw, "DRAW", { kind: u8, xf: u32, ns: u32, profile: u32, flags: u8 },
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
                        $( out.extend_from_slice(&$f.to_le_bytes()); )*
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
                        const N: usize = std::mem::size_of::<$ty>();
                        let bytes = code.get(at..at + N).ok_or_else(|| format!("code ends inside an instruction at byte {pos}"))?;
                        at += N;
                        let mut arr = [0u8; N];
                        arr.copy_from_slice(bytes);
                        <$ty>::from_le_bytes(arr)
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
                    $(Op::$name { $($f),* } => vec![$((stringify!($f), $f as u64)),*],)*
                }
            }
        }

        /// Every opcode: (byte, mnemonic, meaning), for documentation and tests.
        pub const OPCODES: &[(u8, &str, &str)] = &[$(($byte, $mn, $doc)),*];
    };
}

for_each_op!(define_ops);

/// Drawable kinds used by `DRAW`.
pub const DRAWABLE_KINDS: &[&str] = &[
    "VERTEX",
    "FACENORMALS",
    "MOVETO",
    "LINETO",
    "BLENDTO",
    "SLINETO",
    "ALINETO",
    "NEWLINE",
    "FRAME",
    "RESET",
    "DEBUG",
];
