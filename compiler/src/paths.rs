//! Flat paths (Context Free's `path`, reference §9 "Flat paths"): which rule
//! definitions are paths, and how a path drawable's arguments and option words
//! become the fixed arguments the VM's `DRAW` takes
//! ([`mdg_vm::bundle::ops::path_arity`]). Shared by the checker and lowering.

use crate::ast::{walk_body, BodyItem, BodyKind, Expr};
use mdg_vm::bundle::ops::{path_bits, PATH_WORDS};

/// The drawables that exist only in flat paths; one of them in a rule definition
/// makes it a path (its `MOVETO`/`LINETO` then build the path).
pub const PATH_DRAWABLES: &[&str] =
    &["ARCTO", "CURVETO", "CLOSEPOLY", "FILL", "STROKE", "MOVEREL", "LINEREL", "ARCREL", "CURVEREL"];

/// The relative drawables (CFDG 3's) and the absolute ones they are the same as,
/// their point (and a curve's control points) offset from the current point.
pub const RELATIVE: &[(&str, &str)] =
    &[("MOVEREL", "MOVETO"), ("LINEREL", "LINETO"), ("ARCREL", "ARCTO"), ("CURVEREL", "CURVETO")];

/// The absolute drawable `name` stands for and the option bits it adds:
/// `LINEREL` is `LINETO` with [`path_bits::REL`], any other name itself.
pub fn canonical(name: &str) -> (&str, u32) {
    match RELATIVE.iter().find(|(r, _)| *r == name) {
        Some((_, abs)) => (abs, path_bits::REL),
        None => (name, 0),
    }
}

fn calls<'a>(body: &'a [BodyItem], names: &[&str]) -> Option<&'a BodyItem> {
    let mut found = None;
    walk_body(body, &mut |item| {
        if let BodyKind::Call { name, .. } = &item.kind {
            if found.is_none() && names.contains(&name.text.as_str()) {
                found = Some(item);
            }
        }
    });
    found
}

/// Whether a rule definition with this body is a flat path.
pub fn is_path(body: &[BodyItem]) -> bool {
    calls(body, PATH_DRAWABLES).is_some()
}

/// Whether a path paints itself (else a `FILL {}` is implied at its end, as in
/// Context Free).
pub fn paints(body: &[BodyItem]) -> bool {
    calls(body, &["FILL", "STROKE"]).is_some()
}

/// Whether `name` is a drawable of flat paths in a path definition.
pub fn is_path_op(name: &str, in_path: bool) -> bool {
    PATH_DRAWABLES.contains(&name) || (in_path && matches!(name, "MOVETO" | "LINETO"))
}

/// Why an option word is refused.
#[derive(Clone, Debug, PartialEq)]
pub enum BadOption {
    /// The part is another drawable's option.
    Elsewhere { part: String, drawable: &'static str, owner: &'static str },
    /// No drawable has the part; `known` are this drawable's.
    Unknown { part: String, drawable: &'static str, known: Vec<&'static str> },
    /// Two joins or two caps.
    Twice { word: String },
}

impl std::fmt::Display for BadOption {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            BadOption::Elsewhere { part, drawable, owner } => {
                write!(f, "`{part}` is an option of `{owner}`, not of `{drawable}`")
            }
            BadOption::Unknown { part, drawable, known } if known.is_empty() => {
                write!(f, "`{drawable}` takes no option word (`{part}`)")
            }
            BadOption::Unknown { part, drawable, known } => {
                write!(f, "unknown option `{part}` of `{drawable}`: {}", known.join(", "))
            }
            BadOption::Twice { word } => write!(f, "`{word}` names two joins or two caps"),
        }
    }
}

/// The option bits of the word after a path drawable (`evenodd`, `large_cw`,
/// `roundjoin_roundcap`: words joined by `_`).
pub fn option_bits(drawable: &str, word: &str) -> Result<u32, BadOption> {
    let drawable = canonical(drawable).0;
    let name =
        |d: &str| PATH_WORDS.iter().map(|(_, _, n)| *n).chain(["MOVETO", "LINETO"]).find(|n| *n == d).unwrap_or("");
    let drawable = name(drawable);
    let mut bits = 0;
    for part in word.split('_') {
        match PATH_WORDS.iter().find(|(w, _, _)| *w == part) {
            Some((_, b, d)) if *d == drawable => bits |= b,
            Some((_, _, d)) => return Err(BadOption::Elsewhere { part: part.to_string(), drawable, owner: d }),
            None => {
                let known = PATH_WORDS.iter().filter(|(_, _, d)| *d == drawable).map(|(w, _, _)| *w).collect();
                return Err(BadOption::Unknown { part: part.to_string(), drawable, known });
            }
        }
    }
    let joins = [path_bits::ROUNDJOIN, path_bits::BEVELJOIN];
    let caps = [path_bits::ROUNDCAP, path_bits::SQUARECAP];
    for group in [&joins, &caps] {
        if group.iter().filter(|b| bits & **b != 0).count() > 1 {
            return Err(BadOption::Twice { word: word.to_string() });
        }
    }
    Ok(bits)
}

/// The numbers of arguments `drawable` takes in a path with option `bits`, for
/// the message of a wrong count.
pub fn arities(drawable: &str, bits: u32) -> &'static [usize] {
    let smooth = bits & path_bits::SMOOTH != 0;
    match drawable {
        // A relative point needs its offset (a frame's origin is no offset).
        "MOVEREL" | "LINEREL" => &[2],
        d => match canonical(d).0 {
            "MOVETO" | "LINETO" => &[0, 2],
            "ARCTO" => &[3, 5],
            "CURVETO" if smooth => &[2, 4],
            "CURVETO" => &[4, 6],
            "STROKE" => &[0, 1],
            _ => &[0],
        },
    }
}

/// Says how many arguments `drawable` takes (`2 or 4`).
pub fn arity_text(drawable: &str, bits: u32) -> String {
    let a = arities(drawable, bits);
    let v: Vec<String> = a.iter().map(usize::to_string).collect();
    v.join(" or ")
}

/// The VM's arguments for `drawable` given `args`: every position filled (`None`
/// for a default: 0, or a `STROKE`'s width 0.1, Context Free's), the last being
/// the option bits. `None` when the count is wrong (the checker says so).
pub fn vm_args<'a>(drawable: &str, args: &'a [Expr], bits: u32) -> Option<(Vec<Option<&'a Expr>>, f64)> {
    if !arities(drawable, bits).contains(&args.len()) {
        return None;
    }
    let a = |i: usize| args.get(i);
    let (drawable, rel) = canonical(drawable);
    let mut bits = bits | rel;
    let v = match drawable {
        "MOVETO" | "LINETO" => vec![a(0), a(1)],
        // ARCTO(x, y, r) is a circle's arc: rx = ry = r, no turn.
        "ARCTO" if args.len() == 3 => vec![a(0), a(1), a(2), a(2), None],
        "ARCTO" => vec![a(0), a(1), a(2), a(3), a(4)],
        "CURVETO" => {
            let smooth = bits & path_bits::SMOOTH != 0;
            if args.len() == 6 || (smooth && args.len() == 4) {
                bits |= path_bits::CUBIC;
            }
            vec![a(0), a(1), a(2), a(3), a(4), a(5)]
        }
        "STROKE" => vec![a(0)],
        _ => vec![],
    };
    Some((v, f64::from(bits)))
}

/// Context Free's default stroke width.
pub const DEFAULT_STROKE_WIDTH: f64 = 0.1;

/// One op of a primitive's outline: the drawable and its VM arguments (without
/// the option bits, which are 0).
pub type OutlineOp = (&'static str, &'static [f64]);

/// Context Free's flat primitives as subpaths (`path CIRCLE [..]` there, a call of
/// `CIRCLE` in a path here): the outlines Context Free 3 adds, counter-clockwise
/// and closed: the circle of diameter 1 as two half-circle arcs from (½, 0), the
/// unit square from (½, ½), the unit triangle (centroid at the origin) from its top.
pub fn primitive_outline(name: &str) -> Option<&'static [OutlineOp]> {
    // The triangle's circumradius 1/√3 and its inradius half that.
    const H: f64 = 0.577_350_269_189_625_8;
    const CIRCLE: &[OutlineOp] = &[
        ("MOVETO", &[0.5, 0.0]),
        ("ARCTO", &[-0.5, 0.0, 0.5, 0.5, 0.0]),
        ("ARCTO", &[0.5, 0.0, 0.5, 0.5, 0.0]),
        ("CLOSEPOLY", &[]),
    ];
    const SQUARE: &[OutlineOp] = &[
        ("MOVETO", &[0.5, 0.5]),
        ("LINETO", &[-0.5, 0.5]),
        ("LINETO", &[-0.5, -0.5]),
        ("LINETO", &[0.5, -0.5]),
        ("CLOSEPOLY", &[]),
    ];
    const TRIANGLE: &[OutlineOp] =
        &[("MOVETO", &[0.0, H]), ("LINETO", &[-0.5, -H / 2.0]), ("LINETO", &[0.5, -H / 2.0]), ("CLOSEPOLY", &[])];
    match name {
        "CIRCLE" => Some(CIRCLE),
        "SQUARE" => Some(SQUARE),
        "TRIANGLE" => Some(TRIANGLE),
        _ => None,
    }
}
