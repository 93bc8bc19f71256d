//! What one step of an iterator does: `30/30 * [ry 360]` steps by `ry 12°`.
//!
//! Divisors split the step (reference §7): translations, angles and colour and weight
//! deltas are divided by N, a scale k becomes k^(1/N), reflections are kept. Angles
//! are shown in degrees, honouring unit suffixes and the `angle` directive.

use super::index::IterInfo;
use crate::ast::*;
use crate::check::{AdjKind, Components};
use crate::expand::Expanded;

/// The unit of angles written without a suffix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AngleUnit {
    Degrees,
    Radians,
    Orbits,
}

impl AngleUnit {
    /// The unit set by the program's `angle` directive (degrees without one).
    pub fn of(ex: &Expanded) -> AngleUnit {
        for e in &ex.items {
            if let ItemKind::Directive { name, args } = &e.item.kind {
                if name.text == "angle" {
                    if let [DirArg::Word(w)] = args.as_slice() {
                        return match w.text.as_str() {
                            "radians" => AngleUnit::Radians,
                            "orbits" | "frequency" => AngleUnit::Orbits,
                            _ => AngleUnit::Degrees,
                        };
                    }
                }
            }
        }
        AngleUnit::Degrees
    }

    /// Degrees for a value in this unit.
    fn to_degrees(self, v: f64) -> f64 {
        match self {
            AngleUnit::Degrees => v,
            AngleUnit::Radians => v.to_degrees(),
            AngleUnit::Orbits => v * 360.0,
        }
    }
}

/// Degrees for a number with an optional unit suffix.
pub fn angle_degrees(value: f64, unit: Option<char>, mode: AngleUnit) -> f64 {
    match unit {
        Some('d') => value,
        Some('r') => value.to_degrees(),
        Some('o') => value * 360.0,
        Some('t') => value.atan().to_degrees(),
        _ => mode.to_degrees(value),
    }
}

/// What the step computation needs from the program.
pub struct StepContext<'a> {
    pub angle: AngleUnit,
    pub components: &'a Components,
    pub constant: &'a dyn Fn(&str) -> Option<f64>,
}

/// One iterator, described.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    /// The number of runs, when it is a constant.
    pub count: Option<f64>,
    /// The divisor (1 without one), when it is a constant.
    pub divisor: Option<f64>,
    /// One step's transform, e.g. `ry 12°`; empty for `{}`.
    pub transform: String,
}

/// Describes an iterator's step.
pub fn describe(info: &IterInfo, cx: &StepContext) -> Step {
    let count = count_value(&info.count, cx);
    let divisor = match &info.divisor {
        Some(d) => count_value(d, cx),
        None => Some(1.0),
    };
    let n = divisor.filter(|d| *d > 0.0);
    let parts: Vec<String> = info.adj.adjs.iter().filter_map(|a| adjustment(a, n, cx)).collect();
    Step { count, divisor, transform: parts.join(" ") }
}

fn count_value(c: &Count, cx: &StepContext) -> Option<f64> {
    match c {
        Count::Num(n) => Some(n.value),
        Count::Neg(n) => Some(-n.value),
        Count::Expr(e) => crate::consteval::eval(e, cx.constant),
    }
}

/// An argument's value (angles in degrees), or its text when it is not constant.
enum Value {
    Known(f64),
    Text(String),
}

fn arg_value(a: &Arg, angle: bool, cx: &StepContext) -> Value {
    let conv = |v: f64, unit: Option<char>| if angle { angle_degrees(v, unit, cx.angle) } else { v };
    match a {
        Arg::Num(n) => Value::Known(conv(n.value, n.unit)),
        Arg::Neg(n) => Value::Known(conv(-n.value, n.unit)),
        Arg::Expr(e) => match crate::consteval::eval(e, cx.constant) {
            Some(v) => Value::Known(conv(v, None)),
            None => Value::Text(crate::fmt::expr(e)),
        },
    }
}

fn adjustment(a: &Adj, n: Option<f64>, cx: &StepContext) -> Option<String> {
    let kind = cx.components.adj_kind(&a.name.text)?;
    let name = &a.name.text;
    let deg = |s: String| if kind.is_angle() { format!("{s}°") } else { s };
    let divided = |v: Value| -> String {
        match (v, n) {
            (Value::Known(x), Some(n)) => deg(fmt_num(x / n)),
            (Value::Known(x), None) => format!("{}/?", deg(fmt_num(x))),
            (Value::Text(t), Some(n)) => {
                if n == 1.0 {
                    t
                } else {
                    format!("{t}/{}", fmt_num(n))
                }
            }
            (Value::Text(t), None) => format!("{t}/?"),
        }
    };
    let args: Vec<Value> = a.args.iter().map(|x| arg_value(x, kind.is_angle(), cx)).collect();
    let text = match kind {
        AdjKind::Flip(_) => {
            let raw: Vec<String> = a.args.iter().map(arg_text).collect();
            std::iter::once(name.clone()).chain(raw).collect::<Vec<_>>().join(" ")
        }
        AdjKind::Scale => {
            // The n-th root of each factor.
            let root = |v: Value| match (v, n) {
                (Value::Known(k), Some(n)) => fmt_num(k.powf(1.0 / n)),
                (Value::Known(k), None) => format!("{}^(1/?)", fmt_num(k)),
                (Value::Text(t), Some(1.0)) => t,
                (Value::Text(t), Some(n)) => format!("{t}^(1/{})", fmt_num(n)),
                (Value::Text(t), None) => format!("{t}^(1/?)"),
            };
            std::iter::once(name.clone()).chain(args.into_iter().map(root)).collect::<Vec<_>>().join(" ")
        }
        AdjKind::Turn(..) if args.is_empty() => format!("{name} {}", divided(Value::Known(90.0))),
        _ => {
            let vals: Vec<String> = args.into_iter().map(divided).collect();
            std::iter::once(name.clone()).chain(vals).collect::<Vec<_>>().join(" ")
        }
    };
    Some(text.trim_end().to_string())
}

fn arg_text(a: &Arg) -> String {
    match a {
        Arg::Num(n) => n.text.clone(),
        Arg::Neg(n) => format!("-{}", n.text),
        Arg::Expr(e) => crate::fmt::expr(e),
    }
}

/// A number for display: integers without a fraction, others with up to four
/// decimals (trailing zeros dropped), tiny values in scientific notation.
pub fn fmt_num(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if (v - v.round()).abs() < 1e-9 {
        let r = v.round();
        return if r == 0.0 { "0".to_string() } else { format!("{r}") };
    }
    if v.abs() < 1e-3 {
        return format!("{v:.3e}");
    }
    let s = format!("{v:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_short() {
        assert_eq!(fmt_num(12.0), "12");
        assert_eq!(fmt_num(-0.0), "0");
        assert_eq!(fmt_num(0.5), "0.5");
        assert_eq!(fmt_num(1.0 / 3.0), "0.3333");
        assert_eq!(fmt_num(0.002 / 400.0), "5.000e-6");
    }

    #[test]
    fn angle_suffixes_override_the_mode() {
        assert_eq!(angle_degrees(45.0, Some('d'), AngleUnit::Orbits), 45.0);
        assert_eq!(angle_degrees(0.25, Some('o'), AngleUnit::Degrees), 90.0);
        assert!((angle_degrees(1.0, Some('t'), AngleUnit::Degrees) - 45.0).abs() < 1e-9);
        assert!((angle_degrees(std::f64::consts::PI, None, AngleUnit::Radians) - 180.0).abs() < 1e-9);
        assert_eq!(angle_degrees(1.0, None, AngleUnit::Orbits), 360.0);
    }
}
