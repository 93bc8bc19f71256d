//! Rule parameters and locals: their types, the signatures of rules, and the type
//! of an expression (SPEC "Rules with parameters", docs/reference.md).
//!
//! Every value is a number at run time; the types exist for the checker: `int` is a
//! whole number (counts, depths), `float` any number, `bool` a truth value (a
//! comparison, `&&`, `||`, `!`, `true`, `false`). An `int` is accepted where a `float`
//! is expected; nothing else converts silently (`floor(x)` makes an `int`, `x != 0` a
//! `bool`).

use crate::ast::{BinOp, Expr, ExprKind, Number};
use crate::span::Span;

/// A parameter or local type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ty {
    Int,
    Float,
    Bool,
}

/// The words a parameter list accepts as types.
pub const TYPE_NAMES: &[&str] = &["int", "float", "bool"];

impl Ty {
    /// The type a word names (`int`, `float`, `bool`).
    pub fn parse(word: &str) -> Option<Ty> {
        match word {
            "int" => Some(Ty::Int),
            "float" => Some(Ty::Float),
            "bool" => Some(Ty::Bool),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Ty::Int => "int",
            Ty::Float => "float",
            Ty::Bool => "bool",
        }
    }

    /// "an `int`", "a `float`", "a `bool`".
    pub fn article(self) -> &'static str {
        match self {
            Ty::Int => "an `int`",
            Ty::Float => "a `float`",
            Ty::Bool => "a `bool`",
        }
    }

    /// Whether a value of type `given` may be passed where `self` is expected.
    pub fn accepts(self, given: Ty) -> bool {
        self == given || (self == Ty::Float && given == Ty::Int)
    }

    /// The type of `-a`, `a + b`: `int` when both are `int` (or `bool`), else `float`.
    fn numeric(a: Ty, b: Ty) -> Ty {
        if a == Ty::Float || b == Ty::Float {
            Ty::Float
        } else {
            Ty::Int
        }
    }
}

/// One parameter of a rule.
#[derive(Clone, Debug, PartialEq)]
pub struct SigParam {
    pub name: String,
    pub ty: Ty,
    /// The default's value (defaults are compile-time constants).
    pub default: Option<f64>,
    /// The span of the declaration (`float len = 1`).
    pub span: Span,
}

impl SigParam {
    /// `float len = 1`.
    pub fn label(&self) -> String {
        match self.default {
            Some(d) => format!("{} {} = {d}", self.ty.name(), self.name),
            None => format!("{} {}", self.ty.name(), self.name),
        }
    }
}

/// The parameters of a rule (the same for every definition).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Signature {
    pub params: Vec<SigParam>,
}

impl Signature {
    /// How many arguments a call must pass (the parameters before the first default).
    pub fn required(&self) -> usize {
        self.params.iter().take_while(|p| p.default.is_none()).count()
    }

    /// `tree(int n, float len = 1)`.
    pub fn label(&self, name: &str) -> String {
        let list = param_labels(&self.params);
        format!("{name}({})", list.join(", "))
    }
}

/// The labels of a rule's parameters as written: the components `float v[0]`,
/// `float v[1]` of a vector parameter are one `vector2 v` (with its default `(1,
/// 2)`); others as [`SigParam::label`] (a vector is a group of scalars after
/// `crate::vectors`).
pub fn param_labels(params: &[SigParam]) -> Vec<String> {
    param_groups(params).into_iter().map(|g| g.label).collect()
}

/// A parameter as written: a number parameter, or the components of a vector one.
pub struct ParamGroup {
    /// `len`, or `at` for the components `at[0]`, `at[1]`.
    pub name: String,
    /// `float`, `vector2`.
    pub ty: String,
    /// `float len = 1`, `vector2 at = (0, 1)`.
    pub label: String,
}

/// The parameters as written (see [`param_labels`]).
pub fn param_groups(params: &[SigParam]) -> Vec<ParamGroup> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < params.len() {
        let p = &params[i];
        let base = p.name.strip_suffix("[0]");
        let n = match base {
            Some(b) => params[i..].iter().enumerate().take_while(|(k, q)| q.name == format!("{b}[{k}]")).count(),
            None => 1,
        };
        match base {
            Some(b) if n > 1 => {
                let defaults: Option<Vec<String>> =
                    params[i..i + n].iter().map(|q| q.default.map(|d| d.to_string())).collect();
                let ty = format!("vector{n}");
                let label = match defaults {
                    Some(d) => format!("{ty} {b} = ({})", d.join(", ")),
                    None => format!("{ty} {b}"),
                };
                out.push(ParamGroup { name: b.to_string(), ty, label });
            }
            _ => out.push(ParamGroup { name: p.name.clone(), ty: p.ty.name().to_string(), label: p.label() }),
        }
        i += n.max(1);
    }
    out
}

/// The type of a number literal: `int` for digits alone, `float` with a point, an
/// exponent or an angle unit.
pub fn number_type(n: &Number) -> Ty {
    if n.unit.is_some() || n.text.contains(['.', 'e', 'E']) {
        Ty::Float
    } else {
        Ty::Int
    }
}

/// The type of `e`, with the types of names from `var` (`None`: unknown, reported
/// elsewhere; it then counts as `float`).
pub fn type_of(e: &Expr, var: &dyn Fn(&str) -> Option<Ty>) -> Ty {
    match &e.kind {
        ExprKind::Num(n) => number_type(n),
        ExprKind::Var(v) => var(&v.text).unwrap_or(Ty::Float),
        ExprKind::Neg(x) => Ty::numeric(type_of(x, var), Ty::Int),
        ExprKind::Paren(x) => type_of(x, var),
        ExprKind::Not(_) => Ty::Bool,
        ExprKind::Binary(op, a, b) => match op {
            BinOp::Or | BinOp::And | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge | BinOp::Eq | BinOp::Ne => Ty::Bool,
            BinOp::Add | BinOp::Sub | BinOp::Mul => Ty::numeric(type_of(a, var), type_of(b, var)),
            BinOp::Div | BinOp::Pow => Ty::Float,
        },
        ExprKind::Let(_, body) => type_of(body, var),
        ExprKind::Call(f, args) => match f.text.as_str() {
            "floor" | "ceil" => Ty::Int,
            // The branches' type (the index or condition is not a value).
            "if" | "select" => args.iter().skip(1).map(|a| type_of(a, var)).fold(Ty::Int, Ty::numeric),
            "abs" | "min" | "max" | "mod" | "clamp" => args.iter().map(|a| type_of(a, var)).fold(Ty::Int, Ty::numeric),
            _ => Ty::Float,
        },
        // Rewritten into scalars before checking (`crate::vectors`).
        ExprKind::Tuple(_) | ExprKind::Index(..) | ExprKind::Error => Ty::Float,
    }
}

/// The fix that turns a value of type `given` into one of type `want`, as text
/// around `src` (the argument as written), when there is an obvious one.
pub fn conversion(want: Ty, given: Ty, src: &str) -> Option<String> {
    match (want, given) {
        (Ty::Int, Ty::Float) => Some(format!("floor({src})")),
        (Ty::Bool, Ty::Int | Ty::Float) => Some(format!("{src} != 0")),
        _ => None,
    }
}
