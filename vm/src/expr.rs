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
    /// Skip the next `n` instructions: a block of function bodies (recursive user
    /// functions, compiled once), each an `Enter` … `Ret`.
    Funcs(u32),
    /// The start of a function body taking `arity` arguments (reached only by `Fn`).
    Enter(u32),
    /// Call the function whose `Enter` is `rel` instructions from this one: its
    /// arguments are the top entries, its value replaces them.
    Fn(i32),
    /// Return from a function body (its value on top, its arguments slid off).
    Ret,
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
    /// Skip the next `n` instructions: a block of function bodies.
    Funcs(u32),
    /// A function body's start, with its arity.
    Enter(u32),
    /// Call the function whose `Enter` is `rel` instructions away.
    Fn(i32),
    /// Return from a function body.
    Ret,
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
            ExprOp::Funcs(n) => Core::Funcs(n),
            ExprOp::Enter(a) => Core::Enter(a),
            ExprOp::Fn(rel) => Core::Fn(rel),
            ExprOp::Ret => Core::Ret,
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
            Core::Funcs(n) => ExprOp::Funcs(n),
            Core::Enter(a) => ExprOp::Enter(a),
            Core::Fn(rel) => ExprOp::Fn(rel),
            Core::Ret => ExprOp::Ret,
            Core::Leaf(op) => op,
        }
    }
}

/// The default deepest nesting of function calls in one evaluation
/// ([`CallLimits::depth`]; `mdg-run --max-call-depth`). Calls live on the heap, so a
/// deep recursion cannot overflow the native stack; 10,000 is far more than a
/// formula needs and ends a runaway at once.
pub const DEFAULT_MAX_CALL_DEPTH: u32 = 10_000;
/// The default most function calls in one evaluation ([`CallLimits::calls`];
/// `mdg-run --max-calls`): a depth limit alone does not end `fib(100)`, which stays
/// shallow and makes 2^100 calls. A million calls take a few milliseconds.
pub const DEFAULT_MAX_CALLS: u64 = 1_000_000;

/// The limits on user function calls in one evaluation of an expression.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CallLimits {
    /// The deepest nesting of calls.
    pub depth: u32,
    /// The most calls.
    pub calls: u64,
}

impl Default for CallLimits {
    fn default() -> Self {
        CallLimits { depth: DEFAULT_MAX_CALL_DEPTH, calls: DEFAULT_MAX_CALLS }
    }
}

/// Evaluations a call limit stopped (each gave NaN), counted for the run's warning.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CallsCut {
    /// Stopped at [`CallLimits::depth`].
    pub depth: u64,
    /// Stopped at [`CallLimits::calls`].
    pub calls: u64,
}

/// The machine's memory, kept between evaluations so they allocate nothing: the
/// value stack, the return addresses of function calls, the call limits and the
/// evaluations they stopped.
#[derive(Clone, Debug, Default)]
pub struct Machine {
    values: Vec<f64>,
    returns: Vec<usize>,
    /// The limits on function calls (defaults: [`CallLimits::default`]).
    pub limits: CallLimits,
    /// The evaluations the limits stopped so far.
    pub cut: CallsCut,
}

impl Machine {
    /// A machine with these call limits.
    pub fn new(limits: CallLimits) -> Machine {
        Machine { values: Vec::with_capacity(16), returns: Vec::new(), limits, cut: CallsCut::default() }
    }
}

/// Runs verified code on the shared machine: `leaf` gives a leaf's value, `call`
/// applies a function to its arguments. On malformed code the result is NaN, never
/// a panic; so it is when a user function call would go past `m`'s limits (counted
/// in `m.cut`).
#[inline(always)]
pub fn run<O: StackOp>(
    code: &[O],
    m: &mut Machine,
    mut leaf: impl FnMut(O) -> f64,
    mut call: impl FnMut(Func, &[f64; 3]) -> f64,
) -> f64 {
    let Machine { values: stack, returns, limits, cut } = m;
    stack.clear();
    returns.clear();
    let mut calls: u64 = 0;
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
            Core::Skip(n) | Core::Funcs(n) => pc += n as usize,
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
            Core::Enter(_) => {}
            Core::Fn(rel) => {
                if returns.len() >= limits.depth as usize {
                    cut.depth += 1;
                    return f64::NAN;
                }
                calls += 1;
                if calls > limits.calls {
                    cut.calls += 1;
                    return f64::NAN;
                }
                let Some(target) = (pc - 1).checked_add_signed(rel as isize) else { return f64::NAN };
                returns.push(pc);
                pc = target;
            }
            Core::Ret => match returns.pop() {
                Some(back) => pc = back,
                None => return f64::NAN,
            },
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
    /// A skip at `from` leaves or enters a function body.
    SkipCrossesBody { from: usize },
    /// A function body (its `Enter` at `at`) is reached by falling into it.
    BodyWithoutCall { at: usize },
    /// A call at `at` lands on no function body.
    CallOfNoBody { at: usize },
    /// A function body returns `n` values (one expected) at `at`.
    ReturnsValues { n: i64, at: usize },
    /// Function blocks and bodies are not shaped `Funcs` [`Enter` … `Ret`]…: what
    /// is wrong, and where (`None`: at the end).
    BlockShape { what: &'static str, at: Option<usize> },
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
            CodeError::SkipCrossesBody { from } => write!(f, "skip at {from} leaves or enters a function body"),
            CodeError::BodyWithoutCall { at } => write!(f, "function body at {at} reached without a call"),
            CodeError::CallOfNoBody { at } => write!(f, "call at {at} of no function body"),
            CodeError::ReturnsValues { n, at } => write!(f, "function returns {n} values at {at}"),
            CodeError::BlockShape { what, at: Some(at) } => write!(f, "{what} at {at}"),
            CodeError::BlockShape { what, at: None } => write!(f, "{what}"),
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
/// instruction is unreachable, and `Pick` reads an entry that exists. Function
/// bodies lie in `Funcs` blocks, each `Enter(arity)` … `Ret`, entered only by `Fn`
/// (whose target must be an `Enter`): a body starts with its arguments on the stack
/// and returns exactly one value, and no skip leaves or enters a body. `leaf` checks
/// a leaf's index, `func` whether a function is allowed; both get the instruction's
/// position for the message and say why in the caller's error type `E`, which holds
/// the machine's own [`CodeError`]s too.
pub fn check<O: StackOp, E: From<CodeError>>(
    code: &[O],
    mut leaf: impl FnMut(usize, O) -> Result<(), E>,
    mut func: impl FnMut(usize, Func) -> Result<(), E>,
) -> Result<(), E> {
    let region = regions(code).map_err(E::from)?;
    // The depth each skip brings to its target (index `code.len()`: the end).
    let mut arrive: Vec<Option<i64>> = vec![None; code.len() + 1];
    let meet = |arrive: &mut [Option<i64>], at: usize, d: i64, from: usize| -> Result<(), CodeError> {
        if region.get(at).copied().unwrap_or(0) != region[from] {
            return Err(CodeError::SkipCrossesBody { from });
        }
        match arrive.get_mut(at) {
            None => Err(CodeError::SkipBeyondEnd { from }),
            Some(Some(t)) if *t != d => Err(CodeError::DepthsMeet { a: *t, b: d, at: Some(at) }),
            Some(slot) => {
                *slot = Some(d);
                Ok(())
            }
        }
    };
    // `None`: the previous instruction was an unconditional skip or a return.
    let mut depth: Option<i64> = Some(0);
    for (i, op) in code.iter().enumerate() {
        if let Core::Enter(arity) = op.core() {
            if depth.is_some() || arrive[i].is_some() {
                return Err(CodeError::BodyWithoutCall { at: i }.into());
            }
            depth = Some(i64::from(arity));
            continue;
        }
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
            Core::Skip(n) | Core::Funcs(n) => {
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
            Core::Fn(rel) => {
                let target = i.checked_add_signed(rel as isize).and_then(|t| code.get(t)).map(|t| t.core());
                match target {
                    Some(Core::Enter(arity)) => (i64::from(arity), 1),
                    _ => return Err(CodeError::CallOfNoBody { at: i }.into()),
                }
            }
            Core::Ret => {
                if d != 1 {
                    return Err(CodeError::ReturnsValues { n: d, at: i }.into());
                }
                depth = None;
                continue;
            }
            Core::Enter(_) => (0, 0),
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

/// The function body each instruction belongs to (0: none; bodies are numbered from
/// 1 in order), checking the blocks' shape: a `Funcs` block inside the code and not
/// inside another, holding only bodies, each `Enter` … `Ret`; no `Enter` or `Ret`
/// elsewhere.
fn regions<O: StackOp>(code: &[O]) -> Result<Vec<u32>, CodeError> {
    let mut region = vec![0u32; code.len()];
    let (mut block_end, mut current, mut bodies) = (None::<usize>, 0u32, 0u32);
    for (i, op) in code.iter().enumerate() {
        if block_end == Some(i) {
            if current != 0 {
                return Err(CodeError::BlockShape { what: "function body without a return", at: Some(i) });
            }
            block_end = None;
        }
        match op.core() {
            Core::Funcs(n) => {
                let end = i + 1 + n as usize;
                if block_end.is_some() || end > code.len() {
                    return Err(CodeError::BlockShape { what: "misplaced function block", at: Some(i) });
                }
                block_end = Some(end);
            }
            Core::Enter(_) if block_end.is_some() && current == 0 => {
                bodies += 1;
                current = bodies;
            }
            Core::Enter(_) => {
                return Err(CodeError::BlockShape { what: "function body outside a function block", at: Some(i) })
            }
            Core::Ret if current != 0 => {
                region[i] = current;
                current = 0;
                continue;
            }
            Core::Ret => return Err(CodeError::BlockShape { what: "return outside a function body", at: Some(i) }),
            _ if block_end.is_some() && current == 0 => {
                return Err(CodeError::BlockShape { what: "instruction between function bodies", at: Some(i) });
            }
            _ => {}
        }
        region[i] = current;
    }
    if current != 0 {
        return Err(CodeError::BlockShape { what: "function body without a return", at: None });
    }
    Ok(region)
}

/// Evaluates verified expression code with `vars` (indexed like [`VARIABLES`]) and
/// the running rule's frame `slots`. Verified code never underflows; on malformed
/// code (or a slot beyond `slots`) the result is NaN, never a panic.
pub fn eval(code: &[ExprOp], vars: &[f64; 6], slots: &[f64], rng: &mut dyn Random, m: &mut Machine) -> f64 {
    run(
        code,
        m,
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
mod tests;
