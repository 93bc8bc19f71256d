//! Lowering: a checked program to a bundle (`mdg_vm::bundle::Bundle`).
//!
//! Each adjustment list becomes one precomputed composite (q, q̂, u) plus colour,
//! weight and fps deltas (SPEC §4); lists whose arguments draw random numbers become
//! dynamic transforms composed at run time. Iterators become LOOP/ENDLOOP pairs,
//! blocks a LOOP of one run, continuation a CONT after the item (see the opcode table
//! in `vm/src/bundle/ops.rs`). Everything is emitted in a deterministic order, so the
//! same source and options give byte-identical bundles.

use crate::ast::*;
use crate::check::{AdjKind, Symbols};
use crate::consteval::{self, vm_binop, Call, Leaves};
use crate::diag::Diagnostic;
use crate::expand::{ExpItem, Expanded};
use crate::ext::LowerCx;
use crate::source::Sources;
use crate::span::Span;
use mdg_vm::bundle::{
    self, proto, AdjOp, Bundle, Composite, Def, Drawable, ExprId, IsoId, NsId, Op, OpCount, OpIndex, PrimAdj, Profile,
    ProtoId, RuleId, Selector, Settings, SlotId, SourceLoc, Transform, TransformId, CONT_NEXT, NONE, PATH_OP, SUBPATH,
};
use mdg_vm::expr::{BinOp as VmBinOp, ExprOp, Func, VARIABLES};
use std::collections::{BTreeSet, HashMap};

/// How `angle` reads plain numbers.
#[derive(Clone, Copy)]
enum AngleMode {
    Degrees,
    Radians,
    Orbits,
}

struct Lower<'a> {
    ex: &'a Expanded,
    sym: &'a Symbols,
    sources: &'a Sources,
    strings: Vec<String>,
    string_ids: HashMap<String, u32>,
    transforms: Vec<Transform>,
    const_ids: HashMap<Vec<u32>, u32>,
    exprs: Vec<Vec<ExprOp>>,
    rule_ids: HashMap<String, u32>,
    namespaces: Vec<String>,
    code: Vec<Op>,
    source_map: Vec<SourceLoc>,
    angle: AngleMode,
    diags: Vec<Diagnostic>,
    /// The parameters and locals in scope in the definition being lowered.
    scope: Scope,
    /// The next free slot of the definition being lowered, and the most any
    /// definition of the rule needs.
    next_slot: u16,
    frame: u16,
    /// `INST` ops emitted so far (the next prototype's ordinal).
    n_protos: u32,
    /// The item indices of the recursive user functions.
    recursive: BTreeSet<usize>,
    /// The definition being lowered is a flat path (see [`crate::paths`]).
    in_path: bool,
}

/// Lowers a checked program. Diagnostics here are run-time-relevant problems the
/// checker cannot see (none for a clean program).
pub fn lower(ex: &Expanded, sym: &Symbols, sources: &Sources) -> Result<Bundle, Vec<Diagnostic>> {
    // The checker checked this program without its vectors ([`crate::vectors`]).
    let scalar = crate::vectors::scalarize(ex);
    let ex = scalar.as_ref().map_or(ex, |(s, _)| s);
    let mut l = Lower {
        ex,
        sym,
        sources,
        strings: Vec::new(),
        string_ids: HashMap::new(),
        transforms: Vec::new(),
        const_ids: HashMap::new(),
        exprs: Vec::new(),
        rule_ids: HashMap::new(),
        namespaces: vec![String::new()],
        code: Vec::new(),
        source_map: Vec::new(),
        angle: AngleMode::Degrees,
        diags: Vec::new(),
        in_path: false,
        scope: Vec::new(),
        next_slot: 0,
        frame: 0,
        n_protos: 0,
        recursive: crate::functions::CallGraph::new(ex).recursive(),
    };
    let b = l.run();
    if l.diags.iter().any(|d| d.is_error()) {
        Err(l.diags)
    } else {
        Ok(b)
    }
}

/// Radians per unit of a plain angle number, or of one with a unit suffix.
fn angle_factor(angle: AngleMode, unit: Option<char>) -> f64 {
    match unit {
        Some('d') => std::f64::consts::PI / 180.0,
        Some('r') => 1.0,
        Some('o') => std::f64::consts::TAU,
        _ => match angle {
            AngleMode::Degrees => std::f64::consts::PI / 180.0,
            AngleMode::Radians => 1.0,
            AngleMode::Orbits => std::f64::consts::TAU,
        },
    }
}

/// The slots of the parameters and locals in scope, innermost last.
type Scope = Vec<(String, u16)>;

/// The geometric expression language: parameters and locals by slot, variables by
/// index, constants folded from `@param`/`@define`, numbers with units in radians,
/// calls of user functions inlined, or of recursive ones compiled once into the
/// expression's function block (`crate::functions`).
struct Geometric<'a> {
    ex: &'a Expanded,
    angle: AngleMode,
    scope: &'a [(String, u16)],
    /// The item indices of the recursive functions.
    recursive: &'a BTreeSet<usize>,
    /// The rule's scope while a recursive function's body is emitted (which reads
    /// only its parameters and the names every expression reads).
    outer: Option<&'a [(String, u16)]>,
}

impl Leaves<ExprOp> for Geometric<'_> {
    fn num(&mut self, n: &Number, out: &mut Vec<ExprOp>) -> bool {
        out.push(ExprOp::Push(match n.unit {
            Some('t') => n.value.atan(),
            Some(u) => n.value * angle_factor(self.angle, Some(u)),
            None => n.value,
        }));
        true
    }

    fn var(&mut self, v: &Name, out: &mut Vec<ExprOp>) -> bool {
        if let Some((_, slot)) = self.scope.iter().rev().find(|(n, _)| *n == v.text) {
            out.push(ExprOp::Slot(*slot));
        } else if let Some(i) = VARIABLES.iter().position(|x| *x == v.text) {
            out.push(ExprOp::Var(i as u8));
        } else {
            out.push(ExprOp::Push(self.ex.constant(&v.text).unwrap_or(0.0)));
        }
        true
    }

    fn call(&mut self, _: &Expr, f: &Name, args: &[Expr], out: &mut Vec<ExprOp>) -> Call {
        if let Some(func) = Func::from_name(&f.text) {
            return Call::Builtin(func);
        }
        match self.ex.user_function(&f.text) {
            Some((i, _, params, body)) if self.recursive.contains(&i) => {
                Call::Compiled { key: i, params: params.to_vec(), body: body.clone() }
            }
            // Inlined: a function that is not recursive calls a finite tree of others.
            Some((_, _, params, body)) => Call::Inline(inline_call(params, body, args)),
            // The checker reports unknown functions before lowering.
            None => {
                out.push(ExprOp::Push(0.0));
                Call::Done(false)
            }
        }
    }

    fn in_function(&mut self, inside: bool) {
        if inside {
            self.outer = Some(std::mem::take(&mut self.scope));
        } else if let Some(s) = self.outer.take() {
            self.scope = s;
        }
    }
}

/// Compiles an expression to expression code in the [`Geometric`] language.
fn expr_code(
    ex: &Expanded,
    recursive: &BTreeSet<usize>,
    angle: AngleMode,
    scope: &[(String, u16)],
    e: &Expr,
    out: &mut Vec<ExprOp>,
) {
    consteval::lower(&mut Geometric { ex, angle, scope, recursive, outer: None }, e, out);
}

/// The body of a function with parameters, each parameter replaced by its argument
/// (in parentheses), with the operations on plain numbers it then has folded (with
/// the VM's arithmetic, as `consteval` does), so a helper called with constants
/// costs no more than the formula written out.
pub(crate) fn inline_call(params: &[crate::ast::Name], body: &Expr, args: &[Expr]) -> Expr {
    let e = substitute(params, body, args);
    fold(e)
}

/// `body` with each name of `params` replaced by its argument (the last of a name
/// wins). A `let(…)` name of the body is renamed `NAME#OFFSET` (its source offset;
/// no one can write `#` in a name), so an argument that reads a caller's `let` of the
/// same name is not captured.
fn substitute(params: &[crate::ast::Name], body: &Expr, args: &[Expr]) -> Expr {
    let rec = |e: &Expr| Box::new(substitute(params, e, args));
    let kind = match &body.kind {
        ExprKind::Let(bindings, inner) => {
            let (mut ps, mut xs) = (params.to_vec(), args.to_vec());
            xs.resize(ps.len(), Expr { kind: ExprKind::Error, span: body.span });
            let mut renamed = Vec::new();
            for (n, v) in bindings {
                let v = substitute(&ps, v, &xs);
                let to = crate::ast::Name { text: format!("{}#{}", n.text, n.span.start), span: n.span };
                ps.push(n.clone());
                xs.push(Expr { kind: ExprKind::Var(to.clone()), span: n.span });
                renamed.push((to, v));
            }
            ExprKind::Let(renamed, Box::new(substitute(&ps, inner, &xs)))
        }
        ExprKind::Var(v) => match params.iter().rposition(|p| p.text == v.text) {
            Some(i) => match args.get(i) {
                Some(a) => ExprKind::Paren(Box::new(a.clone())),
                None => ExprKind::Error,
            },
            None => ExprKind::Var(v.clone()),
        },
        ExprKind::Neg(x) => ExprKind::Neg(rec(x)),
        ExprKind::Not(x) => ExprKind::Not(rec(x)),
        ExprKind::Paren(x) => ExprKind::Paren(rec(x)),
        ExprKind::Binary(op, a, b) => ExprKind::Binary(*op, rec(a), rec(b)),
        ExprKind::Call(f, xs) => ExprKind::Call(f.clone(), xs.iter().map(|x| substitute(params, x, args)).collect()),
        ExprKind::Tuple(xs) => ExprKind::Tuple(xs.iter().map(|x| substitute(params, x, args)).collect()),
        ExprKind::Index(v, i) => ExprKind::Index(rec(v), rec(i)),
        k @ (ExprKind::Num(_) | ExprKind::Error) => k.clone(),
    };
    Expr { kind, span: body.span }
}

/// Folds operations whose operands are numbers without a unit, bottom up.
fn fold(e: Expr) -> Expr {
    let plain = |e: &Expr| match &e.kind {
        ExprKind::Num(n) if n.unit.is_none() => Some(n.value),
        _ => None,
    };
    let num = |value: f64, span: Span| Expr {
        kind: ExprKind::Num(crate::ast::Number { value, unit: None, text: format!("{value}"), span }),
        span,
    };
    let span = e.span;
    match e.kind {
        ExprKind::Paren(x) => {
            let x = fold(*x);
            match plain(&x) {
                Some(v) => num(v, span),
                None => Expr { kind: ExprKind::Paren(Box::new(x)), span },
            }
        }
        ExprKind::Neg(x) => {
            let x = fold(*x);
            match plain(&x) {
                Some(v) => num(-v, span),
                None => Expr { kind: ExprKind::Neg(Box::new(x)), span },
            }
        }
        ExprKind::Not(x) => Expr { kind: ExprKind::Not(Box::new(fold(*x))), span },
        ExprKind::Let(bindings, body) => Expr {
            kind: ExprKind::Let(bindings.into_iter().map(|(n, v)| (n, fold(v))).collect(), Box::new(fold(*body))),
            span,
        },
        ExprKind::Binary(op, a, b) => {
            let (a, b) = (fold(*a), fold(*b));
            match (plain(&a), plain(&b)) {
                (Some(u), Some(v)) => num(vm_binop(op).apply(u, v), span),
                // x - 0, x + 0, x * 1 and x / 1 are x.
                (None, Some(v))
                    if (v == 0.0 && matches!(op, BinOp::Add | BinOp::Sub))
                        || (v == 1.0 && matches!(op, BinOp::Mul | BinOp::Div)) =>
                {
                    a
                }
                _ => Expr { kind: ExprKind::Binary(op, Box::new(a), Box::new(b)), span },
            }
        }
        ExprKind::Call(f, xs) => {
            let xs: Vec<Expr> = xs.into_iter().map(fold).collect();
            let values: Option<Vec<f64>> = xs.iter().map(plain).collect();
            let random = matches!(f.text.as_str(), "rand" | "randn");
            match values.filter(|_| !random).and_then(|v| mdg_vm::expr::call(&f.text, &v)) {
                Some(v) => num(v, span),
                None => Expr { kind: ExprKind::Call(f, xs), span },
            }
        }
        kind => Expr { kind, span },
    }
}

/// The VM's index of a math function.
fn function_index(name: &str) -> u8 {
    Func::from_name(name).map_or(0, |f| f as u8)
}

fn key(c: &Composite) -> Vec<u32> {
    c.q.iter()
        .chain(&c.qh)
        .chain(&c.u)
        .chain(&c.color)
        .chain(&c.weight)
        .chain(std::iter::once(&c.fps))
        .map(|f| f.to_bits())
        // (A tag before each optional part keeps the keys of different shapes apart.)
        .chain(std::iter::once(u32::from(c.n.is_some())))
        .chain(c.n.iter().flatten().map(|f| f.to_bits()))
        .chain(std::iter::once(u32::from(c.hsb.is_some())))
        .chain(c.hsb.iter().flatten().map(|f| f.to_bits()))
        .chain(std::iter::once(u32::from(c.set.is_some())))
        .chain(c.set.iter().flatten().map(|f| f.to_bits()))
        .collect()
}

impl<'a> Lower<'a> {
    fn string(&mut self, s: &str) -> u32 {
        if let Some(i) = self.string_ids.get(s) {
            return *i;
        }
        let i = self.strings.len() as u32;
        self.strings.push(s.to_string());
        self.string_ids.insert(s.to_string(), i);
        i
    }

    fn constant(&mut self, c: Composite) -> u32 {
        let k = key(&c);
        if let Some(i) = self.const_ids.get(&k) {
            return *i;
        }
        let i = self.transforms.len() as u32;
        self.transforms.push(Transform::Const(c));
        self.const_ids.insert(k, i);
        i
    }

    fn namespace(&mut self, ns: &str) -> u32 {
        if let Some(i) = self.namespaces.iter().position(|n| n == ns) {
            return i as u32;
        }
        self.namespaces.push(ns.to_string());
        self.namespaces.len() as u32 - 1
    }

    /// The colour value of `background #rrggbb` (the last `background`), if it is one.
    fn background_colour(&self) -> Option<[f32; 4]> {
        self.ex.items.iter().rev().find_map(|ExpItem { item, .. }| match &item.kind {
            ItemKind::Directive { name, args } if name.text == "background" => match args.as_slice() {
                [DirArg::Word(w)] => crate::colour::parse(&w.text).ok(),
                _ => None,
            },
            _ => None,
        })
    }

    fn directive_numbers(&self, name: &str) -> Option<Vec<f64>> {
        self.ex.items.iter().rev().find_map(|ExpItem { item, .. }| match &item.kind {
            ItemKind::Directive { name: n, args } if n.text == name => Some(
                args.iter()
                    .filter_map(|a| match a {
                        DirArg::Num(n) => Some(n.value),
                        DirArg::Neg(n) => Some(-n.value),
                        DirArg::Expr(e) => consteval::eval(e, &|v| self.ex.constant(v)),
                        DirArg::Word(_) => None,
                    })
                    .collect(),
            ),
            _ => None,
        })
    }

    fn run(&mut self) -> Bundle {
        self.angle = match self.ex.items.iter().find_map(|ExpItem { item, .. }| match &item.kind {
            ItemKind::Directive { name, args } if name.text == "angle" => match args.first() {
                Some(DirArg::Word(w)) => Some(w.text.clone()),
                _ => None,
            },
            _ => None,
        }) {
            Some(m) if m == "radians" => AngleMode::Radians,
            Some(m) if m == "orbits" || m == "frequency" => AngleMode::Orbits,
            _ => AngleMode::Degrees,
        };
        self.constant(Composite::IDENTITY);
        // Rule indices in name order (BTreeMap), so bundles are deterministic.
        for (i, name) in self.sym.rules.keys().enumerate() {
            self.rule_ids.insert(name.clone(), i as u32);
        }
        let mut rules = Vec::new();
        for (name, defs) in &self.sym.rules {
            let name_id = self.string(name);
            let mut out_defs = Vec::new();
            let mut transforms = Vec::new();
            let mut iter = NONE;
            let sig = self.sym.signatures.get(name).cloned().unwrap_or_default();
            self.frame = sig.params.len() as u16;
            for def in defs {
                let ExpItem { item, namespace } = &self.ex.items[def.item];
                let ItemKind::Rule(r) = &item.kind else { continue };
                let start = self.code.len() as u32;
                self.mark(r.name.span);
                // Parameters take the first slots, by position (the names of this
                // definition's list).
                self.scope = r
                    .params
                    .iter()
                    .flat_map(|p| &p.params)
                    .enumerate()
                    .map(|(i, p)| (p.name.text.clone(), i as u16))
                    .collect();
                self.next_slot = sig.params.len() as u16;
                // A weight over the parameters is evaluated per call, in the callee's frame.
                let weight_expr = r.weight_expr.as_ref().map_or(NONE, |e| self.expr(e, 1.0));
                self.in_path = crate::paths::is_path(&r.body);
                self.body(&r.body, namespace.as_deref());
                if self.in_path && !crate::paths::paints(&r.body) {
                    // Context Free fills a path that paints nothing itself.
                    let id = AdjList { square: false, adjs: Vec::new(), span: r.body_span };
                    let xf = TransformId(self.transform(&id, 1.0));
                    let e = self.push_expr(vec![ExprOp::Push(f64::from(mdg_vm::bundle::ops::path_bits::IMPLIED))]);
                    self.code.push(Op::Arg { expr: ExprId(e) });
                    let ns = NsId(0);
                    self.code.push(Op::Draw { kind: Drawable::Fill, xf, ns, profile: Profile(NONE), flags: 0 });
                }
                self.in_path = false;
                self.code.push(Op::Ret {});
                self.insert_prototypes(start as usize);
                let w =
                    r.weight.as_ref().map(|w| if w.negative { -w.number.value } else { w.number.value }).unwrap_or(1.0);
                let (retire_depth, retire_to) = match &r.retire {
                    Some(t) => (
                        t.depth.value.clamp(0.0, u32::MAX as f64) as u32,
                        t.other.as_ref().and_then(|o| self.rule_index(&o.text, namespace.as_deref())).unwrap_or(NONE),
                    ),
                    None => (0, NONE),
                };
                out_defs.push(Def { weight: w as f32, weight_expr, start, retire_depth, retire_to });
                if transforms.is_empty() {
                    transforms =
                        r.transforms.iter().filter_map(|t| self.rule_index(&t.text, namespace.as_deref())).collect();
                }
                if iter == NONE {
                    iter = r.iter.as_ref().and_then(|t| self.rule_index(&t.text, namespace.as_deref())).unwrap_or(NONE);
                }
            }
            // A selector reads the call's arguments by the first definition's names.
            self.scope = sig.params.iter().enumerate().map(|(i, p)| (p.name.clone(), i as u16)).collect();
            let selector = match self.sym.selectors.get(name).map(|(m, _)| m.clone()) {
                None => Selector::Random,
                Some(SelectorMode::Word(w)) => match w.text.as_str() {
                    "depth" => Selector::Depth,
                    "scale" => Selector::Scale,
                    "sequential" => Selector::Sequential,
                    "pattern" => Selector::Pattern,
                    _ => Selector::Random,
                },
                Some(SelectorMode::FunctionBody(e)) => Selector::Function(self.expr(&e, 1.0)),
                Some(SelectorMode::FunctionRef(f)) => {
                    let body = self.function_body(&f.text);
                    match body {
                        Some(e) => Selector::Function(self.expr(&e, 1.0)),
                        None => Selector::Random,
                    }
                }
            };
            self.scope.clear();
            let params = sig.params.iter().map(|p| p.default).collect();
            rules.push(bundle::Rule {
                name: name_id,
                selector,
                defs: out_defs,
                transforms,
                iter,
                params,
                frame: self.frame,
            });
        }
        let mut isosurfaces = Vec::new();
        for ExpItem { item, .. } in &self.ex.items {
            if let ItemKind::Isosurface { name, entries } = &item.kind {
                if let Some(iso) = self.isosurface(name, entries) {
                    isosurfaces.push(iso);
                }
            }
        }
        let start = self.sym.startshape.as_ref().and_then(|(s, _)| self.rule_ids.get(s).copied()).unwrap_or(0);
        let rule_of = |me: &Self, f: fn(&ItemKind) -> Option<&Name>| -> u32 {
            me.ex
                .items
                .iter()
                .find_map(|ExpItem { item, namespace }| {
                    f(&item.kind).and_then(|n| me.rule_index(&n.text, namespace.as_deref()))
                })
                .unwrap_or(NONE)
        };
        let linerule = rule_of(self, |k| if let ItemKind::Linerule(n) = k { Some(n) } else { None });
        let camerarule = rule_of(self, |k| if let ItemKind::Camerarule(n) = k { Some(n) } else { None });
        let num = |me: &Self, n: &str, d: f64| me.directive_numbers(n).and_then(|v| v.first().copied()).unwrap_or(d);
        let normal = self
            .directive_numbers("normal")
            .filter(|v| v.len() == 3)
            .map(|v| [v[0] as f32, v[1] as f32, v[2] as f32])
            .unwrap_or([0.0, 0.0, 1.0]);
        // `flat`: Context Free's flat art, on Context Free's white unless `background` says.
        let flat = self.directive_numbers("flat").is_some();
        let background = match self.directive_numbers("background") {
            // `background #rrggbb`: the colour value (no numbers).
            Some(v) if v.is_empty() => {
                self.background_colour().unwrap_or(if flat { [1.0; 4] } else { [0.12, 0.12, 0.14, 1.0] })
            }
            Some(v) if v.len() >= 3 => [v[0] as f32, v[1] as f32, v[2] as f32, v.get(3).copied().unwrap_or(1.0) as f32],
            _ if flat => [1.0, 1.0, 1.0, 1.0],
            _ => [0.12, 0.12, 0.14, 1.0],
        };
        let mut shaders = Vec::new();
        for sh in &self.ex.shaders {
            let name = self.string(&sh.name.text);
            let source = self.string(&sh.code);
            // SPIR-V is attached by the driver from the shader stage (`crate::shaders`),
            // which compiled these same blocks in this order.
            shaders.push(bundle::Shader { vertex: sh.vertex, name, source, spirv: Vec::new() });
        }
        let program = self.program();
        let uniforms = self.uniforms();
        let mut params = Vec::new();
        for p in &self.ex.params {
            let name = self.string(&p.name.text);
            let ty = match p.ty.as_str() {
                "int" => 0,
                "float" => 1,
                _ => 2,
            };
            params.push(bundle::Param {
                name,
                ty,
                value: p.value,
                min: p.min.unwrap_or(0.0),
                max: p.max.unwrap_or(0.0),
            });
        }
        let mut extensions = bundle::Extensions::default();
        let (ex, angle, recursive) = (self.ex, self.angle, &self.recursive);
        let cx = LowerCx {
            ex,
            sym: self.sym,
            rule_ids: &self.rule_ids,
            expr_code: &|e: &Expr| {
                let mut out = Vec::new();
                expr_code(ex, recursive, angle, &[], e, &mut out);
                out
            },
            angle_factor: angle_factor(angle, None),
        };
        crate::ext::lower(&cx, &mut extensions);
        let namespaces: Vec<String> = self.namespaces.clone();
        let namespace_ids = namespaces.iter().map(|n| self.string(n)).collect();
        let settings = Settings {
            startshape: start,
            maxdepth: num(self, "maxdepth", 0.0) as u32,
            minsize: num(self, "minsize", 0.0) as f32,
            maxiter: num(self, "maxiter", 0.0) as u64,
            stacksize: num(self, "stacksize", 0.0) as u32,
            randseed: num(self, "randseed", 0.0) as u64,
            normal,
            background,
            fps: num(self, "fps", 30.0) as f32,
            duration: num(self, "duration", 10.0) as f32,
            camerafov: num(self, "camerafov", 40.0) as f32,
            near: num(self, "cameranearplane", 0.1) as f32,
            far: num(self, "camerafarplane", 1000.0) as f32,
            linerule,
            camerarule,
            namespaces: namespace_ids,
            flat,
            breadth: self.directive_numbers("breadthfirst").is_some(),
            maxobjects: num(self, "maxobjects", 0.0) as u64,
        };
        Bundle {
            strings: std::mem::take(&mut self.strings),
            settings,
            transforms: std::mem::take(&mut self.transforms),
            exprs: std::mem::take(&mut self.exprs),
            rules,
            code: std::mem::take(&mut self.code),
            isosurfaces,
            shaders,
            program,
            uniforms,
            params,
            source_map: std::mem::take(&mut self.source_map),
            extensions,
        }
    }

    /// The last `program` directive: shader names resolved to indices into the
    /// bundle's shader list (first block of that stage and name, as the checker
    /// resolves it); a stage not named is [`NONE`].
    fn program(&self) -> Option<bundle::Program> {
        let words = self.ex.items.iter().rev().find_map(|ExpItem { item, .. }| match &item.kind {
            ItemKind::Program { words } => Some(words),
            _ => None,
        })?;
        let mut p = bundle::Program { vertex: NONE, fragment: NONE };
        for pair in words.windows(2) {
            let vertex = match pair[0].text.as_str() {
                "vertexshader" => true,
                "fragmentshader" => false,
                _ => continue,
            };
            let idx = self.ex.shaders.iter().position(|sh| sh.vertex == vertex && sh.name.text == pair[1].text);
            let idx = idx.map(|i| i as u32).unwrap_or(NONE);
            if vertex {
                p.vertex = idx;
            } else {
                p.fragment = idx;
            }
        }
        Some(p)
    }

    /// `uniform` directives in source order (thesis §4.1.1, reference §13).
    fn uniforms(&mut self) -> Vec<bundle::Uniform> {
        let ex = self.ex;
        let mut out = Vec::new();
        for ExpItem { item, namespace } in &ex.items {
            let ItemKind::Directive { name, args } = &item.kind else { continue };
            if name.text != "uniform" {
                continue;
            }
            let Some(DirArg::Word(uname)) = args.first() else { continue };
            let rest = &args[1..];
            let source = if let [DirArg::Word(rule), DirArg::Word(prop)] = rest {
                let Some(rule) = self.rule_index(&rule.text, namespace.as_deref()) else { continue };
                let Some(prop) = bundle::UNIFORM_PROPS.iter().position(|p| *p == prop.text) else { continue };
                bundle::UniformSource::Frame { rule, prop: prop as u8 }
            } else {
                let mut v = [0.0f32; 4];
                for (slot, a) in v.iter_mut().zip(rest) {
                    *slot = match a {
                        DirArg::Num(n) => n.value as f32,
                        DirArg::Neg(n) => -n.value as f32,
                        DirArg::Expr(e) => consteval::eval(e, &|c| ex.constant(c)).unwrap_or(0.0) as f32,
                        DirArg::Word(_) => 0.0,
                    };
                }
                bundle::UniformSource::Const(v)
            };
            let name = self.string(&uname.text);
            out.push(bundle::Uniform { name, source });
        }
        out
    }

    fn function_body(&self, name: &str) -> Option<Expr> {
        self.ex.items.iter().find_map(|ExpItem { item, namespace }| match &item.kind {
            ItemKind::Function { name: n, body, .. } => {
                let full = match namespace {
                    Some(ns) => format!("{ns}.{}", n.text),
                    None => n.text.clone(),
                };
                (full == name || n.text == name).then(|| body.clone())
            }
            _ => None,
        })
    }

    /// Whether one of the definitions of rule `full` (a resolved name) is a path.
    fn defines_path(&self, full: &str) -> bool {
        self.sym.rules.get(full).is_some_and(|defs| {
            defs.iter().any(|d| {
                matches!(self.ex.items.get(d.item).map(|i| &i.item.kind),
                    Some(ItemKind::Rule(r)) if crate::paths::is_path(&r.body))
            })
        })
    }

    /// A flat primitive's outline added to the path (see
    /// [`crate::paths::primitive_outline`]): its first op under `xf`, the others
    /// continuing from it, so the whole outline is under one frame.
    fn outline(&mut self, ops: &[crate::paths::OutlineOp], xf: TransformId, span: Span) {
        let id = AdjList { square: false, adjs: Vec::new(), span };
        let same = TransformId(self.transform(&id, 1.0));
        for (i, (name, vals)) in ops.iter().enumerate() {
            let Some(kind) = Drawable::from_name(name) else { continue };
            if i > 0 {
                self.code.push(Op::Cont {});
            }
            let n = mdg_vm::bundle::ops::path_arity(kind, PATH_OP).unwrap_or(1) - 1;
            for k in 0..n {
                let e = self.push_expr(vec![ExprOp::Push(vals.get(k).copied().unwrap_or(0.0))]);
                self.code.push(Op::Arg { expr: ExprId(e) });
            }
            let e = self.push_expr(vec![ExprOp::Push(0.0)]);
            self.code.push(Op::Arg { expr: ExprId(e) });
            let flags = if matches!(kind, Drawable::MoveTo | Drawable::LineTo) { PATH_OP } else { 0 };
            let xf = if i == 0 { xf } else { same };
            self.code.push(Op::Draw { kind, xf, ns: NsId(0), profile: Profile(NONE), flags });
        }
    }

    fn rule_index(&self, name: &str, ns: Option<&str>) -> Option<u32> {
        self.sym.resolve(name, ns).and_then(|f| self.rule_ids.get(&f).copied())
    }

    fn mark(&mut self, span: Span) {
        let file = self.sources.file(span.file);
        let line = file.line_col(span.start).0 + 1;
        // Absolute paths are reduced to the file name, so a bundle does not depend on
        // where its source was checked out (determinism across machines).
        let name = if std::path::Path::new(&file.name).is_absolute() {
            std::path::Path::new(&file.name).file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
        } else {
            file.name.clone()
        };
        let file_id = self.string(&name);
        let op = self.code.len() as u32;
        if let Some(last) = self.source_map.last_mut() {
            if last.op == op {
                *last = SourceLoc { op, file: file_id, line };
                return;
            }
        }
        self.source_map.push(SourceLoc { op, file: file_id, line });
    }

    fn body(&mut self, items: &[BodyItem], ns: Option<&str>) {
        // `let` bindings are visible to the items after them in this block.
        let scope_at = self.scope.len();
        for item in items {
            self.item(item, item.cont, ns);
            if item.cont {
                self.code.push(Op::Cont {});
            }
        }
        self.scope.truncate(scope_at);
    }

    /// Puts an `INST` op before every prototype run of the definition that starts at
    /// op `start` and ends the code (see `mdg_vm::bundle::proto`): the longest runs of
    /// whole triangles of `VERTEX`/`FACENORMALS` items with constant transforms, not
    /// right after a continuation (whose first item starts from another frame). Jump
    /// targets, loop ends and the source map move with the ops; a jump to a run's
    /// first item lands on its `INST`.
    fn insert_prototypes(&mut self, start: usize) {
        let mut runs: Vec<(usize, usize)> = Vec::new();
        let mut pc = start;
        while pc < self.code.len() {
            let after_cont = pc > start && matches!(self.code[pc - 1], Op::Cont {});
            let len = if after_cont { 0 } else { proto::run_length(&self.code[pc..], &self.transforms) };
            if len > 0 {
                runs.push((pc, len));
                pc += len;
            } else {
                pc += 1;
            }
        }
        if runs.is_empty() {
            return;
        }
        // Old op i moves past the INSTs of the runs that start before it.
        let moved = |i: u32| i + runs.partition_point(|r| (r.0 as u32) < i) as u32;
        let moved_op = |i: OpIndex| OpIndex(moved(i.0));
        let tail: Vec<Op> = self.code.drain(start..).collect();
        let mut next_run = runs.iter().peekable();
        for (k, mut op) in tail.into_iter().enumerate() {
            if let Some(&&(first, count)) = next_run.peek() {
                if first == start + k {
                    self.code.push(Op::Inst { proto: ProtoId(self.n_protos), count: OpCount(count as u32) });
                    self.n_protos += 1;
                    next_run.next();
                }
            }
            match &mut op {
                Op::Loop { end, .. } | Op::LoopN { end, .. } => *end = moved_op(*end),
                Op::EndLoop { begin } => *begin = moved_op(*begin),
                Op::Jump { target } | Op::JumpIfNot { target, .. } => *target = moved_op(*target),
                _ => {}
            }
            self.code.push(op);
        }
        // The map is in op order (entries are pushed as ops are), so this rule's
        // entries are its tail: moving only those keeps lowering linear in the
        // number of rules (every entry used to be visited for every rule).
        let first = self.source_map.partition_point(|loc| (loc.op as usize) < start);
        for loc in &mut self.source_map[first..] {
            loc.op = moved(loc.op);
        }
    }

    /// A flat path's drawable: its arguments, every one passed (defaults filled in,
    /// the option bits last), then the `DRAW`.
    fn path_draw(
        &mut self,
        kind: Drawable,
        name: &str,
        args: Option<&CallArgs>,
        word: Option<&Name>,
        xf: TransformId,
        flags: u8,
    ) {
        let bits = word.and_then(|w| crate::paths::option_bits(name, &w.text).ok()).unwrap_or(0);
        let given = args.map(|a| a.args.as_slice()).unwrap_or(&[]);
        let n = mdg_vm::bundle::ops::path_arity(kind, PATH_OP).unwrap_or(1) - 1;
        let (vals, bits) = crate::paths::vm_args(name, given, bits).unwrap_or((vec![None; n], f64::from(bits)));
        for v in vals {
            let expr = match v {
                Some(a) => match self.const_eval(a) {
                    Some(c) => self.push_expr(vec![ExprOp::Push(c)]),
                    None => self.expr(a, 1.0),
                },
                None if kind == Drawable::Stroke => {
                    self.push_expr(vec![ExprOp::Push(crate::paths::DEFAULT_STROKE_WIDTH)])
                }
                None => self.push_expr(vec![ExprOp::Push(0.0)]),
            };
            self.code.push(Op::Arg { expr: ExprId(expr) });
        }
        let e = self.push_expr(vec![ExprOp::Push(bits)]);
        self.code.push(Op::Arg { expr: ExprId(e) });
        let flags = if matches!(kind, Drawable::MoveTo | Drawable::LineTo) { flags | PATH_OP } else { flags };
        self.code.push(Op::Draw { kind, xf, ns: NsId(0), profile: Profile(NONE), flags });
    }

    /// A new slot for a binding named `name`, in scope from now on.
    fn bind(&mut self, name: &str) -> u16 {
        let slot = self.next_slot;
        self.next_slot = self.next_slot.saturating_add(1);
        self.frame = self.frame.max(self.next_slot);
        self.scope.push((name.to_string(), slot));
        slot
    }

    /// Points the jump at op `at` to the next op.
    fn patch_jump(&mut self, at: usize) {
        let here = OpIndex(self.code.len() as u32);
        match &mut self.code[at] {
            Op::Jump { target } | Op::JumpIfNot { target, .. } => *target = here,
            _ => {}
        }
    }

    /// Emits a LOOP (constant count) or LOOPN (count expression `dynamic`) around
    /// `inner`; `after_run` emits ops at the end of each run (a loop variable's step).
    #[allow(clippy::too_many_arguments)]
    fn emit_loop(
        &mut self,
        count: u64,
        dynamic: Option<u32>,
        step: u32,
        chain: u8,
        inner: &BodyItem,
        cont_next: bool,
        ns: Option<&str>,
        after_run: Option<(u16, u32)>,
    ) {
        let begin = OpIndex(self.code.len() as u32);
        let (step, end) = (TransformId(step), OpIndex(0));
        match dynamic {
            Some(e) => self.code.push(Op::LoopN { count: ExprId(e), step, end, chain }),
            None => self.code.push(Op::Loop { count, step, end, chain }),
        }
        self.item(inner, cont_next, ns);
        if let Some((slot, expr)) = after_run {
            self.code.push(Op::Set { slot: SlotId(slot), expr: ExprId(expr) });
        }
        let end = OpIndex(self.code.len() as u32);
        self.code.push(Op::EndLoop { begin });
        if let Op::Loop { end: e, .. } | Op::LoopN { end: e, .. } = &mut self.code[begin.index()] {
            *e = end;
        }
    }

    fn item(&mut self, item: &BodyItem, cont_next: bool, ns: Option<&str>) {
        self.mark(item.span);
        let flags = if cont_next { CONT_NEXT } else { 0 };
        match &item.kind {
            BodyKind::Call { name, args, profile, adj } => {
                let xf = TransformId(self.transform(adj, 1.0));
                let (prefix, last) = match name.text.rsplit_once('.') {
                    Some((p, l)) => (p, l),
                    None => ("", name.text.as_str()),
                };
                if let Some(kind) = Drawable::from_name(crate::paths::canonical(last).0)
                    .filter(|_| self.sym.resolve(&name.text, ns).is_none() || prefix.is_empty())
                {
                    if prefix.is_empty() && crate::paths::is_path_op(last, self.in_path) {
                        self.path_draw(kind, last, args.as_ref(), profile.as_ref(), xf, flags);
                        return;
                    }
                    let ns_id = NsId(self.namespace(prefix));
                    let profile = Profile(profile.as_ref().and_then(|p| self.rule_index(&p.text, ns)).unwrap_or(NONE));
                    self.code.push(Op::Draw { kind, xf, ns: ns_id, profile, flags });
                } else if self.sym.isosurfaces.contains_key(&name.text) {
                    let iso =
                        self.ex.items.iter().filter(|i| matches!(i.item.kind, ItemKind::Isosurface { .. })).position(
                            |i| matches!(&i.item.kind, ItemKind::Isosurface { name: n, .. } if n.text == name.text),
                        );
                    if let Some(iso) = iso {
                        self.code.push(Op::Iso { iso: IsoId(iso as u32), xf, flags });
                    }
                } else if let Some(ops) = crate::paths::primitive_outline(&name.text).filter(|_| {
                    self.in_path && !self.sym.resolve(&name.text, ns).is_some_and(|f| self.defines_path(&f))
                }) {
                    // In a path, Context Free's `path CIRCLE [..]`: the outline.
                    self.outline(ops, xf, item.span);
                } else if let Some(rule) = self.rule_index(&name.text, ns) {
                    // Arguments by position; the parameters not passed take their defaults.
                    let full = self.sym.resolve(&name.text, ns).unwrap_or_default();
                    // A path's call of a path is a subpath (its points join this path).
                    let flags = if self.in_path && self.defines_path(&full) { flags | SUBPATH } else { flags };
                    let sig = self.sym.signatures.get(&full).cloned().unwrap_or_default();
                    let given = args.as_ref().map(|a| a.args.as_slice()).unwrap_or(&[]);
                    for (i, p) in sig.params.iter().enumerate() {
                        let expr = match given.get(i) {
                            Some(a) => match self.const_eval(a) {
                                Some(v) => self.push_expr(vec![ExprOp::Push(v)]),
                                None => self.expr(a, 1.0),
                            },
                            None => self.push_expr(vec![ExprOp::Push(p.default.unwrap_or(0.0))]),
                        };
                        self.code.push(Op::Arg { expr: ExprId(expr) });
                    }
                    // `seed N` (the last one, if several; the checker allows it only here).
                    let seed = adj
                        .adjs
                        .iter()
                        .rev()
                        .find(|a| self.sym.components.adj_kind(&a.name.text) == Some(AdjKind::Seed))
                        .and_then(|a| a.args.first());
                    if let Some(arg) = seed {
                        let expr = match self.arg_value(arg, false) {
                            Ok(v) => self.push_expr(vec![ExprOp::Push(v)]),
                            Err(e) => e,
                        };
                        self.code.push(Op::Seed { expr: ExprId(expr) });
                    }
                    self.code.push(Op::Call { rule: RuleId(rule), xf, flags });
                }
            }
            BodyKind::Iterate { count, divisor, adj, chain, item: inner } => {
                let dynamic = match count {
                    Count::Expr(e) if self.const_eval(e).is_none() => Some(self.expr(e, 1.0)),
                    _ => None,
                };
                let n = if dynamic.is_some() { 0 } else { self.count_value(count).max(0.0) as u64 };
                let div = divisor.as_ref().map(|d| self.count_value(d)).unwrap_or(1.0);
                let step = self.transform(adj, if div > 0.0 { div } else { 1.0 });
                // The runs chain (run k + 1 starts from run k's end state composed with
                // the step) for `M * {T} \ ITEM`, for a block whose last item ends with
                // `\` (`M * {T} { A {} \ }`), and for an iterator followed by `\`.
                let block_chains =
                    matches!(&inner.kind, BodyKind::Block(items) if items.last().is_some_and(|i| i.cont));
                let chains = *chain || block_chains || cont_next;
                self.emit_loop(n, dynamic, step, chains as u8, inner, cont_next, ns, None);
            }
            BodyKind::Loop { var, range, adj, item: inner } => {
                let LoopRange { start, end, step } = &**range;
                // slot := START; runs = ceil((END - slot) / STEP); after each run
                // slot := slot + STEP.
                let start_e = self.expr(start, 1.0);
                let scope_at = self.scope.len();
                let slot = self.bind(&var.text);
                self.code.push(Op::Set { slot: SlotId(slot), expr: ExprId(start_e) });
                let mut step_code = Vec::new();
                match step {
                    Some(s) => self.expr_code(s, &mut step_code),
                    None => step_code.push(ExprOp::Push(1.0)),
                }
                let mut count = Vec::new();
                self.expr_code(end, &mut count);
                count.extend([ExprOp::Slot(slot), ExprOp::Bin(VmBinOp::Sub)]);
                count.extend(step_code.iter().copied());
                count.extend([ExprOp::Bin(VmBinOp::Div), ExprOp::Call(function_index("ceil"))]);
                let count = self.push_expr(count);
                let mut next = vec![ExprOp::Slot(slot)];
                next.extend(step_code);
                next.push(ExprOp::Bin(VmBinOp::Add));
                let next = self.push_expr(next);
                let xf = self.transform(adj, 1.0);
                let block_chains =
                    matches!(&inner.kind, BodyKind::Block(items) if items.last().is_some_and(|i| i.cont));
                let flags = (block_chains || cont_next) as u8 | bundle::ops::LOOP_FIRST_PLAIN;
                self.emit_loop(0, Some(count), xf, flags, inner, cont_next, ns, Some((slot, next)));
                self.scope.truncate(scope_at);
            }
            BodyKind::If { cond, then, otherwise, .. } => {
                let c = self.expr(cond, 1.0);
                let jz = self.code.len();
                self.code.push(Op::JumpIfNot { expr: ExprId(c), target: OpIndex(0) });
                self.body(then, ns);
                match otherwise {
                    Some(o) => {
                        let jmp = self.code.len();
                        self.code.push(Op::Jump { target: OpIndex(0) });
                        self.patch_jump(jz);
                        match &o.kind {
                            BodyKind::Block(items) => self.body(items, ns),
                            _ => self.item(o, false, ns),
                        }
                        self.patch_jump(jmp);
                    }
                    None => self.patch_jump(jz),
                }
            }
            // Expansion replaces a `switch` by what it means; lower that here too.
            BodyKind::Switch(s) => self.item(&s.lowered, cont_next, ns),
            BodyKind::Let { name, value } => {
                let expr = self.expr(value, 1.0);
                let slot = self.bind(&name.text);
                self.code.push(Op::Set { slot: SlotId(slot), expr: ExprId(expr) });
            }
            BodyKind::Block(items) => {
                let begin = OpIndex(self.code.len() as u32);
                self.code.push(Op::Loop { count: 1, step: TransformId(0), end: OpIndex(0), chain: 0 });
                self.body(items, ns);
                let end = OpIndex(self.code.len() as u32);
                self.code.push(Op::EndLoop { begin });
                if let Op::Loop { end: e, .. } = &mut self.code[begin.index()] {
                    *e = end;
                }
                if cont_next {
                    // A block followed by `\`: the next item continues from its last drawable.
                }
            }
            BodyKind::Pre(_) | BodyKind::Error => {}
        }
    }

    fn count_value(&self, c: &Count) -> f64 {
        match c {
            Count::Num(n) => n.value,
            Count::Neg(n) => -n.value,
            Count::Expr(e) => self.const_eval(e).unwrap_or(0.0),
        }
    }

    /// The compile-time value of `e`, if it reads no parameter or local.
    fn const_eval(&self, e: &Expr) -> Option<f64> {
        let scope = &self.scope;
        consteval::eval(e, &|v| {
            if scope.iter().any(|(n, _)| n == v) {
                None
            } else {
                self.ex.constant(v)
            }
        })
    }

    fn push_expr(&mut self, code: Vec<ExprOp>) -> u32 {
        self.exprs.push(code);
        self.exprs.len() as u32 - 1
    }

    fn angle_factor(&self, unit: Option<char>) -> f64 {
        angle_factor(self.angle, unit)
    }

    /// An argument's value: `Ok(constant)` or `Err(expression)` for run-time draws.
    /// Angles come out in radians.
    fn arg_value(&mut self, a: &Arg, angle: bool) -> Result<f64, u32> {
        let n = match a {
            Arg::Num(n) => (n.value, n.unit),
            Arg::Neg(n) => (-n.value, n.unit),
            Arg::Expr(e) => match self.const_eval(e) {
                Some(v) => (v, None),
                None => {
                    let factor = if angle { self.angle_factor(None) } else { 1.0 };
                    return Err(self.expr(e, factor));
                }
            },
        };
        let (v, unit) = n;
        if angle {
            if unit == Some('t') {
                return Ok(v.atan());
            }
            return Ok(v * self.angle_factor(unit));
        }
        Ok(v)
    }

    /// Compiles an adjustment list, divided into `divisor` steps.
    fn transform(&mut self, adj: &AdjList, divisor: f64) -> u32 {
        let comps = &self.sym.components;
        let mut prims: Vec<PrimAdj> = Vec::new();
        let mut dynamic = false;
        for a in &adj.adjs {
            let Some(kind) = comps.adj_kind(&a.name.text) else { continue };
            if kind == AdjKind::Seed {
                // Not part of the transform: the call's `SEED` op (see `item`).
                continue;
            }
            let angle = kind.is_angle();
            let mut args = Vec::new();
            for arg in &a.args {
                match self.arg_value(arg, angle) {
                    // As at run time (`eval_transform`): a NaN or infinite argument
                    // is used as 0 (the checker warns, W0013), so the source and its
                    // bundle run alike.
                    Ok(v) => args.push(bundle::Arg::Const(if v.is_finite() { v as f32 } else { 0.0 })),
                    Err(e) => {
                        dynamic = true;
                        args.push(bundle::Arg::Expr(e));
                    }
                }
            }
            if kind == AdjKind::Paint {
                // A colour value: its RGBA as four constants (a malformed one is the
                // checker's error, E0410; here it paints nothing).
                if let Ok(rgba) = crate::colour::parse(&a.name.text) {
                    prims.push(PrimAdj { kind: AdjOp::Paint, axis: 0, args: rgba.map(bundle::Arg::Const).to_vec() });
                }
                continue;
            }
            let (k, axis) = match kind {
                AdjKind::Translate(ax) => (AdjOp::Translate, if ax == 0 && args.len() > 1 { 3 } else { ax }),
                AdjKind::Rotate(ax) => (AdjOp::Rotate, ax),
                AdjKind::Turn(ax, sign) => {
                    let v = match args.first() {
                        Some(bundle::Arg::Const(v)) => bundle::Arg::Const(*v * sign as f32),
                        Some(bundle::Arg::Expr(e)) => {
                            let mut code = self.exprs[*e as usize].clone();
                            code.extend([ExprOp::Push(sign as f64), ExprOp::Bin(VmBinOp::Mul)]);
                            self.exprs.push(code);
                            bundle::Arg::Expr(self.exprs.len() as u32 - 1)
                        }
                        None => bundle::Arg::Const(std::f32::consts::FRAC_PI_2 * sign as f32),
                    };
                    args = vec![v];
                    (AdjOp::Rotate, ax)
                }
                AdjKind::Scale => (AdjOp::Scale, 0),
                AdjKind::Flip(ax) => (AdjOp::Flip, ax),
                AdjKind::Color(i) => (AdjOp::Color, i),
                AdjKind::Weight(i) => (AdjOp::Weight, i),
                AdjKind::Fps => (AdjOp::Fps, 0),
                AdjKind::Hsb(i) => (AdjOp::Hsb, i),
                AdjKind::Skew => (AdjOp::Skew, 0),
                AdjKind::Paint | AdjKind::Seed => continue,
            };
            prims.push(PrimAdj { kind: k, axis, args });
        }
        if dynamic {
            let i = self.transforms.len() as u32;
            self.transforms.push(Transform::Dynamic { adjs: prims, divisor: divisor as f32 });
            return i;
        }
        let c = mdg_vm::eval::compose_prims(&prims, divisor as f32);
        self.constant(c)
    }

    /// Compiles an expression, multiplied by `factor` (for angle units).
    fn expr(&mut self, e: &Expr, factor: f64) -> u32 {
        let mut code = Vec::new();
        self.expr_code(e, &mut code);
        if factor != 1.0 {
            code.extend([ExprOp::Push(factor), ExprOp::Bin(VmBinOp::Mul)]);
        }
        self.exprs.push(code);
        self.exprs.len() as u32 - 1
    }

    fn expr_code(&self, e: &Expr, out: &mut Vec<ExprOp>) {
        expr_code(self.ex, &self.recursive, self.angle, &self.scope, e, out)
    }

    fn isosurface(&mut self, name: &Name, entries: &[IsoEntry]) -> Option<bundle::Isosurface> {
        let mut min = [-1.0f32; 3];
        let mut max = [1.0f32; 3];
        let mut res = [16u32; 3];
        let mut function = None;
        for e in entries {
            match e {
                IsoEntry::Axis { axis, args, .. } => {
                    let v: Vec<f64> = args
                        .iter()
                        .filter_map(|a| match a {
                            DirArg::Num(n) => Some(n.value),
                            DirArg::Neg(n) => Some(-n.value),
                            DirArg::Expr(e) => consteval::eval(e, &|v| self.ex.constant(v)),
                            DirArg::Word(_) => None,
                        })
                        .collect();
                    if v.len() != 3 {
                        continue;
                    }
                    let which: &[usize] = match axis.text.as_str() {
                        "x" => &[0],
                        "y" => &[1],
                        "z" => &[2],
                        _ => &[0, 1, 2],
                    };
                    for &w in which {
                        min[w] = v[0] as f32;
                        max[w] = v[1] as f32;
                        res[w] = v[2].max(1.0) as u32;
                    }
                }
                IsoEntry::FunctionBody(e) => function = Some(self.expr(e, 1.0)),
                IsoEntry::FunctionRef(f) => {
                    if let Some(body) = self.function_body(&f.text) {
                        function = Some(self.expr(&body, 1.0));
                    }
                }
            }
        }
        let name = self.string(&name.text);
        Some(bundle::Isosurface { name, min, max, res, function: function? })
    }
}
