//! A Context Free program (CFDG 2 or 3 syntax) read into a small tree: shapes with
//! their weighted rules, body items, adjustment lists and expressions. What the
//! reader cannot place is skipped to the next item with a report note, so a file
//! always gives a tree.

use super::cflex::{Tok, T};
use super::report::Report;

#[derive(Clone, Debug)]
pub(crate) enum Expr {
    Num(f64),
    Name(String),
    Call(String, Vec<Expr>),
    Bin(&'static str, Box<Expr>, Box<Expr>),
    Neg(Box<Expr>),
    Not(Box<Expr>),
    /// `(a, b)`: a vector (MDG's too, reference §14).
    Tuple(Vec<Expr>),
    /// `v[i]`: a vector's component.
    Index(Box<Expr>, Box<Expr>),
}

/// One adjustment: its name, arguments, and whether it is a target (`|`).
#[derive(Clone, Debug)]
pub(crate) struct Term {
    pub name: String,
    pub args: Vec<Expr>,
    pub target: bool,
    pub line: u32,
}

/// An adjustment list; `ordered`: applied as written (CFDG 3 `[[ ]]`, CFDG 2 `[ ]`),
/// else in Context Free's canonical order.
#[derive(Clone, Debug, Default)]
pub(crate) struct Adj {
    pub ordered: bool,
    pub terms: Vec<Term>,
}

/// A `case` label: a value, or a range `a..b`.
pub(crate) type CaseLabel = (Expr, Option<Expr>);

#[derive(Clone, Debug)]
pub(crate) enum Item {
    Call {
        name: String,
        args: Option<Vec<Expr>>,
        same: bool,
        adj: Adj,
        line: u32,
    },
    Block(Vec<Item>),
    Loop {
        var: Option<String>,
        start: Option<Expr>,
        end: Expr,
        step: Option<Expr>,
        adj: Adj,
        body: Box<Item>,
        line: u32,
    },
    If {
        cond: Expr,
        then: Box<Item>,
        els: Option<Box<Item>>,
    },
    Switch {
        on: Expr,
        cases: Vec<(Vec<CaseLabel>, Item)>,
        default: Option<Box<Item>>,
    },
    Let {
        name: String,
        value: Expr,
    },
    Transform {
        adj: Adj,
        body: Box<Item>,
    },
    /// A path operation (`MOVETO`, `ARCTO`, `FILL`, …) with its CFDG 3 arguments
    /// and its list (CFDG 2's coordinates, a paint's adjustments).
    PathOp {
        op: String,
        args: Vec<Expr>,
        adj: Adj,
        line: u32,
    },
    Nothing,
}

#[derive(Clone, Debug)]
pub(crate) struct RuleDef {
    pub weight: f64,
    pub percent: bool,
    pub body: Vec<Item>,
    pub line: u32,
}

#[derive(Clone, Debug)]
pub(crate) struct Shape {
    pub name: String,
    /// (type, name)
    pub params: Vec<(String, String)>,
    pub rules: Vec<RuleDef>,
    pub line: u32,
}

/// One copy of a rosette symmetry: (turn in degrees, the mirror line's angle in
/// degrees or none, centre x, centre y).
pub(crate) type SymmetryCopy = (f64, Option<f64>, f64, f64);

/// A whole program (an included file adds to it).
#[derive(Debug, Default)]
pub(crate) struct Program {
    pub v3: bool,
    pub start: Option<(String, Option<Vec<Expr>>, Adj, u32)>,
    pub shapes: Vec<Shape>,
    pub paths: Vec<String>,
    pub globals: Vec<(String, Expr)>,
    pub functions: Vec<(String, Vec<String>, Expr, u32)>,
    /// The parameter types of each function with parameters (`number`, `vector2`…).
    pub function_types: std::collections::BTreeMap<String, Vec<String>>,
    pub background: Option<(Adj, u32)>,
    /// `size`/`CF::Size`: the canvas's width and height in model units.
    pub canvas: Option<(f64, f64)>,
    /// `CF::MinimumSize` in pixels.
    pub min_size_px: Option<f64>,
    pub includes: Vec<(String, u32)>,
    /// `CF::Symmetry` of a rosette (`CF::Cyclic`, `CF::Dihedral`): the copies of
    /// the design, each (turn in degrees, mirror line's angle in degrees or none,
    /// centre x, centre y), the identity first.
    pub symmetry: Vec<SymmetryCopy>,
}

pub(crate) struct Parser<'a> {
    toks: &'a [Tok],
    i: usize,
    pub rep: &'a mut Report,
    pub prog: &'a mut Program,
    /// The shape that `rule {…}` (CFDG 3) adds to.
    current: Option<usize>,
    /// How deeply items and expressions nest here (hostile input is cut at
    /// [`MAX_NESTING`], so the reader and the writer never run out of stack).
    depth: u32,
}

/// The deepest nesting of items or expressions read; deeper ones are skipped.
const MAX_NESTING: u32 = 200;

const ADJ_NAMES: &[&str] = &[
    "x",
    "y",
    "z",
    "s",
    "size",
    "r",
    "rot",
    "rotate",
    "f",
    "flip",
    "skew",
    "h",
    "hue",
    "sat",
    "saturation",
    "b",
    "brightness",
    "a",
    "alpha",
    "trans",
    "transform",
    "time",
    "timescale",
    "x1",
    "y1",
    "x2",
    "y2",
    "rx",
    "ry",
    "width",
    "p",
    "param",
];

/// Names that are path operations (MDG's flat paths, the `…REL` ones included).
pub(crate) const PATH_OPS: &[&str] = &[
    "MOVETO",
    "MOVEREL",
    "LINETO",
    "LINEREL",
    "ARCTO",
    "ARCREL",
    "CURVETO",
    "CURVEREL",
    "CLOSEPOLY",
    "FILL",
    "STROKE",
];

const TYPES: &[&str] = &["number", "natural", "adjustment", "shape"];

/// A Context Free type word: `number`, `natural`, `adjustment`, `shape`, `vector2` … `vector99`.
fn is_type(w: &str) -> bool {
    TYPES.contains(&w) || crate::vectors::vector_size(w).is_some()
}

impl<'a> Parser<'a> {
    pub(crate) fn new(toks: &'a [Tok], rep: &'a mut Report, prog: &'a mut Program) -> Parser<'a> {
        Parser { toks, i: 0, rep, prog, current: None, depth: 0 }
    }

    fn peek(&self) -> Option<&T> {
        self.toks.get(self.i).map(|t| &t.t)
    }
    fn peek_at(&self, k: usize) -> Option<&T> {
        self.toks.get(self.i + k).map(|t| &t.t)
    }
    fn line(&self) -> u32 {
        self.toks.get(self.i).or(self.toks.last()).map(|t| t.line).unwrap_or(0)
    }
    fn is_p(&self, p: &str) -> bool {
        matches!(self.peek(), Some(T::P(q)) if *q == p)
    }
    fn is_id(&self, w: &str) -> bool {
        matches!(self.peek(), Some(T::Id(q)) if q == w)
    }
    fn eat_p(&mut self, p: &str) -> bool {
        if self.is_p(p) {
            self.i += 1;
            true
        } else {
            false
        }
    }
    fn id(&mut self) -> Option<String> {
        if let Some(T::Id(w)) = self.peek() {
            let w = w.clone();
            self.i += 1;
            Some(w)
        } else {
            None
        }
    }
    fn done(&self) -> bool {
        self.i >= self.toks.len()
    }

    /// Skips one balanced group starting here (or one token).
    fn skip_group(&mut self) {
        let open = match self.peek() {
            Some(T::P(p)) if ["{", "[", "[[", "("].contains(p) => *p,
            _ => {
                self.i += 1;
                return;
            }
        };
        let mut depth = 0i32;
        while let Some(t) = self.peek() {
            match t {
                T::P("{") | T::P("[") | T::P("(") => depth += 1,
                T::P("[[") => depth += 2,
                T::P("}") | T::P("]") | T::P(")") => depth -= 1,
                T::P("]]") => depth -= 2,
                _ => {}
            }
            self.i += 1;
            if depth <= 0 {
                break;
            }
        }
        let _ = open;
    }

    pub(crate) fn program(&mut self) {
        while !self.done() {
            let before = self.i;
            self.top_item();
            if self.i == before {
                let l = self.line();
                self.rep.drop(l, &tok_text(self.peek()), "not a Context Free item here: skipped");
                self.i += 1;
            }
        }
    }

    fn top_item(&mut self) {
        let line = self.line();
        let Some(T::Id(w)) = self.peek().cloned() else {
            if self.is_p("{") || self.is_p("[") {
                self.rep.drop(line, "{", "a list outside any shape: skipped");
                self.skip_group();
            }
            return;
        };
        match w.as_str() {
            "startshape" => {
                self.i += 1;
                let Some(name) = self.id() else { return };
                let args = if self.is_p("(") { Some(self.call_args()) } else { None };
                let adj = self.adj_opt().unwrap_or_default();
                if self.prog.start.is_none() {
                    self.prog.start = Some((name, args, adj, line));
                }
            }
            "shape" => {
                self.i += 1;
                let Some(name) = self.id() else { return };
                let params = if self.is_p("(") { self.params() } else { Vec::new() };
                let idx = self.shape_index(&name, params, line);
                self.current = Some(idx);
                if self.is_p("{") || matches!(self.peek(), Some(T::Num(_))) {
                    self.rule_body(idx, line);
                }
            }
            "rule" => {
                self.i += 1;
                if let Some(T::Id(n)) = self.peek().cloned() {
                    // CFDG 2: `rule NAME [weight] { … }`.
                    self.i += 1;
                    let idx = self.shape_index(&n, Vec::new(), line);
                    self.rule_body(idx, line);
                } else if let Some(idx) = self.current {
                    self.rule_body(idx, line);
                } else {
                    self.rep.drop(line, "rule", "a rule before any `shape`: skipped");
                    self.skip_to_group_end();
                }
            }
            "path" => {
                // A path is a shape whose one rule builds and paints a flat path.
                self.i += 1;
                let Some(name) = self.id() else { return };
                let params = if self.is_p("(") { self.params() } else { Vec::new() };
                let idx = self.shape_index(&name, params, line);
                self.prog.paths.push(name);
                self.current = None;
                if self.is_p("{") {
                    self.rule_body(idx, line);
                }
            }
            "include" | "import" => {
                self.i += 1;
                if let Some(T::Str(f)) = self.peek().cloned() {
                    self.i += 1;
                    self.prog.includes.push((f, line));
                }
            }
            "background" | "tile" | "size" => {
                self.i += 1;
                let adj = self.adj_opt().unwrap_or_default();
                self.setting(&w, adj, line);
            }
            _ if w.starts_with("CF::") => {
                self.i += 1;
                if !self.eat_p("=") {
                    return;
                }
                let key = w.trim_start_matches("CF::").to_string();
                if self.is_p("[") || self.is_p("[[") || self.is_p("{") {
                    let adj = self.adj_opt().unwrap_or_default();
                    let k = match key.as_str() {
                        "Background" => "background",
                        "Size" => "size",
                        "Tile" => "tile",
                        _ => "",
                    };
                    if k.is_empty() {
                        self.rep.drop(line, &w, "no MDG counterpart: left out");
                    } else {
                        self.setting(k, adj, line);
                    }
                } else if key == "StartShape" {
                    if let Some(n) = self.id() {
                        let args = if self.is_p("(") { Some(self.call_args()) } else { None };
                        self.prog.start = Some((n, args, Adj::default(), line));
                    }
                } else {
                    let e = self.expr(false);
                    match (key.as_str(), const_value(&e)) {
                        ("MinimumSize", Some(v)) => self.prog.min_size_px = Some(v),
                        ("MaxShapes", _) => self.rep.drop(
                            line,
                            &w,
                            "MDG bounds rule calls (`maxiter`), not shapes: the run's own limits apply",
                        ),
                        ("Symmetry", _) => {
                            // `CF::Symmetry = CF::Dihedral, 6[, angle][, x, y]`.
                            let mut data = Vec::new();
                            while self.eat_p(",") {
                                data.push(const_value(&self.expr(false)));
                            }
                            let kind = match &e {
                                Expr::Name(k) => k.as_str(),
                                _ => "",
                            };
                            match rosette(kind, &data) {
                                Some(copies) => self.prog.symmetry = copies,
                                None => self.rep.drop(
                                    line,
                                    &w,
                                    "only the rosettes (`CF::Cyclic`, `CF::Dihedral` with constant values) have \
                                     an MDG form: one copy is drawn",
                                ),
                            }
                        }
                        _ => self.rep.drop(line, &w, "no MDG counterpart: left out"),
                    }
                    while self.eat_p(",") {
                        let _ = self.expr(false);
                    }
                }
            }
            _ if is_type(&w) || matches!(self.peek_at(1), Some(T::P("=")) | Some(T::P("("))) => {
                self.global(line);
            }
            _ => {}
        }
    }

    /// `NAME = EXPR` or `TYPE NAME(PARAMS) = EXPR` at the top level.
    fn global(&mut self, line: u32) {
        if let Some(T::Id(w)) = self.peek() {
            if is_type(w) && matches!(self.peek_at(1), Some(T::Id(_))) {
                self.i += 1;
            }
        }
        let Some(name) = self.id() else { return };
        let params = if self.is_p("(") { Some(self.params()) } else { None };
        if !self.eat_p("=") {
            self.rep.drop(line, &name, "not a Context Free item here: skipped");
            return;
        }
        let mut e = self.expr(false);
        // `NAME = a, b`: a vector without parentheses.
        if self.is_p(",") {
            let mut items = vec![e];
            while self.eat_p(",") {
                items.push(self.expr(false));
            }
            e = Expr::Tuple(items);
        }
        match params {
            Some(p) => {
                if !p.is_empty() {
                    self.prog.function_types.insert(name.clone(), p.iter().map(|(t, _)| t.clone()).collect());
                }
                self.prog.functions.push((name, p.into_iter().map(|(_, n)| n).collect(), e, line))
            }
            None => self.prog.globals.push((name, e)),
        }
    }

    fn setting(&mut self, what: &str, adj: Adj, line: u32) {
        match what {
            "background" => self.prog.background = Some((adj, line)),
            "size" => {
                let mut w = None;
                for t in &adj.terms {
                    if t.name == "s" || t.name == "size" {
                        let v: Vec<f64> = t.args.iter().filter_map(const_value).collect();
                        w = match v.as_slice() {
                            [a] => Some((*a, *a)),
                            [a, b, ..] => Some((*a, *b)),
                            _ => None,
                        };
                    }
                }
                match w {
                    Some(c) => self.prog.canvas = Some(c),
                    None => {
                        self.rep.drop(line, "size", "a canvas without a constant `s`: the picture frames the model")
                    }
                }
            }
            _ => self.rep.drop(line, "tile", "MDG has no tiling: one tile is drawn"),
        }
    }

    fn skip_to_group_end(&mut self) {
        while !self.done() && !self.is_p("{") {
            self.i += 1;
        }
        self.skip_group();
    }

    fn shape_index(&mut self, name: &str, params: Vec<(String, String)>, line: u32) -> usize {
        if let Some(k) = self.prog.shapes.iter().position(|s| s.name == name) {
            if !params.is_empty() {
                self.prog.shapes[k].params = params;
            }
            return k;
        }
        self.prog.shapes.push(Shape { name: name.to_string(), params, rules: Vec::new(), line });
        self.prog.shapes.len() - 1
    }

    /// `[WEIGHT[%]] { BODY }` for shape `idx`.
    fn rule_body(&mut self, idx: usize, line: u32) {
        let mut weight = 1.0;
        let mut percent = false;
        if let Some(T::Num(v)) = self.peek() {
            weight = *v;
            self.i += 1;
            percent = self.eat_p("%");
        }
        if !self.is_p("{") {
            self.rep.drop(line, "rule", "a rule without a body: skipped");
            return;
        }
        let body = self.block();
        self.prog.shapes[idx].rules.push(RuleDef { weight, percent, body, line });
    }

    fn params(&mut self) -> Vec<(String, String)> {
        let mut out = Vec::new();
        self.i += 1; // (
        while !self.done() && !self.is_p(")") {
            let line = self.line();
            let mut ty = "number".to_string();
            let mut name = self.id().unwrap_or_default();
            if is_type(&name) {
                if let Some(T::Id(_)) = self.peek() {
                    ty = name;
                    name = self.id().unwrap_or_default();
                }
            }
            if self.eat_p("=") {
                let _ = self.expr(false);
                self.rep.approx(line, "default", "parameter defaults are dropped: calls pass every argument");
            }
            if !name.is_empty() {
                out.push((ty, name));
            } else {
                self.i += 1;
            }
            self.eat_p(",");
        }
        self.eat_p(")");
        out
    }

    /// `{ ITEMS }`
    fn block(&mut self) -> Vec<Item> {
        let mut items = Vec::new();
        if !self.eat_p("{") {
            return items;
        }
        while !self.done() && !self.is_p("}") {
            let before = self.i;
            let it = self.item();
            items.push(it);
            if self.i == before {
                let l = self.line();
                self.rep.drop(l, &tok_text(self.peek()), "not a Context Free body item: skipped");
                self.i += 1;
            }
        }
        self.eat_p("}");
        items
    }

    fn item(&mut self) -> Item {
        if self.depth >= MAX_NESTING {
            let l = self.line();
            self.rep.drop(l, "nesting", format!("items nested deeper than {MAX_NESTING}: skipped"));
            self.i += 1;
            return Item::Nothing;
        }
        self.depth += 1;
        let it = self.item_inner();
        self.depth -= 1;
        it
    }

    fn item_inner(&mut self) -> Item {
        let line = self.line();
        if self.is_p("{") {
            return Item::Block(self.block());
        }
        if let Some(T::Num(_)) | Some(T::P("(")) = self.peek() {
            // CFDG 2 loop `N * {adj} ITEM`.
            let save = self.i;
            // The count is one number or a parenthesised expression: `6 * {r 60}`
            // is a loop, not a product.
            let n = self.primary(false);
            if self.eat_p("*") {
                let adj = self.adj_opt().unwrap_or_default();
                let body = Box::new(self.item());
                return Item::Loop { var: None, start: None, end: n, step: None, adj, body, line };
            }
            self.i = save;
            return Item::Nothing;
        }
        let Some(T::Id(w)) = self.peek().cloned() else { return Item::Nothing };
        match w.as_str() {
            "loop" => {
                self.i += 1;
                let (mut var, mut start, mut step) = (None, None, None);
                if matches!(self.peek_at(1), Some(T::P("="))) {
                    var = self.id();
                    self.i += 1;
                }
                let mut end = self.expr(false);
                if self.eat_p(",") {
                    start = Some(end);
                    end = self.expr(false);
                    if self.eat_p(",") {
                        step = Some(self.expr(false));
                    }
                }
                // `loop i = (3, -4, -1)`: the bounds as one vector.
                if let (None, Expr::Tuple(items)) = (&start, &end) {
                    if let [a, b, rest @ ..] = items.as_slice() {
                        if rest.len() <= 1 {
                            step = rest.first().cloned();
                            start = Some(a.clone());
                            end = b.clone();
                        }
                    }
                }
                let adj = self.adj_opt().unwrap_or_default();
                let body = Box::new(self.item());
                if self.is_id("finally") {
                    self.i += 1;
                    self.rep.drop(line, "finally", "a loop's `finally` item is left out");
                    let _ = self.item();
                }
                Item::Loop { var, start, end, step, adj, body, line }
            }
            "if" => {
                self.i += 1;
                let cond = self.paren_expr();
                let then = Box::new(self.item());
                let els = if self.is_id("else") {
                    self.i += 1;
                    Some(Box::new(self.item()))
                } else {
                    None
                };
                Item::If { cond, then, els }
            }
            "switch" => {
                self.i += 1;
                let on = self.paren_expr();
                let mut cases = Vec::new();
                let mut default = None;
                if self.eat_p("{") {
                    while !self.done() && !self.is_p("}") {
                        if self.is_id("case") {
                            self.i += 1;
                            let mut labels = Vec::new();
                            loop {
                                // `case 4..5:` (or `4…5`): the expression reader takes
                                // the range as a `..` operator; a label keeps both ends.
                                let label = match self.expr(false) {
                                    Expr::Bin("..", a, b) => (*a, Some(*b)),
                                    a => (a, if self.eat_p("..") { Some(self.expr(false)) } else { None }),
                                };
                                labels.push(label);
                                if !self.eat_p(",") {
                                    break;
                                }
                            }
                            self.eat_p(":");
                            cases.push((labels, self.item()));
                        } else if self.is_id("else") {
                            self.i += 1;
                            self.eat_p(":");
                            default = Some(Box::new(self.item()));
                        } else {
                            self.i += 1;
                        }
                    }
                    self.eat_p("}");
                }
                Item::Switch { on, cases, default }
            }
            "transform" | "trans" => {
                self.i += 1;
                let adj = self.adj_opt().unwrap_or_default();
                while self.is_p("[") || self.is_p("[[") {
                    self.rep.approx(line, "transform", "only the first of several adjustment lists is kept");
                    let _ = self.adj_opt();
                }
                Item::Transform { adj, body: Box::new(self.item()) }
            }
            "clone" => {
                self.i += 1;
                let _ = self.adj_opt();
                let _ = self.item();
                self.rep.drop(line, "clone", "MDG cannot clone shapes: left out");
                Item::Nothing
            }
            _ if is_type(&w) && matches!(self.peek_at(2), Some(T::P("="))) => {
                self.i += 1;
                self.local()
            }
            _ if matches!(self.peek_at(1), Some(T::P("="))) => self.local(),
            _ if PATH_OPS.contains(&w.as_str()) => {
                self.i += 1;
                let args = if self.is_p("(") { self.call_args() } else { Vec::new() };
                let adj = self.adj_opt().unwrap_or_default();
                Item::PathOp { op: w, args, adj, line }
            }
            "path" if matches!(self.peek_at(1), Some(T::Id(_))) => {
                // `path CIRCLE [adj]`, `path star(2) [adj]`: another path's outline
                // added to this one; in MDG a path's call of a path or of a flat
                // primitive is that (reference §9, "Subpaths").
                self.i += 1;
                let name = self.id().unwrap_or_default();
                let args = if self.is_p("(") { Some(self.call_args()) } else { None };
                let adj = self.adj_opt().unwrap_or_default();
                Item::Call { name, args, same: false, adj, line }
            }
            _ => {
                self.i += 1;
                let mut same = false;
                let args = if self.is_p("(") {
                    if matches!(self.peek_at(1), Some(T::P("="))) && matches!(self.peek_at(2), Some(T::P(")"))) {
                        self.i += 3;
                        same = true;
                        None
                    } else {
                        Some(self.call_args())
                    }
                } else {
                    None
                };
                let adj = self.adj_opt().unwrap_or_default();
                Item::Call { name: w, args, same, adj, line }
            }
        }
    }

    fn local(&mut self) -> Item {
        let name = self.id().unwrap_or_default();
        self.eat_p("=");
        let mut value = self.expr(false);
        // `v = 1, 2, 3`: a vector without parentheses.
        if self.is_p(",") {
            let mut items = vec![value];
            while self.eat_p(",") {
                items.push(self.expr(false));
            }
            value = Expr::Tuple(items);
        }
        Item::Let { name, value }
    }

    fn paren_expr(&mut self) -> Expr {
        if self.eat_p("(") {
            let e = self.expr(false);
            self.eat_p(")");
            e
        } else {
            self.expr(false)
        }
    }

    fn call_args(&mut self) -> Vec<Expr> {
        let mut out = Vec::new();
        self.i += 1; // (
        while !self.done() && !self.is_p(")") {
            let before = self.i;
            out.push(self.expr(false));
            if !self.eat_p(",") && self.i == before {
                self.i += 1;
            }
        }
        self.eat_p(")");
        out
    }

    /// An adjustment list if one starts here.
    fn adj_opt(&mut self) -> Option<Adj> {
        let (close, ordered) = if self.is_p("[[") {
            ("]]", true)
        } else if self.is_p("[") {
            ("]", !self.prog.v3)
        } else if self.is_p("{") {
            ("}", false)
        } else {
            return None;
        };
        self.i += 1;
        let mut adj = Adj { ordered, terms: Vec::new() };
        while !self.done() && !self.is_p(close) {
            let line = self.line();
            let pre_target = self.eat_p("|");
            let Some(name) = self.id() else {
                let t = tok_text(self.peek());
                self.rep.drop(line, &t, "not an adjustment: skipped");
                if self.is_p("]") || self.is_p("}") || self.is_p("]]") {
                    // a bracket of the other kind: give up on the list
                    break;
                }
                self.skip_group();
                continue;
            };
            let mut args = Vec::new();
            let mut target = pre_target;
            while !self.done() && self.starts_arg() {
                args.push(self.expr(true));
                if self.eat_p("|") {
                    target = true;
                }
            }
            adj.terms.push(Term { name, args, target, line });
        }
        self.eat_p(close);
        Some(adj)
    }

    fn starts_arg(&self) -> bool {
        match self.peek() {
            Some(T::Num(_)) => true,
            Some(T::P("(")) | Some(T::P("-")) | Some(T::P("+")) | Some(T::P("!")) => true,
            Some(T::Id(w)) => !ADJ_NAMES.contains(&w.as_str()),
            _ => false,
        }
    }

    /// An expression; `arg`: an adjustment argument, where `a -1` is two values.
    pub(crate) fn expr(&mut self, arg: bool) -> Expr {
        if self.depth >= MAX_NESTING {
            let l = self.line();
            self.rep.drop(l, "nesting", format!("expressions nested deeper than {MAX_NESTING}: 0"));
            self.i += 1;
            return Expr::Num(0.0);
        }
        self.depth += 1;
        let e = self.binary(0, arg);
        self.depth -= 1;
        e
    }

    fn binary(&mut self, level: usize, arg: bool) -> Expr {
        const LEVELS: &[&[&str]] = &[
            &["||", "^^"],
            &["&&"],
            &["<", ">", "<=", ">=", "==", "!=", "<>"],
            &["+", "-", "--", "+-", ".."],
            &["*", "/", "%"],
        ];
        if level == LEVELS.len() {
            return self.unary(arg);
        }
        let mut l = self.binary(level + 1, arg);
        let mut chain = 0;
        while let Some(tok) = self.toks.get(self.i) {
            // A chain `1 + 1 + …` is a tree as deep as it is long: cut it too.
            chain += 1;
            if chain > MAX_NESTING {
                let line = tok.line;
                self.rep.drop(line, "nesting", format!("an operator chain longer than {MAX_NESTING}: cut"));
                break;
            }
            let T::P(p) = tok.t else { break };
            if !LEVELS[level].contains(&p) {
                break;
            }
            // In a list, `1 -2` (space before, none after) starts a new value.
            if arg && (p == "-" || p == "+") && tok.space && self.toks.get(self.i + 1).is_some_and(|n| !n.space) {
                break;
            }
            self.i += 1;
            let r = self.binary(level + 1, arg);
            l = Expr::Bin(p, Box::new(l), Box::new(r));
        }
        l
    }

    fn unary(&mut self, arg: bool) -> Expr {
        if self.depth >= MAX_NESTING {
            self.i += 1;
            return Expr::Num(0.0);
        }
        self.depth += 1;
        let e = self.unary_inner(arg);
        self.depth -= 1;
        e
    }

    fn unary_inner(&mut self, arg: bool) -> Expr {
        if self.eat_p("-") {
            return Expr::Neg(Box::new(self.unary(arg)));
        }
        if self.eat_p("+") {
            return self.unary(arg);
        }
        if self.eat_p("!") {
            return Expr::Not(Box::new(self.unary(arg)));
        }
        let base = self.primary(arg);
        if self.eat_p("^") {
            let e = self.unary(arg);
            return Expr::Bin("^", Box::new(base), Box::new(e));
        }
        base
    }

    fn primary(&mut self, arg: bool) -> Expr {
        let start = self.i;
        let mut e = self.primary_inner(arg);
        // `v[i]` (no space before `[`) after a value read here (not an adjustment
        // given as an argument, `f([s 2])`).
        while self.i > start
            && self.is_p("[")
            && self.toks.get(self.i).is_some_and(|t| !t.space)
            && self.depth < MAX_NESTING
        {
            let line = self.line();
            self.i += 1;
            let i = self.expr(false);
            let mut more = Vec::new();
            while self.eat_p(",") {
                more.push(self.expr(false));
            }
            self.eat_p("]");
            // `v[i, n]`, `v[i, n, stride]`: n components from i, `stride` apart.
            let part = match (const_value(&i), more.first().and_then(const_value), more.get(1).map(const_value)) {
                (Some(i), Some(n), None | Some(Some(_))) if more.len() <= 2 && (1.0..=99.0).contains(&n) => {
                    let stride = more.get(1).and_then(const_value).unwrap_or(1.0);
                    Some((0..n as usize).map(|k| i + k as f64 * stride).collect::<Vec<f64>>())
                }
                _ => None,
            };
            e = match part {
                _ if more.is_empty() => Expr::Index(Box::new(e), Box::new(i)),
                Some(ks) if ks.len() == 1 => Expr::Index(Box::new(e), Box::new(Expr::Num(ks[0]))),
                Some(ks) => Expr::Tuple(
                    ks.into_iter().map(|k| Expr::Index(Box::new(e.clone()), Box::new(Expr::Num(k)))).collect(),
                ),
                None => {
                    self.rep.approx(line, "v[i, n]", "a part of a vector at an index known only at run time has no MDG form: the component `v[i]` is used");
                    Expr::Index(Box::new(e), Box::new(i))
                }
            };
        }
        e
    }

    fn primary_inner(&mut self, arg: bool) -> Expr {
        match self.peek().cloned() {
            Some(T::Num(v)) => {
                self.i += 1;
                Expr::Num(v)
            }
            Some(T::P("(")) => {
                self.i += 1;
                let mut items = vec![self.expr(false)];
                while self.eat_p(",") {
                    items.push(self.expr(false));
                }
                self.eat_p(")");
                if items.len() == 1 {
                    items.pop().unwrap_or(Expr::Num(0.0))
                } else {
                    Expr::Tuple(items)
                }
            }
            Some(T::Id(w)) => {
                self.i += 1;
                if self.is_p("(") && !self.toks.get(self.i).is_some_and(|t| t.space && arg) {
                    Expr::Call(w, self.call_args())
                } else {
                    Expr::Name(w)
                }
            }
            _ => Expr::Num(0.0),
        }
    }
}

/// The value of a constant expression of numbers.
/// The copies of a rosette symmetry, as Context Free's `processDihedral` makes
/// them: for turn k of `order`, the turned copy and (dihedral) the turned copy
/// mirrored across the line at `angle` through the centre; duplicates once.
fn rosette(kind: &str, data: &[Option<f64>]) -> Option<Vec<SymmetryCopy>> {
    let d: Vec<f64> = data.iter().copied().collect::<Option<Vec<f64>>>()?;
    let (order, angle, x, y, mirrored) = match (kind, d.as_slice()) {
        ("CF::Cyclic", [n]) => (*n, 0.0, 0.0, 0.0, false),
        ("CF::Cyclic", [n, x, y]) => (*n, 0.0, *x, *y, false),
        ("CF::Dihedral", [n]) => (*n, 0.0, 0.0, 0.0, true),
        ("CF::Dihedral", [n, a]) => (*n, *a, 0.0, 0.0, true),
        ("CF::Dihedral", [n, x, y]) => (*n, 0.0, *x, *y, true),
        ("CF::Dihedral", [n, a, x, y]) => (*n, *a, *x, *y, true),
        _ => return None,
    };
    if !(1.0..=360.0).contains(&order) {
        return None;
    }
    let n = order as u32;
    let mut out = Vec::new();
    for k in 0..n {
        let turn = f64::from(k) * 360.0 / order;
        out.push((turn, None, x, y));
        // (For order 1 the mirror is the only other copy; a mirror never equals a turn.)
        if mirrored {
            out.push((turn, Some(angle), x, y));
        }
    }
    Some(out)
}

pub(crate) fn const_value(e: &Expr) -> Option<f64> {
    match e {
        Expr::Num(v) => Some(*v),
        Expr::Neg(a) => const_value(a).map(|v| -v),
        Expr::Bin(op, a, b) => {
            let (a, b) = (const_value(a)?, const_value(b)?);
            Some(match *op {
                "+" => a + b,
                "-" => a - b,
                "*" => a * b,
                "/" => a / b,
                "^" => a.powf(b),
                "--" => (a - b).max(0.0),
                _ => return None,
            })
        }
        Expr::Call(f, args) if args.len() == 1 => {
            let a = const_value(&args[0])?;
            Some(match f.as_str() {
                "sqrt" => a.sqrt(),
                "sin" => a.to_radians().sin(),
                "cos" => a.to_radians().cos(),
                _ => return None,
            })
        }
        _ => None,
    }
}

pub(crate) fn tok_text(t: Option<&T>) -> String {
    match t {
        Some(T::Num(v)) => format!("{v}"),
        Some(T::Id(w)) => w.clone(),
        Some(T::Str(s)) => format!("\"{s}\""),
        Some(T::P(p)) => p.to_string(),
        None => "end of file".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::super::cflex::lex;
    use super::*;

    #[test]
    fn hostile_nesting_is_cut_not_overflowed() {
        let deep = format!(
            "startshape A\nshape A {{ SQUARE [x {}1 y {}] {} }}\n",
            "(".repeat(100_000),
            "1+".repeat(100_000),
            "{".repeat(100_000)
        );
        let toks = lex(&deep, true).toks;
        let (mut rep, mut prog) = (Report::new("t", "context-free"), Program::default());
        Parser::new(&toks, &mut rep, &mut prog).program();
        assert!(rep.notes.iter().any(|n| n.construct == "nesting"));
        assert_eq!(prog.shapes.len(), 1);
    }
}
