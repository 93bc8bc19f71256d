//! The syntax tree of one MDG file, before preprocessing is resolved.
//!
//! Preprocessor constructs (`@import`, `@ifdef`, `@macro`, `@expand`, …) are nodes
//! here, so the formatter and the language server see the file as written; the
//! expander (`crate::expand`) resolves them into a flat program.

use crate::span::Span;

/// A name as written: `A`, `ns.A`, `VERTEX`.
#[derive(Clone, Debug, PartialEq)]
pub struct Name {
    pub text: String,
    pub span: Span,
}

/// A number literal with its unit suffix.
#[derive(Clone, Debug, PartialEq)]
pub struct Number {
    pub value: f64,
    /// `d` degrees, `r` radians, `o` orbits, `t` atan.
    pub unit: Option<char>,
    /// The text as written (the formatter prints it unchanged).
    pub text: String,
    pub span: Span,
}

/// A parsed file.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct File {
    pub items: Vec<Item>,
}

/// A top-level item (or an item inside `namespace { }`).
#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    pub kind: ItemKind,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ItemKind {
    Startshape(Name),
    /// Shared (`Arc`): a rule is most of a program, and the language server's next
    /// version of a document takes the rules an edit left alone from the previous
    /// one's parse, and the expander takes rules without preprocessor constructs
    /// from the parse, without copying them (issue 39).
    Rule(std::sync::Arc<Rule>),
    Selector {
        rules: Vec<Name>,
        mode: SelectorMode,
    },
    Linerule(Name),
    Camerarule(Name),
    Namespace {
        name: Name,
        items: Vec<Item>,
    },
    /// Any other directive: `maxdepth 10`, `angle radians`, `uniform lightPos 1 2 3`, …
    /// The checker validates the name and arguments.
    Directive {
        name: Name,
        args: Vec<DirArg>,
    },
    /// `function NAME { EXPR }`, or with parameters `function NAME(a, b) { EXPR }`:
    /// called like a math function, `NAME(1, 2)`, its body inlined with the
    /// parameters replaced by the arguments.
    Function {
        name: Name,
        params: Vec<Name>,
        /// The type word written before each parameter (`function f(vector2 c, n)`:
        /// `vector2`, none), index-aligned with `params`; a parameter without one is
        /// a number.
        types: Vec<Option<Name>>,
        body: Expr,
    },
    Isosurface {
        name: Name,
        entries: Vec<IsoEntry>,
    },
    /// `program { vertexshader VS fragmentshader FS target screen render }`: the words in order.
    Program {
        words: Vec<Name>,
    },
    /// A SPEC §11 extension section: `guide`, `search`, `creature`, `grid`.
    Section(Section),
    Pre(Pre<Item>),
    /// Something that did not parse; a diagnostic was reported.
    Error,
}

/// `KIND [NAME] { ENTRY… }` — one syntax for every §11 extension (guided search,
/// creatures, grid grammars). The parser only knows the shape; each extension's
/// module in `crate::ext` checks its keys and values.
#[derive(Clone, Debug, PartialEq)]
pub struct Section {
    /// `guide`, `search`, `creature` or `grid`.
    pub kind: Name,
    pub name: Option<Name>,
    pub entries: Vec<Entry>,
    /// The span of `{ … }`.
    pub body_span: Span,
}

/// `KEY VALUE… ;` or `KEY VALUE… { ENTRY… }`.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    pub key: Name,
    pub values: Vec<Value>,
    /// The nested entries of `KEY VALUE… { … }`, with the span of the braces.
    pub block: Option<(Vec<Entry>, Span)>,
    pub span: Span,
}

/// A value in a section entry.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Num(Number),
    Neg(Number),
    /// `( EXPR )` or `f(…)`.
    Expr(Expr),
    Word(Name),
    /// `"text"`: the text without quotes, and the span with them.
    Str(String, Span),
}

impl Value {
    /// The span of the value.
    pub fn span(&self) -> Span {
        match self {
            Value::Num(n) | Value::Neg(n) => n.span,
            Value::Expr(e) => e.span,
            Value::Word(w) => w.span,
            Value::Str(_, s) => *s,
        }
    }
}

/// A directive argument.
#[derive(Clone, Debug, PartialEq)]
pub enum DirArg {
    Num(Number),
    /// A negative number `-N` (kept apart so the formatter prints it as written).
    Neg(Number),
    Word(Name),
    Expr(Expr),
}

/// `rule NAME[(TYPE P [= DEFAULT], …)] [* ITER] [: XF]… [WEIGHT] { BODY }`.
#[derive(Clone, Debug, PartialEq)]
pub struct Rule {
    pub name: Name,
    /// The parameter list, when written with parentheses (`rule tree(int n)`).
    pub params: Option<Params>,
    pub iter: Option<Name>,
    pub transforms: Vec<Name>,
    /// `rule square += { … }`: the span of `+=`, written when this definition adds to
    /// a rule another file (std or an import) defines on purpose (else W0015).
    pub adds: Option<Span>,
    pub weight: Option<Weight>,
    /// `rule leaf(int n) (EXPR) { … }`: a weight computed per call from the arguments
    /// (only after a parameter list; then `weight` is `None`).
    pub weight_expr: Option<Expr>,
    /// `maxdepth N [> OTHER]` after the weight: rule-local retirement (reference §4).
    pub retire: Option<Box<Retire>>,
    pub body: Vec<BodyItem>,
    /// The span of `{ … }`.
    pub body_span: Span,
}

/// Rule-local retirement, `rule R maxdepth N > OTHER { … }` (Structure Synth's
/// `rule R md N > OTHER`): once N runs of this definition are on a call's path, a
/// further call that picks it runs OTHER instead (or nothing without `> OTHER`).
#[derive(Clone, Debug, PartialEq)]
pub struct Retire {
    /// The word before the count (the checker wants `maxdepth`).
    pub keyword: Name,
    pub depth: Number,
    pub other: Option<Name>,
    pub span: Span,
}

/// A rule's parameter list `( … )`.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    pub params: Vec<ParamDecl>,
    /// The span of `( … )` (with the name before it, for `rule tree(`: from `(`).
    pub span: Span,
}

/// One parameter: `int n`, `float len = 1`.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamDecl {
    /// `int`, `float` or `bool` (the checker rejects other words).
    pub ty: Name,
    pub name: Name,
    pub default: Option<Expr>,
    pub span: Span,
}

/// The arguments of a rule call `NAME(a, b) {ADJ}`.
#[derive(Clone, Debug, PartialEq)]
pub struct CallArgs {
    pub args: Vec<Expr>,
    /// The span of `( … )`.
    pub span: Span,
}

/// A rule weight, possibly negated (which the checker rejects).
#[derive(Clone, Debug, PartialEq)]
pub struct Weight {
    pub negative: bool,
    pub number: Number,
}

/// How a rule's definitions are chosen.
#[derive(Clone, Debug, PartialEq)]
pub enum SelectorMode {
    /// `random`, `frequency`, `depth`, `scale`, `sequential`, `pattern` (or an unknown word).
    Word(Name),
    /// `function F`.
    FunctionRef(Name),
    /// `function { EXPR }`.
    FunctionBody(Expr),
}

/// One entry of an isosurface declaration.
#[derive(Clone, Debug, PartialEq)]
pub enum IsoEntry {
    /// `x MIN MAX RES`, `y …`, `z …`, `xyz …` (or an unknown word).
    Axis {
        axis: Name,
        args: Vec<DirArg>,
        span: Span,
    },
    FunctionRef(Name),
    FunctionBody(Expr),
}

/// An item of a rule body.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyItem {
    pub kind: BodyKind,
    /// Whether the item is followed by `\` (continuation).
    pub cont: bool,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum BodyKind {
    /// `NAME {ADJ}`, `NAME(ARG, …) {ADJ}`, `DRAWABLE {ADJ}`, `ns.LINETO PROFILE {ADJ}`.
    Call {
        name: Name,
        args: Option<CallArgs>,
        profile: Option<Name>,
        adj: AdjList,
    },
    /// `if (COND) { BODY } [else { BODY } | else if …]`.
    If {
        cond: Expr,
        then: Vec<BodyItem>,
        /// The span of the `then` braces.
        then_span: Span,
        /// A `Block` (`else { … }`) or another `If` (`else if …`).
        otherwise: Option<Box<BodyItem>>,
    },
    /// `let NAME = EXPR;`: a local binding, visible to the items after it in its block.
    Let {
        name: Name,
        value: Expr,
    },
    /// `loop NAME = START, END [, STEP] {ADJ} ITEM`: ITEM runs once for each value of
    /// NAME from START while below END (above it for a negative STEP), STEP apart
    /// (default 1), each run under the adjustment applied once more (like `N * {ADJ}`).
    Loop {
        var: Name,
        /// Boxed: body items are moved and matched by value along deep recursions,
        /// so the variants stay small.
        range: Box<LoopRange>,
        adj: AdjList,
        item: Box<BodyItem>,
    },
    /// `COUNT[/DIV] * {ADJ} [\\] ITEM`.
    Iterate {
        count: Count,
        divisor: Option<Count>,
        adj: AdjList,
        /// `M * {T} \ ITEM`: each run continues from the previous run's end state
        /// (composed with the step) instead of the iterator's frame (SPEC resolved
        /// semantics 6).
        chain: bool,
        item: Box<BodyItem>,
    },
    /// `{ BODY }`.
    Block(Vec<BodyItem>),
    /// `switch (EXPR) { case A, B..C: ITEMS … else: ITEMS }`. Boxed, as it is large.
    Switch(Box<Switch>),
    Pre(Pre<BodyItem>),
    Error,
}

/// A `switch` as written, and the items it means.
///
/// The checker, the lowering and the index read [`Switch::lowered`]: a block that
/// binds `floor(EXPR)` once with a `let` and tests it with an `if` / `else if` chain
/// (each arm's labels joined by `||`, a range `A..B` as `A <= k && k <= B` with both
/// bounds floored), so a `switch` means exactly what that chain means. The formatter
/// and the selection ranges read the written form. Every expression written appears
/// once in the lowered form, at its own span; the names it adds (`floor`, the bound
/// value) carry an empty span at the `switch` keyword.
#[derive(Clone, Debug, PartialEq)]
pub struct Switch {
    /// The `switch` keyword.
    pub keyword: Span,
    pub value: Expr,
    pub arms: Vec<SwitchArm>,
    /// `else: ITEMS`, with the span from `else` to the last item.
    pub otherwise: Option<(Vec<BodyItem>, Span)>,
    /// The `{ … }` of the arms.
    pub body_span: Span,
    pub lowered: BodyItem,
}

/// `case LABEL, LABEL: ITEMS`.
#[derive(Clone, Debug, PartialEq)]
pub struct SwitchArm {
    pub labels: Vec<CaseLabel>,
    pub body: Vec<BodyItem>,
    /// From `case` to the arm's last item.
    pub span: Span,
}

/// One label of a `case`: a value, or an inclusive range `LO..HI`.
#[derive(Clone, Debug, PartialEq)]
pub struct CaseLabel {
    pub lo: Expr,
    pub hi: Option<Expr>,
}

impl CaseLabel {
    /// The label's expressions, as written: the value, or a range's two ends.
    pub fn exprs(&self) -> impl Iterator<Item = &Expr> {
        std::iter::once(&self.lo).chain(self.hi.as_ref())
    }
}

impl Switch {
    /// Builds a `switch` and its lowered form (see [`Switch`]).
    pub fn new(
        keyword: Span,
        value: Expr,
        arms: Vec<SwitchArm>,
        otherwise: Option<(Vec<BodyItem>, Span)>,
        body_span: Span,
        whole: Span,
    ) -> Switch {
        // The bound value's name cannot be written in MDG (`#` starts a colour), so it
        // never meets a user's name; the offset keeps nested switches apart. The names
        // added are empty spans at the keyword: nothing to hover, rename or colour.
        let at = Span::new(keyword.file, keyword.start, keyword.start);
        let bound = Name { text: format!("switch#{}", keyword.start), span: at };
        let floor = |e: Expr| Expr {
            span: e.span,
            kind: ExprKind::Call(Name { text: "floor".to_string(), span: at }, vec![e]),
        };
        let var = || Expr { kind: ExprKind::Var(bound.clone()), span: at };
        let bin = |op, a: Expr, b: Expr| {
            let span = Span::new(a.span.file, a.span.start.min(b.span.start), a.span.end.max(b.span.end));
            Expr { kind: ExprKind::Binary(op, Box::new(a), Box::new(b)), span }
        };
        let mut chain: Option<BodyItem> =
            otherwise.clone().map(|(items, span)| BodyItem { kind: BodyKind::Block(items), cont: false, span });
        for arm in arms.iter().rev() {
            let mut cond: Option<Expr> = None;
            for label in &arm.labels {
                let test = match &label.hi {
                    None => bin(BinOp::Eq, var(), floor(label.lo.clone())),
                    Some(hi) => bin(
                        BinOp::And,
                        bin(BinOp::Le, floor(label.lo.clone()), var()),
                        bin(BinOp::Le, var(), floor(hi.clone())),
                    ),
                };
                cond = Some(match cond {
                    None => test,
                    Some(c) => bin(BinOp::Or, c, test),
                });
            }
            let cond = cond.unwrap_or(Expr { kind: ExprKind::Error, span: arm.span });
            chain = Some(BodyItem {
                kind: BodyKind::If {
                    cond,
                    then: arm.body.clone(),
                    then_span: arm.span,
                    otherwise: chain.map(Box::new),
                },
                cont: false,
                span: arm.span,
            });
        }
        let mut items = vec![BodyItem {
            kind: BodyKind::Let { name: bound.clone(), value: floor(value.clone()) },
            cont: false,
            span: keyword,
        }];
        items.extend(chain);
        let lowered = BodyItem { kind: BodyKind::Block(items), cont: false, span: whole };
        Switch { keyword, value, arms, otherwise, body_span, lowered }
    }
}

/// The bounds of a `loop`: `START, END [, STEP]`.
#[derive(Clone, Debug, PartialEq)]
pub struct LoopRange {
    pub start: Expr,
    pub end: Expr,
    pub step: Option<Expr>,
}

/// Calls `f` on every item of `items` and on the items nested in them (an iterator's
/// or loop's item, a block's items, both branches of an `if`), in source order.
pub fn walk_body<'a>(items: &'a [BodyItem], f: &mut dyn FnMut(&'a BodyItem)) {
    for item in items {
        f(item);
        match &item.kind {
            BodyKind::Iterate { item, .. } | BodyKind::Loop { item, .. } => walk_body(std::slice::from_ref(item), f),
            BodyKind::Block(inner) => walk_body(inner, f),
            BodyKind::Switch(s) => walk_body(std::slice::from_ref(&s.lowered), f),
            BodyKind::If { then, otherwise, .. } => {
                walk_body(then, f);
                if let Some(o) = otherwise {
                    walk_body(std::slice::from_ref(o), f);
                }
            }
            _ => {}
        }
    }
}

/// An iterator count or divisor.
#[derive(Clone, Debug, PartialEq)]
pub enum Count {
    Num(Number),
    Neg(Number),
    /// `( EXPR )` over constants.
    Expr(Expr),
}

impl Count {
    /// The span of the count.
    pub fn span(&self) -> Span {
        match self {
            Count::Num(n) | Count::Neg(n) => n.span,
            Count::Expr(e) => e.span,
        }
    }
}

/// An adjustment list `{ … }` or `[ … ]`.
#[derive(Clone, Debug, PartialEq)]
pub struct AdjList {
    /// `true` for `[ ]`.
    pub square: bool,
    pub adjs: Vec<Adj>,
    pub span: Span,
}

/// One adjustment: a name and its arguments.
#[derive(Clone, Debug, PartialEq)]
pub struct Adj {
    pub name: Name,
    pub args: Vec<Arg>,
    pub span: Span,
}

/// An adjustment argument.
#[derive(Clone, Debug, PartialEq)]
pub enum Arg {
    Num(Number),
    Neg(Number),
    /// `( EXPR )` or `rand(a, b)` / `randn(m, sd)`.
    Expr(Expr),
}

impl Arg {
    /// The span of the argument.
    pub fn span(&self) -> Span {
        match self {
            Arg::Num(n) | Arg::Neg(n) => n.span,
            Arg::Expr(e) => e.span,
        }
    }
}

/// An expression (functions, selectors, adjustment arguments, counts).
#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    Num(Number),
    Var(Name),
    Neg(Box<Expr>),
    Binary(BinOp, Box<Expr>, Box<Expr>),
    /// A call. `if(c, a, b)` and `select(i, a, b, …)` are calls of the names `if`
    /// and `select` (see [`SPECIAL_FORMS`]): only the chosen argument is evaluated.
    Call(Name, Vec<Expr>),
    /// `let(a = 1; b = a * 2; a + b)`: each binding is evaluated once, in order (it
    /// sees the earlier ones), then the body.
    Let(Vec<(Name, Expr)>, Box<Expr>),
    /// Parentheses as written (kept so formatting reproduces the same tree).
    Paren(Box<Expr>),
    /// `!e`: 1 when `e` is 0, else 0.
    Not(Box<Expr>),
    /// `(a, b)`, `(a, b, c)`: a vector (Context Free's), a group of scalars known to
    /// the checker; a vector inside one is spread (`(v, 1)` has three components).
    /// Never a value at run time: [`crate::vectors`] turns every vector into its
    /// components before checking and lowering.
    Tuple(Vec<Expr>),
    /// `v[i]`: component `i` (a constant) of the vector `v`.
    Index(Box<Expr>, Box<Expr>),
    Error,
}

/// The calls that evaluate only the argument they choose: `if(c, a, b)` and
/// `select(i, a, b, …)`, with their least number of arguments.
pub const SPECIAL_FORMS: &[(&str, usize)] = &[("if", 3), ("select", 2)];

/// Binary operators, loosest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinOp {
    Or,
    And,
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
    Ne,
    Add,
    Sub,
    Mul,
    Div,
    Pow,
}

impl BinOp {
    /// The operator as written.
    pub fn symbol(self) -> &'static str {
        match self {
            BinOp::Or => "||",
            BinOp::And => "&&",
            BinOp::Lt => "<",
            BinOp::Le => "<=",
            BinOp::Gt => ">",
            BinOp::Ge => ">=",
            BinOp::Eq => "==",
            BinOp::Ne => "!=",
            BinOp::Add => "+",
            BinOp::Sub => "-",
            BinOp::Mul => "*",
            BinOp::Div => "/",
            BinOp::Pow => "^",
        }
    }
}

/// Preprocessor constructs, generic over the kind of item they contain.
#[derive(Clone, Debug, PartialEq)]
pub enum Pre<T> {
    /// `@import a b/c.mdg`.
    Import(Vec<Name>),
    /// `@define NAME [NUMBER]`.
    Define { name: Name, value: Option<Number> },
    /// `@param TYPE NAME DEFAULT [MIN MAX]`; the words after `@param`.
    Param(Vec<Name>),
    /// `@presets a b c`.
    Presets(Vec<Name>),
    /// `@vertexshader NAME … @endshader` / `@fragmentshader …`.
    Shader { vertex: bool, name: Name, code: String, code_span: Span },
    /// `@macro NAME(a, b) … @endmacro`.
    Macro(MacroDef),
    /// `@expand NAME(arg, …)`.
    Expand { name: Name, args: Vec<MacroArg> },
    /// `@ifdef NAME … [@else …] @endif`.
    IfDef { name: Name, then: Vec<T>, otherwise: Option<Vec<T>> },
    /// A malformed or unknown preprocessor line; a diagnostic was reported.
    Bad,
}

/// A macro definition.
#[derive(Clone, Debug, PartialEq)]
pub struct MacroDef {
    pub name: Name,
    pub params: Vec<Name>,
    /// The body's tokens, spans pointing into the defining file.
    pub body: Vec<crate::lexer::Token>,
    /// The span of the body text (from after the parameter list to `@endmacro`).
    pub body_span: Span,
}

/// One macro argument: its tokens and the span of its text.
#[derive(Clone, Debug, PartialEq)]
pub struct MacroArg {
    pub tokens: Vec<crate::lexer::Token>,
    pub span: Span,
}
