//! The disassembler: a bundle as readable text (`mdgc disasm`), snapshot-tested.

use super::*;
use std::fmt::Write;

fn composite(c: &Composite) -> String {
    let f = |v: &[f32]| v.iter().map(|x| format!("{x:.6}")).collect::<Vec<_>>().join(" ");
    let mut s = format!("q=({}) q̂=({}) u=({})", f(&c.q), f(&c.qh), f(&c.u));
    if let Some(set) = &c.set {
        let _ = write!(s, " color=({})", f(set));
    }
    if c.color != [0.0; 4] {
        let _ = write!(s, " color+=({})", f(&c.color));
    }
    if c.weight != [0.0; 4] {
        let _ = write!(s, " weight+=({})", f(&c.weight));
    }
    if c.fps != 0.0 {
        let _ = write!(s, " fps+={}", c.fps);
    }
    if let Some(n) = &c.n {
        let _ = write!(s, " N=({})", f(n));
    }
    if let Some(h) = &c.hsb {
        let _ = write!(s, " hue+={} sat*={}+{} b*={}+{}", h[0], h[1], h[2], h[3], h[4]);
    }
    s
}

/// Expression code as infix text: `s0` is slot 0 of the rule's frame. Code with
/// branches or bindings (`if`, `let`, `select`) is listed op by op instead:
/// `[push 1; skipunless 2; …]`.
pub fn expr_text(code: &[crate::expr::ExprOp]) -> String {
    use crate::expr::{ExprOp, FUNCTIONS, VARIABLES};
    if code.iter().any(|op| {
        matches!(
            op,
            ExprOp::Skip(_)
                | ExprOp::SkipUnless(_)
                | ExprOp::Pick(_)
                | ExprOp::Slide(_)
                | ExprOp::Funcs(_)
                | ExprOp::Fn(_)
        )
    }) {
        let ops: Vec<String> = code
            .iter()
            .map(|op| match *op {
                ExprOp::Push(v) => format!("push {v}"),
                ExprOp::Var(i) => VARIABLES.get(i as usize).unwrap_or(&"?").to_string(),
                ExprOp::Slot(i) => format!("s{i}"),
                ExprOp::Neg => "neg".into(),
                ExprOp::Bin(o) => o.symbol().into(),
                ExprOp::Call(f) => FUNCTIONS.get(f as usize).map_or("?", |f| f.0).into(),
                ExprOp::Skip(n) => format!("skip {n}"),
                ExprOp::SkipUnless(n) => format!("skipunless {n}"),
                ExprOp::Pick(k) => format!("pick {k}"),
                ExprOp::Slide(n) => format!("slide {n}"),
                ExprOp::Funcs(n) => format!("funcs {n}"),
                ExprOp::Enter(a) => format!("enter {a}"),
                ExprOp::Fn(rel) => format!("fn {rel:+}"),
                ExprOp::Ret => "ret".into(),
            })
            .collect();
        return format!("[{}]", ops.join("; "));
    }
    // (text, binds loosely: needs parentheses as an operand)
    let mut st: Vec<(String, bool)> = Vec::new();
    let pop = |st: &mut Vec<(String, bool)>| st.pop().unwrap_or_else(|| ("?".into(), false));
    for op in code {
        match *op {
            ExprOp::Push(v) => st.push((format!("{v}"), v < 0.0)),
            ExprOp::Var(i) => st.push((VARIABLES.get(i as usize).unwrap_or(&"?").to_string(), false)),
            ExprOp::Slot(i) => st.push((format!("s{i}"), false)),
            ExprOp::Neg => {
                let (a, loose) = pop(&mut st);
                st.push((if loose { format!("-({a})") } else { format!("-{a}") }, false));
            }
            ExprOp::Bin(o) => {
                let (b, lb) = pop(&mut st);
                let (a, la) = pop(&mut st);
                let wrap = |t: String, loose: bool| if loose { format!("({t})") } else { t };
                let sym = o.symbol();
                st.push((format!("{} {sym} {}", wrap(a, la), wrap(b, lb)), true));
            }
            ExprOp::Call(f) => {
                let (name, arity) = FUNCTIONS.get(f as usize).copied().unwrap_or(("?", 0));
                let at = st.len().saturating_sub(arity);
                let args: Vec<String> = st.drain(at..).map(|(t, _)| t).collect();
                st.push((format!("{name}({})", args.join(", ")), false));
            }
            ExprOp::Skip(_)
            | ExprOp::SkipUnless(_)
            | ExprOp::Pick(_)
            | ExprOp::Slide(_)
            | ExprOp::Funcs(_)
            | ExprOp::Enter(_)
            | ExprOp::Fn(_)
            | ExprOp::Ret => {}
        }
    }
    st.pop().map(|(t, _)| t).unwrap_or_default()
}

/// `(a b c)`: a list of numbers as the disassembler writes them.
fn tuple<T: std::fmt::Display>(v: &[T]) -> String {
    let parts: Vec<String> = v.iter().map(|x| x.to_string()).collect();
    format!("({})", parts.join(" "))
}

/// Renders the whole bundle.
pub fn disassemble(b: &Bundle) -> String {
    let mut o = String::new();
    let s = &b.settings;
    let _ = writeln!(o, "; MDG bundle, format version {VERSION}");
    let _ = writeln!(o, "startshape {}", b.string(b.rules.get(s.startshape as usize).map(|r| r.name).unwrap_or(0)));
    let _ = writeln!(
        o,
        "settings maxdepth={} minsize={} maxiter={} stacksize={} randseed={} fps={} duration={}",
        s.maxdepth, s.minsize, s.maxiter, s.stacksize, s.randseed, s.fps, s.duration
    );
    if s.breadth {
        let _ = writeln!(o, "breadthfirst maxobjects={}", s.maxobjects);
    }
    let ns: Vec<&str> = s.namespaces.iter().map(|n| b.string(*n)).collect();
    let ns: Vec<String> = ns.iter().map(|n| format!("\"{n}\"")).collect();
    let _ = writeln!(o, "namespaces [{}]", ns.join(", "));
    let _ = writeln!(o, "\n; transforms");
    for (i, t) in b.transforms.iter().enumerate() {
        match t {
            Transform::Const(c) => {
                let _ = writeln!(o, "X{i:<4} {}", composite(c));
            }
            Transform::Dynamic { adjs, divisor } => {
                let list: Vec<String> = adjs
                    .iter()
                    .map(|a| {
                        let args: Vec<String> = a
                            .args
                            .iter()
                            .map(|arg| match arg {
                                Arg::Const(v) => format!("{v}"),
                                Arg::Expr(e) => format!("E{e}"),
                            })
                            .collect();
                        std::iter::once(a.kind.name(a.axis)).chain(args).collect::<Vec<_>>().join(" ")
                    })
                    .collect();
                let _ = writeln!(o, "X{i:<4} dynamic /{divisor} {{{}}}", list.join("; "));
            }
        }
    }
    if !b.exprs.is_empty() {
        let _ = writeln!(o, "\n; expressions");
        for (i, e) in b.exprs.iter().enumerate() {
            let _ = writeln!(o, "E{i:<4} {}", expr_text(e));
        }
    }
    let _ = writeln!(o, "\n; rules");
    for (i, r) in b.rules.iter().enumerate() {
        let defs: Vec<String> = r
            .defs
            .iter()
            .map(|d| {
                let def = match b.exprs.get(d.weight_expr as usize) {
                    Some(e) if d.weight_expr != NONE => format!("@{} w=({})", d.start, expr_text(e)),
                    _ => format!("@{} w={}", d.start, d.weight),
                };
                if d.retire_depth == 0 {
                    return def;
                }
                let to = b.rules.get(d.retire_to as usize).map_or("-", |r| b.string(r.name));
                format!("{def} maxdepth {} > {to}", d.retire_depth)
            })
            .collect();
        let params = if r.params.is_empty() {
            if r.frame > 0 {
                format!(" frame={}", r.frame)
            } else {
                String::new()
            }
        } else {
            let p: Vec<String> = r
                .params
                .iter()
                .enumerate()
                .map(|(k, d)| match d {
                    None => format!("s{k}"),
                    Some(d) => format!("s{k}={d}"),
                })
                .collect();
            format!("({}) frame={}", p.join(", "), r.frame)
        };
        let selector = match r.selector {
            Selector::Random => "random".to_string(),
            Selector::Depth => "depth".to_string(),
            Selector::Scale => "scale".to_string(),
            Selector::Sequential => "sequential".to_string(),
            Selector::Pattern => "pattern".to_string(),
            Selector::Function(e) => format!("function E{e}"),
        };
        let _ = writeln!(o, "R{i:<4} {}{params} {selector} [{}]", b.string(r.name), defs.join(", "));
    }
    let _ = writeln!(o, "\n; code");
    let mut last_src = None;
    for (pc, op) in b.code.iter().enumerate() {
        let src = b.source_of(pc as u32);
        if src != last_src {
            if let Some((f, l)) = src {
                let _ = writeln!(o, "        ; {f}:{l}");
            }
            last_src = src;
        }
        // (Each operand's text comes with its type: rule names, `X3`, `E2`, `@12` …)
        let operands = op.operand_texts(b);
        let mut line = format!("{pc:>6}  {:<8} {}", op.mnemonic(), operands.join(" "));
        if let Op::Inst { count, .. } = op {
            // What the prototype holds: the items it covers, one instance per run.
            let items = b.code.iter().skip(pc + 1).take(count.index());
            let vertices = items.filter(|o| matches!(o, Op::Draw { kind: Drawable::Vertex, .. })).count();
            let t = vertices / 3;
            let _ = write!(line, "    ; prototype: {vertices} vertices, {t} triangle{}", if t == 1 { "" } else { "s" });
        }
        let _ = writeln!(o, "{}", line.trim_end());
    }
    for (i, iso) in b.isosurfaces.iter().enumerate() {
        let _ = writeln!(
            o,
            "\nI{i} isosurface {} min={} max={} res={} f=E{}",
            b.string(iso.name),
            tuple(&iso.min),
            tuple(&iso.max),
            tuple(&iso.res),
            iso.function
        );
    }
    for (i, sh) in b.shaders.iter().enumerate() {
        let stage = if sh.vertex { "vertex" } else { "fragment" };
        let _ = writeln!(o, "\nS{i} {stage} shader {} ({} SPIR-V words)", b.string(sh.name), sh.spirv.len());
    }
    if let Some(p) = &b.program {
        let name = |i: u32| if i == NONE { "-".to_string() } else { format!("S{i}") };
        let _ = writeln!(o, "\nprogram vertex={} fragment={}", name(p.vertex), name(p.fragment));
    }
    for u in &b.uniforms {
        match u.source {
            UniformSource::Const(v) => {
                let _ = writeln!(o, "uniform {} {}", b.string(u.name), tuple(&v));
            }
            UniformSource::Frame { rule, prop } => {
                let rule = b.string(b.rules.get(rule as usize).map(|r| r.name).unwrap_or(0));
                let prop = UNIFORM_PROPS.get(prop as usize).unwrap_or(&"?");
                let _ = writeln!(o, "uniform {} {rule} {prop}", b.string(u.name));
            }
        }
    }
    o
}
