//! Expression code: a small stack machine for `function` bodies, function
//! selectors, isosurface functions and run-time adjustment arguments.
//!
//! Also the one table of math functions the compiler's checker and constant folder use.

use serde::Serialize;

/// Declares [`Func`], [`FUNCTIONS`] and the functions' definitions from one list.
macro_rules! functions {
    ($( $v:ident $name:literal $arity:literal => |$a:ident, $r:ident| $body:expr ),* $(,)?) => {
        /// A math function of the expression language, resolved when code is decoded
        /// (the index in `CALL` is its position in [`FUNCTIONS`]): evaluation matches on
        /// it, never on a name.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum Func {
            $( #[doc = $name] $v, )*
        }

        /// Math functions: name and arity. The index is the function id in `CALL`.
        /// `rand` and `randn` draw from the run's seeded stream.
        pub const FUNCTIONS: &[(&str, usize)] = &[$(($name, $arity)),*];

        impl Func {
            /// Every function, by id.
            pub const ALL: &[Func] = &[$(Func::$v),*];

            /// The function with id `i` (its index in [`FUNCTIONS`]).
            #[inline]
            pub fn from_id(i: u8) -> Option<Func> {
                Func::ALL.get(i as usize).copied()
            }

            /// The function called `name` in the language.
            pub fn from_name(name: &str) -> Option<Func> {
                FUNCTIONS.iter().position(|(n, _)| *n == name).map(|i| Func::ALL[i])
            }

            /// The name in the language.
            pub fn name(self) -> &'static str {
                FUNCTIONS[self as usize].0
            }

            /// The number of arguments.
            pub fn arity(self) -> usize {
                FUNCTIONS[self as usize].1
            }

            /// The value on `a` (the first `arity` entries are read), drawing from
            /// `rng` for `rand`/`randn`.
            #[inline]
            pub fn apply(self, args: &[f64; 3], rng: &mut dyn Random) -> f64 {
                match self {
                    $( Func::$v => {
                        let $a = args;
                        let $r = &mut *rng;
                        let _ = &$r;
                        $body
                    } )*
                }
            }
        }
    };
}

functions! {
    Sin "sin" 1 => |a, r| a[0].sin(),
    Cos "cos" 1 => |a, r| a[0].cos(),
    Tan "tan" 1 => |a, r| a[0].tan(),
    Asin "asin" 1 => |a, r| a[0].asin(),
    Acos "acos" 1 => |a, r| a[0].acos(),
    Atan "atan" 1 => |a, r| a[0].atan(),
    Atan2 "atan2" 2 => |a, r| a[0].atan2(a[1]),
    Sqrt "sqrt" 1 => |a, r| a[0].sqrt(),
    Abs "abs" 1 => |a, r| a[0].abs(),
    Min "min" 2 => |a, r| a[0].min(a[1]),
    Max "max" 2 => |a, r| a[0].max(a[1]),
    Pow "pow" 2 => |a, r| a[0].powf(a[1]),
    Exp "exp" 1 => |a, r| a[0].exp(),
    Log "log" 1 => |a, r| a[0].ln(),
    Floor "floor" 1 => |a, r| a[0].floor(),
    Ceil "ceil" 1 => |a, r| a[0].ceil(),
    Fract "fract" 1 => |a, r| a[0].fract(),
    Mod "mod" 2 => |a, r| a[0].rem_euclid(a[1]),
    Clamp "clamp" 3 => |a, r| clamp(a[0], a[1], a[2]),
    Mix "mix" 3 => |a, r| a[0] + (a[1] - a[0]) * a[2],
    Step "step" 2 => |a, r| if a[1] < a[0] { 0.0 } else { 1.0 },
    Smoothstep "smoothstep" 3 => |a, r| {
        let t = ((a[2] - a[0]) / (a[1] - a[0])).clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    },
    Rand "rand" 2 => |a, r| a[0] + (a[1] - a[0]) * r.uniform(),
    Randn "randn" 2 => |a, r| a[0] + a[1] * r.normal(),
    Radians "radians" 1 => |a, r| a[0].to_radians(),
    Degrees "degrees" 1 => |a, r| a[0].to_degrees(),
}

/// `clamp(v, a, b)`: `v` limited to the range between `a` and `b` (in either order),
/// NaN when any of the three is NaN (a NaN bound is not "no bound": it is an error
/// upstream, `log(-1)` or `0/0`, and it stays visible). Never panics, unlike
/// `f64::clamp`, so constant folding and evaluation give the same NaN.
#[inline]
pub fn clamp(v: f64, a: f64, b: f64) -> f64 {
    if v.is_nan() || a.is_nan() || b.is_nan() {
        return f64::NAN;
    }
    let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
    v.max(lo).min(hi)
}

/// Variables an expression may read at run time, by index.
pub const VARIABLES: &[&str] = &["x", "y", "z", "depth", "scale", "g"];

/// Declares [`BinOp`], [`BINOPS`] and the operators' definitions from one list.
macro_rules! binops {
    ($( $v:ident $sym:literal => |$a:ident, $b:ident| $body:expr ),* $(,)?) => {
        /// A binary operator of the expression languages. In a bundle it is written as
        /// its id, its position in [`BINOPS`]; decoding resolves the id, so code holds
        /// only known operators and evaluation matches on the operator, never a number.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum BinOp {
            $( #[doc = $sym] $v, )*
        }

        /// Binary operators' symbols, by id: `+ - * / ^ < <= > >= == != && ||`. `&&`
        /// and `||` read 0 (and NaN) as false, anything else as true, and give 1 or 0;
        /// both sides are always evaluated (so the random stream does not depend on a
        /// condition).
        pub const BINOPS: &[&str] = &[$($sym),*];

        impl BinOp {
            /// Every operator, by id.
            pub const ALL: &[BinOp] = &[$(BinOp::$v),*];

            /// The operator with id `i` (its index in [`BINOPS`]).
            #[inline]
            pub fn from_id(i: u8) -> Option<BinOp> {
                BinOp::ALL.get(i as usize).copied()
            }

            /// The operator written `symbol`.
            pub fn from_symbol(symbol: &str) -> Option<BinOp> {
                BINOPS.iter().position(|s| *s == symbol).map(|i| BinOp::ALL[i])
            }

            /// The id written in a bundle.
            pub fn id(self) -> u8 {
                self as u8
            }

            /// The operator as written.
            pub fn symbol(self) -> &'static str {
                BINOPS[self as usize]
            }

            /// `a self b`.
            #[inline]
            pub fn apply(self, x: f64, y: f64) -> f64 {
                match self {
                    $( BinOp::$v => {
                        let ($a, $b) = (x, y);
                        $body
                    } )*
                }
            }
        }
    };
}

/// 1 for true, 0 for false.
#[inline]
fn bool01(c: bool) -> f64 {
    if c {
        1.0
    } else {
        0.0
    }
}

binops! {
    Add "+" => |a, b| a + b,
    Sub "-" => |a, b| a - b,
    Mul "*" => |a, b| a * b,
    Div "/" => |a, b| a / b,
    Pow "^" => |a, b| a.powf(b),
    Lt "<" => |a, b| bool01(a < b),
    Le "<=" => |a, b| bool01(a <= b),
    Gt ">" => |a, b| bool01(a > b),
    Ge ">=" => |a, b| bool01(a >= b),
    Eq "==" => |a, b| bool01(a == b),
    Ne "!=" => |a, b| bool01(a != b),
    And "&&" => |a, b| bool01(truthy(a) && truthy(b)),
    Or "||" => |a, b| bool01(truthy(a) || truthy(b)),
}

/// Written as its id (a number), as in the bundle: the creature table's JSON keeps
/// its bytes.
impl Serialize for BinOp {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u8(self.id())
    }
}

impl<'de> serde::Deserialize<'de> for BinOp {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<BinOp, D::Error> {
        let id = <u8 as serde::Deserialize>::deserialize(d)?;
        BinOp::from_id(id).ok_or_else(|| serde::de::Error::custom(format!("unknown operator {id}")))
    }
}

/// One expression instruction.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum ExprOp {
    /// Push a constant.
    Push(f64),
    /// Push variable `VARIABLES[i]`.
    Var(u8),
    /// Negate the top.
    Neg,
    /// Pop b, pop a, push `a op b`.
    Bin(BinOp),
    /// Pop `arity` arguments, push `FUNCTIONS[i](…)`.
    Call(u8),
    /// Push slot `i` of the running rule's frame (a parameter, a `let` binding or a
    /// loop variable; see `bundle::Rule::frame`).
    Slot(u16),
    /// Skip the next `n` instructions (the end of an `if`/`select` branch).
    Skip(u32),
    /// Pop; when it is false (0 or NaN), skip the next `n` instructions.
    SkipUnless(u32),
    /// Push a copy of the stack entry `k` below the top (0: the top; a `let(…)`
    /// binding or a `select(…)` index).
    Pick(u32),
    /// Pop the top, drop the `n` entries under it, push the top back (the end of a
    /// `let(…)`).
    Slide(u32),
}

/// Whether a value counts as true (`if`, `&&`, `||`): not 0 and not NaN.
#[inline]
pub fn truthy(v: f64) -> bool {
    v != 0.0 && !v.is_nan()
}

/// Applies a deterministic math function by name (`None` for unknown names, a
/// missing argument, and `rand`/`randn`, which need the run's random stream). For the
/// compiler's constant folder; evaluation dispatches on [`Func`].
pub fn call(name: &str, a: &[f64]) -> Option<f64> {
    let f = Func::from_name(name)?;
    if a.len() < f.arity() {
        return None;
    }
    f.deterministic(&std::array::from_fn(|i| a.get(i).copied().unwrap_or(f64::NAN)))
}

impl Func {
    /// Whether the function draws from the run's random stream.
    pub fn is_random(self) -> bool {
        matches!(self, Func::Rand | Func::Randn)
    }

    /// The value on `a` of a function that draws nothing; `None` for `rand`/`randn`.
    pub fn deterministic(self, a: &[f64; 3]) -> Option<f64> {
        (!self.is_random()).then(|| self.apply(a, &mut NoRandom))
    }
}

/// A stream for functions that draw nothing.
struct NoRandom;

impl Random for NoRandom {
    fn uniform(&mut self) -> f64 {
        f64::NAN
    }
    fn normal(&mut self) -> f64 {
        f64::NAN
    }
}

/// A source of random numbers for `rand`/`randn` (the evaluator's seeded stream).
pub trait Random {
    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64;
    /// Standard normal.
    fn normal(&mut self) -> f64;
}

/// The value of the shapes of expression a call argument or a condition over
/// parameters nearly always has (`n`, `n - 1`, `len * 0.8`, `n > 0`, a constant),
/// computed without the stack or the variables; `None` for any other code. Gives
/// exactly what [`eval`] gives.
#[inline(always)]
pub fn quick(code: &[ExprOp], slots: &[f64]) -> Option<f64> {
    let slot = |i: u16| slots.get(i as usize).copied().unwrap_or(f64::NAN);
    match *code {
        [ExprOp::Slot(i)] => Some(slot(i)),
        [ExprOp::Slot(i), ExprOp::Push(c), ExprOp::Bin(o)] => Some(o.apply(slot(i), c)),
        [ExprOp::Push(c), ExprOp::Slot(i), ExprOp::Bin(o)] => Some(o.apply(c, slot(i))),
        [ExprOp::Push(c)] => Some(c),
        _ => None,
    }
}

/// The one stack machine: what an instruction of an expression language does, as
/// far as the shared arithmetic is concerned. [`ExprOp`] (geometric expressions) and
/// the creature condition code (`creature::cond::CondOp`) are both this machine with
/// their own leaves (the instructions that push a value read from outside).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Core<L> {
    /// Push a constant.
    Push(f64),
    /// Push the value of a leaf (a variable, a slot, a count).
    Leaf(L),
    /// Negate the top.
    Neg,
    /// Pop b, pop a, push `a op b`.
    Bin(BinOp),
    /// Pop `arity` arguments, push `FUNCTIONS[i](…)`.
    Call(u8),
    /// Skip the next `n` instructions. Only forward: code always ends.
    Skip(u32),
    /// Pop; when it is false (0 or NaN, as [`truthy`]), skip the next `n` instructions.
    SkipUnless(u32),
    /// Push a copy of the stack entry `k` below the top (0: the top).
    Pick(u32),
    /// Pop the top, drop the `n` entries under it, push the top back.
    Slide(u32),
}

/// An instruction of the shared stack machine ([`Core`]): its encoder-side
/// constructors and its decoder-side view, so the compiler's lowering, [`run`] and
/// [`check`] are written once for every expression language.
pub trait StackOp: Copy {
    /// The instruction seen as the shared machine sees it.
    fn core(self) -> Core<Self>;
    /// The instruction that does `c` (a leaf is the instruction itself).
    fn from_core(c: Core<Self>) -> Self;
}

impl StackOp for ExprOp {
    #[inline(always)]
    fn core(self) -> Core<Self> {
        match self {
            ExprOp::Push(v) => Core::Push(v),
            ExprOp::Neg => Core::Neg,
            ExprOp::Bin(o) => Core::Bin(o),
            ExprOp::Call(f) => Core::Call(f),
            ExprOp::Skip(n) => Core::Skip(n),
            ExprOp::SkipUnless(n) => Core::SkipUnless(n),
            ExprOp::Pick(k) => Core::Pick(k),
            ExprOp::Slide(n) => Core::Slide(n),
            leaf @ (ExprOp::Var(_) | ExprOp::Slot(_)) => Core::Leaf(leaf),
        }
    }

    fn from_core(c: Core<Self>) -> Self {
        match c {
            Core::Push(v) => ExprOp::Push(v),
            Core::Neg => ExprOp::Neg,
            Core::Bin(o) => ExprOp::Bin(o),
            Core::Call(f) => ExprOp::Call(f),
            Core::Skip(n) => ExprOp::Skip(n),
            Core::SkipUnless(n) => ExprOp::SkipUnless(n),
            Core::Pick(k) => ExprOp::Pick(k),
            Core::Slide(n) => ExprOp::Slide(n),
            Core::Leaf(op) => op,
        }
    }
}

/// Runs verified code on the shared machine: `leaf` gives a leaf's value, `call`
/// applies a function to its arguments. On malformed code the result is NaN, never
/// a panic.
#[inline(always)]
pub fn run<O: StackOp>(
    code: &[O],
    stack: &mut Vec<f64>,
    mut leaf: impl FnMut(O) -> f64,
    mut call: impl FnMut(Func, &[f64; 3]) -> f64,
) -> f64 {
    stack.clear();
    let mut pc = 0;
    while let Some(op) = code.get(pc) {
        pc += 1;
        match op.core() {
            Core::Push(v) => stack.push(v),
            Core::Leaf(l) => stack.push(leaf(l)),
            Core::Neg => {
                if let Some(t) = stack.last_mut() {
                    *t = -*t;
                }
            }
            Core::Bin(o) => {
                let b = stack.pop().unwrap_or(f64::NAN);
                let a = stack.pop().unwrap_or(f64::NAN);
                stack.push(o.apply(a, b));
            }
            Core::Call(f) => {
                let Some(func) = Func::from_id(f) else { return f64::NAN };
                let at = stack.len().saturating_sub(func.arity());
                let args: [f64; 3] = std::array::from_fn(|i| stack.get(at + i).copied().unwrap_or(f64::NAN));
                stack.truncate(at);
                stack.push(call(func, &args));
            }
            Core::Skip(n) => pc += n as usize,
            Core::SkipUnless(n) => {
                if !truthy(stack.pop().unwrap_or(f64::NAN)) {
                    pc += n as usize;
                }
            }
            Core::Pick(k) => {
                let v = stack.len().checked_sub(1 + k as usize).and_then(|i| stack.get(i)).copied();
                stack.push(v.unwrap_or(f64::NAN));
            }
            Core::Slide(n) => {
                let top = stack.pop().unwrap_or(f64::NAN);
                stack.truncate(stack.len().saturating_sub(n as usize));
                stack.push(top);
            }
        }
    }
    stack.pop().unwrap_or(f64::NAN)
}

/// Why code is not valid for the shared machine ([`check`], [`verify`]); positions
/// are instruction indices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CodeError {
    /// A skip at `from` lands past the end of the code.
    SkipBeyondEnd { from: usize },
    /// Two ways reach instruction `at` (`None`: the end) with stack depths `a` and `b`.
    DepthsMeet { a: i64, b: i64, at: Option<usize> },
    /// No way reaches the instruction.
    Unreachable { at: usize },
    /// A constant is NaN or infinite.
    NonFinite { at: usize },
    /// A call names no function.
    UnknownFunction { id: u8, at: usize },
    /// An instruction pops more than the stack holds.
    Underflow { at: usize },
    /// A `Pick` reads below the bottom of the stack.
    PickBeyond { k: u32, at: usize },
    /// The code ends with this many values instead of one.
    LeavesValues(i64),
    /// A variable leaf names none of [`VARIABLES`].
    UnknownVariable { var: u8, at: usize },
}

impl std::fmt::Display for CodeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            CodeError::SkipBeyondEnd { from } => write!(f, "skip beyond the end at {from}"),
            CodeError::DepthsMeet { a, b, at: Some(at) } => write!(f, "stack depths {a} and {b} meet at {at}"),
            CodeError::DepthsMeet { a, b, at: None } => write!(f, "stack depths {a} and {b} meet at the end"),
            CodeError::Unreachable { at } => write!(f, "unreachable instruction at {at}"),
            CodeError::NonFinite { at } => write!(f, "non-finite constant at {at}"),
            CodeError::UnknownFunction { id, at } => write!(f, "unknown function {id} at {at}"),
            CodeError::Underflow { at } => write!(f, "stack underflow at {at}"),
            CodeError::PickBeyond { k, at } => write!(f, "pick {k} beyond the stack at {at}"),
            CodeError::LeavesValues(n) => write!(f, "expression leaves {n} values"),
            CodeError::UnknownVariable { var, at } => write!(f, "unknown variable {var} at {at}"),
        }
    }
}

impl std::error::Error for CodeError {}

/// For checkers whose own errors are still messages.
impl From<CodeError> for String {
    fn from(e: CodeError) -> String {
        e.to_string()
    }
}

/// Checks code for the shared machine: constants finite, operators and functions
/// known, the stack never underflows and ends with exactly one value, skips land
/// inside the code (or at its end) with the same stack depth on every way there, no
/// instruction is unreachable, and `Pick` reads an entry that exists. `leaf` checks
/// a leaf's index, `func` whether a function is allowed; both get the instruction's
/// position for the message and say why in the caller's error type `E`, which holds
/// the machine's own [`CodeError`]s too.
pub fn check<O: StackOp, E: From<CodeError>>(
    code: &[O],
    mut leaf: impl FnMut(usize, O) -> Result<(), E>,
    mut func: impl FnMut(usize, Func) -> Result<(), E>,
) -> Result<(), E> {
    // The depth each skip brings to its target (index `code.len()`: the end).
    let mut arrive: Vec<Option<i64>> = vec![None; code.len() + 1];
    let meet = |arrive: &mut [Option<i64>], at: usize, d: i64, from: usize| -> Result<(), CodeError> {
        match arrive.get_mut(at) {
            None => Err(CodeError::SkipBeyondEnd { from }),
            Some(Some(t)) if *t != d => Err(CodeError::DepthsMeet { a: *t, b: d, at: Some(at) }),
            Some(slot) => {
                *slot = Some(d);
                Ok(())
            }
        }
    };
    // `None`: the previous instruction was an unconditional skip.
    let mut depth: Option<i64> = Some(0);
    for (i, op) in code.iter().enumerate() {
        let d = match (depth, arrive[i]) {
            (Some(d), Some(t)) if d != t => return Err(CodeError::DepthsMeet { a: d, b: t, at: Some(i) }.into()),
            (Some(d), _) | (None, Some(d)) => d,
            (None, None) => return Err(CodeError::Unreachable { at: i }.into()),
        };
        let (pop, push) = match op.core() {
            Core::Push(v) if !v.is_finite() => return Err(CodeError::NonFinite { at: i }.into()),
            Core::Push(_) => (0, 1),
            Core::Leaf(l) => {
                leaf(i, l)?;
                (0, 1)
            }
            Core::Neg => (1, 1),
            Core::Bin(_) => (2, 1),
            Core::Call(f) => match Func::from_id(f) {
                Some(f) => {
                    func(i, f)?;
                    (f.arity() as i64, 1)
                }
                None => return Err(CodeError::UnknownFunction { id: f, at: i }.into()),
            },
            Core::Skip(n) => {
                meet(&mut arrive, i + 1 + n as usize, d, i)?;
                depth = None;
                continue;
            }
            Core::SkipUnless(n) => {
                if d < 1 {
                    return Err(CodeError::Underflow { at: i }.into());
                }
                meet(&mut arrive, i + 1 + n as usize, d - 1, i)?;
                (1, 0)
            }
            Core::Pick(k) if i64::from(k) >= d => return Err(CodeError::PickBeyond { k, at: i }.into()),
            Core::Pick(_) => (0, 1),
            Core::Slide(n) => (i64::from(n) + 1, 1),
        };
        if d < pop {
            return Err(CodeError::Underflow { at: i }.into());
        }
        depth = Some(d - pop + push);
    }
    let end = match (depth, arrive[code.len()]) {
        (Some(d), Some(t)) if d != t => return Err(CodeError::DepthsMeet { a: d, b: t, at: None }.into()),
        (Some(d), _) | (None, Some(d)) => d,
        (None, None) => 0,
    };
    if end != 1 {
        return Err(CodeError::LeavesValues(end).into());
    }
    Ok(())
}

/// Evaluates verified expression code with `vars` (indexed like [`VARIABLES`]) and
/// the running rule's frame `slots`. Verified code never underflows; on malformed
/// code (or a slot beyond `slots`) the result is NaN, never a panic.
pub fn eval(code: &[ExprOp], vars: &[f64; 6], slots: &[f64], rng: &mut dyn Random, stack: &mut Vec<f64>) -> f64 {
    run(
        code,
        stack,
        |leaf| match leaf {
            ExprOp::Slot(i) => slots.get(i as usize).copied().unwrap_or(f64::NAN),
            ExprOp::Var(i) => vars.get(i as usize).copied().unwrap_or(f64::NAN),
            _ => f64::NAN,
        },
        |f, args| f.apply(args, rng),
    )
}

/// The highest slot `code` reads, plus one (0 when it reads none): the bundle
/// verifier checks it against the frame of every rule that uses the expression.
pub fn slots_needed(code: &[ExprOp]) -> usize {
    code.iter().map(|op| if let ExprOp::Slot(i) = op { *i as usize + 1 } else { 0 }).max().unwrap_or(0)
}

/// Checks stack discipline: never underflows, ends with exactly one value.
pub fn verify(code: &[ExprOp]) -> Result<(), CodeError> {
    check(
        code,
        |i, leaf| match leaf {
            ExprOp::Var(v) if v as usize >= VARIABLES.len() => Err(CodeError::UnknownVariable { var: v, at: i }),
            _ => Ok(()),
        },
        |_, _| Ok(()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fixed stream (the draws do not matter here, only that nothing panics).
    struct Half;

    impl Random for Half {
        fn uniform(&mut self) -> f64 {
            0.5
        }
        fn normal(&mut self) -> f64 {
            0.5
        }
    }

    /// Values one `log(-1)`, `0/0`, `1e308*10` or an underflow away.
    const HOSTILE: [f64; 12] =
        [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e308, -1e308, 0.0, -0.0, 1.0, -1.0, 5e-324, 1e-300, 0.5];

    /// A stream that counts its draws.
    struct Counting(u32);

    impl Random for Counting {
        fn uniform(&mut self) -> f64 {
            self.0 += 1;
            0.25
        }
        fn normal(&mut self) -> f64 {
            self.0 += 1;
            0.0
        }
    }

    fn rand_01() -> [ExprOp; 3] {
        [ExprOp::Push(0.0), ExprOp::Push(1.0), ExprOp::Call(Func::Rand as u8)]
    }

    /// `if(s0, 10, rand(0, 1))`, as the compiler lowers it.
    fn if_code() -> Vec<ExprOp> {
        let mut c = vec![ExprOp::Slot(0), ExprOp::SkipUnless(2), ExprOp::Push(10.0), ExprOp::Skip(3)];
        c.extend(rand_01());
        c
    }

    #[test]
    fn if_runs_only_the_chosen_branch() {
        let code = if_code();
        assert_eq!(verify(&code), Ok(()));
        let (mut rng, mut stack) = (Counting(0), Vec::new());
        assert_eq!(eval(&code, &[0.0; 6], &[1.0], &mut rng, &mut stack), 10.0);
        assert_eq!(rng.0, 0, "the untaken branch draws nothing");
        assert_eq!(eval(&code, &[0.0; 6], &[0.0], &mut rng, &mut stack), 0.25);
        assert_eq!(eval(&code, &[0.0; 6], &[f64::NAN], &mut rng, &mut stack), 0.25, "NaN is false");
        assert_eq!(rng.0, 2);
    }

    #[test]
    fn let_bindings_are_picked_and_slid_off() {
        // let(a = s0 * 2; b = a + 1; a * b)
        let code = [
            ExprOp::Slot(0),
            ExprOp::Push(2.0),
            ExprOp::Bin(BinOp::Mul),
            ExprOp::Pick(0),
            ExprOp::Push(1.0),
            ExprOp::Bin(BinOp::Add),
            ExprOp::Pick(1),
            ExprOp::Pick(1),
            ExprOp::Bin(BinOp::Mul),
            ExprOp::Slide(2),
            // … + 1: the bindings are gone from under the value.
            ExprOp::Push(1.0),
            ExprOp::Bin(BinOp::Add),
        ];
        assert_eq!(verify(&code), Ok(()));
        let mut stack = Vec::new();
        assert_eq!(eval(&code, &[0.0; 6], &[3.0], &mut Half, &mut stack), 43.0);
    }

    #[test]
    fn select_floors_and_clamps_its_index() {
        // select(s0, 10, 20, 30): the index stays under the branches.
        let branch = |k: f64| [ExprOp::Pick(0), ExprOp::Push(k), ExprOp::Bin(BinOp::Lt), ExprOp::SkipUnless(2)];
        let mut code = vec![ExprOp::Slot(0)];
        code.extend(branch(1.0));
        code.extend([ExprOp::Push(10.0), ExprOp::Skip(7)]);
        code.extend(branch(2.0));
        code.extend([ExprOp::Push(20.0), ExprOp::Skip(1)]);
        code.extend([ExprOp::Push(30.0), ExprOp::Slide(1)]);
        assert_eq!(verify(&code), Ok(()));
        let mut stack = Vec::new();
        let at = |i: f64, stack: &mut Vec<f64>| eval(&code, &[0.0; 6], &[i], &mut Half, stack);
        let got: Vec<f64> = [-3.0, 0.0, 0.9, 1.0, 1.5, 2.0, 7.0, f64::NAN].iter().map(|&i| at(i, &mut stack)).collect();
        assert_eq!(got, [10.0, 10.0, 10.0, 20.0, 20.0, 30.0, 30.0, 30.0]);
    }

    #[test]
    fn verify_refuses_bad_skips_and_picks() {
        let bad = |code: &[ExprOp]| verify(code).err().map_or(String::new(), |e| e.to_string());
        // A skip past the end: the error is data (which skip), its message says so.
        assert_eq!(verify(&[ExprOp::Push(1.0), ExprOp::Skip(5)]), Err(CodeError::SkipBeyondEnd { from: 1 }));
        assert!(bad(&[ExprOp::Push(1.0), ExprOp::Skip(5)]).contains("beyond the end"));
        // Branches that leave different depths.
        let uneven = [ExprOp::Push(1.0), ExprOp::SkipUnless(2), ExprOp::Push(1.0), ExprOp::Push(2.0)];
        assert!(bad(&uneven).contains("meet"), "{}", bad(&uneven));
        // An instruction no path reaches.
        let dead = [ExprOp::Push(1.0), ExprOp::Skip(1), ExprOp::Neg];
        assert!(bad(&dead).contains("unreachable"), "{}", bad(&dead));
        // A pick below the bottom, a slide of more than there is.
        assert!(bad(&[ExprOp::Push(1.0), ExprOp::Pick(1), ExprOp::Bin(BinOp::Add)]).contains("pick 1"));
        assert!(bad(&[ExprOp::Push(1.0), ExprOp::Slide(1)]).contains("underflow"));
        assert_eq!(verify(&[ExprOp::Var(9)]), Err(CodeError::UnknownVariable { var: 9, at: 0 }));
        assert_eq!(verify(&[ExprOp::Push(1.0), ExprOp::Push(2.0)]), Err(CodeError::LeavesValues(2)));
        // Malformed code never panics in evaluation.
        for code in [&[ExprOp::Skip(9)][..], &[ExprOp::Pick(3)], &[ExprOp::Slide(4)], &[ExprOp::SkipUnless(1)]] {
            let _ = eval(code, &[0.0; 6], &[], &mut Half, &mut Vec::new());
        }
    }

    #[test]
    fn clamp_with_a_nan_argument_is_nan() {
        let nan = f64::NAN;
        for args in [[1.0, nan, nan], [1.0, nan, 0.0], [1.0, 0.0, nan], [nan, 0.0, 1.0], [nan, nan, nan]] {
            let v = Func::Clamp.apply(&args, &mut Half);
            assert!(v.is_nan(), "clamp{args:?} = {v}");
            assert!(call("clamp", &args).is_some_and(f64::is_nan), "the folder's clamp{args:?}");
        }
    }

    #[test]
    fn clamp_orders_its_bounds_and_takes_infinite_ones() {
        let clamp = |a: [f64; 3]| Func::Clamp.apply(&a, &mut Half);
        assert_eq!(clamp([5.0, 0.0, 1.0]), 1.0);
        assert_eq!(clamp([5.0, 1.0, 0.0]), 1.0);
        assert_eq!(clamp([-5.0, 1.0, 0.0]), 0.0);
        assert_eq!(clamp([0.25, 1.0, 0.0]), 0.25);
        assert_eq!(clamp([f64::NEG_INFINITY, 0.0, 1.0]), 0.0);
        assert_eq!(clamp([0.5, f64::NEG_INFINITY, f64::INFINITY]), 0.5);
        assert_eq!(clamp([f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY]), f64::INFINITY);
    }

    /// Every function of the table (so a function added later is covered) on every
    /// combination of NaN, infinite, huge, tiny and plain arguments: no panic, and the
    /// constant folder (`call`) gives what evaluation gives.
    #[test]
    fn operators_are_named_and_numbered_by_one_table() {
        assert_eq!(BinOp::ALL.len(), BINOPS.len());
        for (i, &op) in BinOp::ALL.iter().enumerate() {
            assert_eq!(op.id() as usize, i);
            assert_eq!(BinOp::from_id(op.id()), Some(op));
            assert_eq!(BinOp::from_symbol(op.symbol()), Some(op));
        }
        assert_eq!(BinOp::from_id(BINOPS.len() as u8), None);
        // The ids a bundle holds (docs/bytecode.md): `*` is 2, `||` is 12.
        assert_eq!((BinOp::Mul.id(), BinOp::Or.id()), (2, 12));
        assert_eq!(
            (BinOp::Pow.apply(2.0, 10.0), BinOp::Le.apply(1.0, 1.0), BinOp::And.apply(f64::NAN, 1.0)),
            (1024.0, 1.0, 0.0)
        );
        // Serialised as the id (the creature table's JSON), and read back.
        assert_eq!(serde_json::to_string(&BinOp::Ge).ok().as_deref(), Some("8"));
        assert_eq!(serde_json::from_str::<BinOp>("8").ok(), Some(BinOp::Ge));
        assert!(serde_json::from_str::<BinOp>("13").is_err());
    }

    #[test]
    fn every_function_takes_non_finite_and_huge_arguments() {
        for &f in Func::ALL {
            let n = f.arity();
            let combos = HOSTILE.len().pow(n as u32);
            for k in 0..combos {
                let args: [f64; 3] = std::array::from_fn(|i| {
                    if i < n {
                        HOSTILE[k / HOSTILE.len().pow(i as u32) % HOSTILE.len()]
                    } else {
                        f64::NAN
                    }
                });
                let v = f.apply(&args, &mut Half);
                if let Some(folded) = call(f.name(), &args[..n]) {
                    assert!(folded.to_bits() == v.to_bits() || (folded.is_nan() && v.is_nan()), "{}{args:?}", f.name());
                }
            }
        }
        for &op in BinOp::ALL {
            for a in HOSTILE {
                for b in HOSTILE {
                    let _ = op.apply(a, b);
                }
            }
        }
    }
}
