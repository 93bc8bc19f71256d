//! The verifier: every index, count and jump in a decoded bundle is checked before
//! the evaluator sees it, so evaluation can index without bounds surprises.

use super::*;
use crate::expr;

fn bad(msg: String) -> LoadError {
    LoadError(msg)
}

/// The sizes indices are checked against.
struct Counts {
    n_str: u32,
    n_rules: u32,
    n_expr: u32,
    n_ops: u32,
}

impl Counts {
    fn string(&self, i: u32, what: &str) -> Result<(), LoadError> {
        if i < self.n_str {
            Ok(())
        } else {
            Err(bad(format!("{what}: string {i} out of range")))
        }
    }

    fn rule(&self, i: u32, what: &str) -> Result<(), LoadError> {
        if i < self.n_rules {
            Ok(())
        } else {
            Err(bad(format!("{what}: rule {i} out of range")))
        }
    }

    fn rule_or_none(&self, i: u32, what: &str) -> Result<(), LoadError> {
        if i == NONE {
            Ok(())
        } else {
            self.rule(i, what)
        }
    }

    fn expr(&self, i: u32, what: &str) -> Result<(), LoadError> {
        if i < self.n_expr {
            Ok(())
        } else {
            Err(bad(format!("{what}: expression {i} out of range")))
        }
    }
}

/// Verifies a decoded bundle.
pub fn verify(b: &Bundle) -> Result<(), LoadError> {
    let c = Counts {
        n_str: b.strings.len() as u32,
        n_rules: b.rules.len() as u32,
        n_expr: b.exprs.len() as u32,
        n_ops: b.code.len() as u32,
    };
    let s = &b.settings;
    c.rule(s.startshape, "startshape")?;
    c.rule_or_none(s.linerule, "linerule")?;
    c.rule_or_none(s.camerarule, "camerarule")?;
    if s.namespaces.is_empty() {
        return Err(bad("no namespaces (the global one must be present)".into()));
    }
    for n in &s.namespaces {
        c.string(*n, "namespace")?;
    }
    for (i, e) in b.exprs.iter().enumerate() {
        expr::verify(e).map_err(|m| bad(format!("expression {i}: {m}")))?;
    }
    verify_transforms(b, &c)?;
    verify_rules(b, &c)?;
    verify_code(b)?;
    verify_graphics(b, &c)?;
    for p in &b.params {
        c.string(p.name, "param")?;
        if p.ty > 2 {
            return Err(bad("param type out of range".into()));
        }
    }
    let mut prev = 0;
    for l in &b.source_map {
        c.string(l.file, "source map")?;
        if l.op < prev || l.op >= c.n_ops.max(1) {
            return Err(bad("source map out of order or out of range".into()));
        }
        prev = l.op;
    }
    Ok(())
}

/// Dynamic transforms: positive divisors, well-formed adjustments, expressions in range.
fn verify_transforms(b: &Bundle, c: &Counts) -> Result<(), LoadError> {
    for (i, t) in b.transforms.iter().enumerate() {
        if let Transform::Dynamic { adjs, divisor } = t {
            if *divisor <= 0.0 {
                return Err(bad(format!("transform {i}: divisor {divisor} ≤ 0")));
            }
            for a in adjs {
                let max_args = a.kind.max_args();
                if a.axis > 3 || a.args.len() > max_args {
                    return Err(bad(format!("transform {i}: malformed adjustment")));
                }
                for arg in &a.args {
                    if let Arg::Expr(e) = arg {
                        c.expr(*e, "adjustment argument")?;
                    }
                }
            }
        }
    }
    Ok(())
}

/// Rules: names, definitions, selectors and weights, retirement, transform rules.
fn verify_rules(b: &Bundle, c: &Counts) -> Result<(), LoadError> {
    for (i, r) in b.rules.iter().enumerate() {
        c.string(r.name, "rule name")?;
        if r.defs.is_empty() {
            return Err(bad(format!("rule {i} has no definitions")));
        }
        if let Selector::Function(e) = r.selector {
            c.expr(e, "selector")?;
            // A selector reads the call's arguments, not the body's locals.
            if expr::slots_needed(&b.exprs[e as usize]) > r.params.len() {
                return Err(bad(format!("rule {i}: the selector reads a slot beyond the parameters")));
            }
        }
        if r.params.len() > r.frame as usize {
            return Err(bad(format!("rule {i}: {} parameters in a frame of {}", r.params.len(), r.frame)));
        }
        for d in &r.defs {
            if d.start >= c.n_ops {
                return Err(bad(format!("rule {i}: definition starts at op {} beyond the code", d.start)));
            }
            if d.weight_expr != NONE {
                c.expr(d.weight_expr, "weight")?;
                // Like a selector, a weight reads the call's arguments only.
                if expr::slots_needed(&b.exprs[d.weight_expr as usize]) > r.params.len() {
                    return Err(bad(format!("rule {i}: a weight reads a slot beyond the parameters")));
                }
            }
        }
        for d in &r.defs {
            c.rule_or_none(d.retire_to, "retirement rule")?;
        }
        for t in &r.transforms {
            c.rule(*t, "transform rule")?;
        }
        c.rule_or_none(r.iter, "iterator rule")?;
    }
    Ok(())
}

/// The code: every operand in range, every definition's body, prototypes and loops.
fn verify_code(b: &Bundle) -> Result<(), LoadError> {
    for (pc, op) in b.code.iter().enumerate() {
        // Every operand in range (the check its type declares, see `ops`), before
        // any body walk reads through them.
        op.check_operands(b).map_err(|m| bad(format!("op {pc} ({}): {m}", op.mnemonic())))?;
    }
    for (i, r) in b.rules.iter().enumerate() {
        for d in &r.defs {
            verify_body(b, i, d.start)?;
        }
    }
    let mut n_protos = 0u32;
    for (pc, op) in b.code.iter().enumerate() {
        let at = |what: &str| format!("op {pc} ({what})");
        match *op {
            Op::Inst { proto, count } => {
                if proto.0 != n_protos {
                    return Err(bad(format!("{}: prototype {}, expected {n_protos}", at("INST"), proto.0)));
                }
                n_protos += 1;
                let covered = b.code.get(pc + 1..).and_then(|c| c.get(..count.index()));
                if !covered.is_some_and(|c| super::proto::is_run(c, &b.transforms)) {
                    return Err(bad(format!(
                        "{}: the next {} ops are not a run of VERTEX/FACENORMALS with constant transforms",
                        at("INST"),
                        count.0
                    )));
                }
            }
            Op::Loop { end, .. } | Op::LoopN { end, .. } => match b.code.get(end.index()) {
                Some(Op::EndLoop { begin }) if begin.index() == pc => {}
                _ => return Err(bad(format!("{}: end {} is not its ENDLOOP", at("LOOP"), end.0))),
            },
            Op::EndLoop { begin } => match b.code.get(begin.index()) {
                Some(Op::Loop { end, .. } | Op::LoopN { end, .. }) if end.index() == pc => {}
                _ => return Err(bad(format!("{}: begin {} is not its LOOP", at("ENDLOOP"), begin.0))),
            },
            // (Ranges checked above; slots and jumps per definition by `verify_body`.)
            Op::Call { .. } | Op::Draw { .. } | Op::Iso { .. } => {}
            // Checked per definition by `verify_body`.
            Op::Arg { .. } | Op::Set { .. } | Op::Jump { .. } | Op::JumpIfNot { .. } | Op::Seed { .. } => {}
            Op::Cont {} | Op::Ret {} => {}
        }
    }
    Ok(())
}

/// Isosurfaces, shaders, the program and uniforms.
fn verify_graphics(b: &Bundle, c: &Counts) -> Result<(), LoadError> {
    for iso in &b.isosurfaces {
        c.string(iso.name, "isosurface")?;
        c.expr(iso.function, "isosurface function")?;
        for a in 0..3 {
            if iso.res[a] == 0 || iso.min[a] >= iso.max[a] {
                return Err(bad("isosurface grid with zero resolution or empty range".into()));
            }
        }
    }
    for (i, sh) in b.shaders.iter().enumerate() {
        c.string(sh.name, "shader")?;
        c.string(sh.source, "shader")?;
        // A SPIR-V module is a 5-word header (magic, version, generator, bound,
        // schema) and at least one instruction; the driver validates the rest.
        if !sh.spirv.is_empty() && (sh.spirv.len() < 6 || sh.spirv[0] != SPIRV_MAGIC) {
            return Err(bad(format!("shader {i}: SPIR-V without the module header")));
        }
        let n = super::spirv::largest_array(&sh.spirv);
        if n > super::spirv::MAX_ARRAY_ELEMENTS {
            return Err(bad(format!(
                "shader {i}: an array of {n} elements (at most {})",
                super::spirv::MAX_ARRAY_ELEMENTS
            )));
        }
    }
    if let Some(p) = &b.program {
        for (idx, vertex, what) in [(p.vertex, true, "vertex"), (p.fragment, false, "fragment")] {
            if idx == NONE {
                continue;
            }
            match b.shaders.get(idx as usize) {
                Some(sh) if sh.vertex == vertex => {}
                _ => return Err(bad(format!("program: {what} shader {idx} out of range or of the wrong stage"))),
            }
        }
    }
    for u in &b.uniforms {
        c.string(u.name, "uniform")?;
        if let UniformSource::Frame { rule, prop } = u.source {
            c.rule(rule, "uniform rule")?;
            if prop as usize >= UNIFORM_PROPS.len() {
                return Err(bad(format!("uniform: property {prop} out of range")));
            }
        }
    }
    Ok(())
}

/// A definition of rule `rule` runs from `start` to a `RET` at loop depth 0, with
/// loops nested; every `CALL` is preceded by exactly as many `ARG`s as its rule has
/// parameters (and nothing else happens between them); jumps go forward to an op of
/// the same definition inside the same loop, never between an `ARG` and its `CALL`;
/// every slot read or written lies in the rule's frame.
fn verify_body(b: &Bundle, rule: usize, start: u32) -> Result<(), LoadError> {
    let frame = b.rules[rule].frame as usize;
    let slots_ok = |e: ExprId, pc: usize| {
        if expr::slots_needed(&b.exprs[e]) > frame {
            Err(bad(format!("op {pc}: expression {} reads a slot beyond the frame of {frame}", e.0)))
        } else {
            Ok(())
        }
    };
    let xf_ok = |xf: TransformId, pc: usize| -> Result<(), LoadError> {
        if let Some(Transform::Dynamic { adjs, .. }) = b.transforms.get(xf.index()) {
            for a in adjs {
                for arg in &a.args {
                    if let Arg::Expr(e) = arg {
                        if (*e as usize) < b.exprs.len() {
                            slots_ok(ExprId(*e), pc)?;
                        }
                    }
                }
            }
        }
        Ok(())
    };
    // The innermost open loop (its LOOP op) and the pending ARG count, per op.
    let mut loops: Vec<usize> = Vec::new();
    let mut pending = 0usize;
    let mut at: Vec<(Option<usize>, usize)> = Vec::new();
    let mut jumps: Vec<(usize, OpIndex)> = Vec::new();
    let mut pc = start as usize;
    while let Some(op) = b.code.get(pc) {
        at.push((loops.last().copied(), pending));
        let path_draw = match *op {
            Op::Draw { kind, flags, .. } => super::ops::path_arity(kind, flags),
            _ => None,
        };
        if let Some(want) = path_draw {
            if pending != want {
                return Err(bad(format!("op {pc}: {} with {pending} arguments for {want}", op.mnemonic())));
            }
            pending = 0;
        } else if pending > 0 && !matches!(op, Op::Arg { .. } | Op::Call { .. } | Op::Seed { .. }) {
            return Err(bad(format!("op {pc}: {} between an ARG and its CALL", op.mnemonic())));
        }
        match *op {
            Op::Loop { step, .. } => {
                xf_ok(step, pc)?;
                loops.push(pc);
            }
            Op::LoopN { count, step, .. } => {
                slots_ok(count, pc)?;
                xf_ok(step, pc)?;
                loops.push(pc);
            }
            Op::EndLoop { .. } => {
                loops.pop().ok_or_else(|| bad(format!("ENDLOOP without LOOP at op {pc}")))?;
            }
            Op::Arg { expr } => {
                slots_ok(expr, pc)?;
                pending += 1;
            }
            Op::Call { rule: callee, xf, .. } => {
                xf_ok(xf, pc)?;
                let want = b.rules.get(callee.index()).map(|r| r.params.len()).unwrap_or(0);
                if pending != want {
                    return Err(bad(format!("op {pc}: CALL with {pending} arguments for {want} parameters")));
                }
                pending = 0;
            }
            Op::Draw { xf, .. } | Op::Iso { xf, .. } => xf_ok(xf, pc)?,
            Op::Set { slot, expr } => {
                slots_ok(expr, pc)?;
                if slot.index() >= frame {
                    return Err(bad(format!("op {pc}: SET of slot {} beyond the frame of {frame}", slot.0)));
                }
            }
            Op::Jump { target } => jumps.push((pc, target)),
            Op::JumpIfNot { expr, target } => {
                slots_ok(expr, pc)?;
                jumps.push((pc, target));
            }
            Op::Seed { expr } => {
                slots_ok(expr, pc)?;
                if !matches!(b.code.get(pc + 1), Some(Op::Call { .. })) {
                    return Err(bad(format!("op {pc}: SEED not followed by a CALL")));
                }
            }
            Op::Cont {} | Op::Inst { .. } => {}
            Op::Ret {} => {
                if !loops.is_empty() {
                    return Err(bad(format!("RET inside a loop at op {pc}")));
                }
                for (from, target) in jumps {
                    let t = target.index();
                    let ok = t > from && t <= pc && at[t - start as usize] == (at[from - start as usize].0, 0);
                    if !ok {
                        return Err(bad(format!("op {from}: jump to op {t} leaves its definition or loop")));
                    }
                }
                return Ok(());
            }
        }
        pc += 1;
    }
    Err(bad(format!("definition starting at op {start} has no RET")))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal valid bundle: one rule `A` that returns, one shader of each stage.
    fn bundle() -> Bundle {
        let spirv = vec![SPIRV_MAGIC, 0x0001_0000, 0, 1, 0, 0x0002_0011];
        Bundle {
            strings: vec!["A".into(), "vs".into(), "fs".into(), "src".into(), "glow".into(), "".into()],
            settings: Settings { background: [0.0, 0.0, 0.0, 1.0], namespaces: vec![5], ..Bundle::empty().settings },
            transforms: vec![Transform::Const(Composite::IDENTITY)],
            exprs: vec![],
            rules: vec![Rule {
                name: 0,
                selector: Selector::Random,
                defs: vec![Def { weight: 1.0, weight_expr: NONE, start: 0, retire_depth: 0, retire_to: NONE }],
                transforms: vec![],
                iter: NONE,
                params: vec![],
                frame: 0,
            }],
            code: vec![Op::Ret {}],
            isosurfaces: vec![],
            shaders: vec![
                Shader { vertex: true, name: 1, source: 3, spirv: spirv.clone() },
                Shader { vertex: false, name: 2, source: 3, spirv },
            ],
            program: Some(Program { vertex: 0, fragment: 1 }),
            uniforms: vec![
                Uniform { name: 4, source: UniformSource::Const([0.5, 0.0, 0.0, 0.0]) },
                Uniform { name: 4, source: UniformSource::Frame { rule: 0, prop: 0 } },
            ],
            params: vec![],
            source_map: vec![],
            extensions: Extensions::default(),
        }
    }

    #[test]
    fn shaders_program_and_uniforms_round_trip_and_verify() {
        let b = bundle();
        verify(&b).expect("valid");
        let bytes = encode(&b);
        assert_eq!(load(&bytes).expect("loads"), b);
    }

    #[test]
    fn bad_shader_program_and_uniform_references_are_rejected() {
        let mut b = bundle();
        b.shaders[0].spirv = vec![1, 2, 3, 4, 5, 6];
        assert!(verify(&b).is_err(), "SPIR-V without the magic number");
        // `float[100000000]`: (the capability's operand,) OpConstant %int %10 100000000,
        // OpTypeArray %20 %float %10.
        let mut b = bundle();
        b.shaders[1].spirv.extend([1, (4 << 16) | 43, 1, 10, 100_000_000, (4 << 16) | 28, 20, 5, 10]);
        let e = verify(&b).expect_err("a huge array").to_string();
        assert!(e.contains("an array of 100000000 elements (at most 65536)"), "{e}");
        let mut b = bundle();
        b.program = Some(Program { vertex: 1, fragment: 1 });
        assert!(verify(&b).is_err(), "a fragment shader as the vertex stage");
        let mut b = bundle();
        b.program = Some(Program { vertex: NONE, fragment: 7 });
        assert!(verify(&b).is_err(), "shader index out of range");
        let mut b = bundle();
        b.uniforms[1].source = UniformSource::Frame { rule: 3, prop: 0 };
        assert!(verify(&b).is_err(), "uniform rule out of range");
        let mut b = bundle();
        b.uniforms[1].source = UniformSource::Frame { rule: 0, prop: 9 };
        assert!(verify(&b).is_err(), "uniform property out of range");
    }

    #[test]
    fn every_out_of_range_operand_is_named_by_its_type() {
        // One op per operand type that indexes a table, each one past its table's end:
        // the error names the op and what is out of range (a namespace of DRAW and an
        // isosurface of ISO were "operand out of range" before their types said what).
        let cases: [(Op, &str); 7] = [
            (Op::Call { rule: RuleId(1), xf: TransformId(0), flags: 0 }, "op 0 (CALL): rule 1 out of range"),
            (Op::Call { rule: RuleId(0), xf: TransformId(1), flags: 0 }, "op 0 (CALL): transform 1 out of range"),
            (
                Op::Draw { kind: Drawable::Vertex, xf: TransformId(0), ns: NsId(1), profile: Profile(NONE), flags: 0 },
                "op 0 (DRAW): namespace 1 out of range",
            ),
            (
                Op::Draw { kind: Drawable::LineTo, xf: TransformId(0), ns: NsId(0), profile: Profile(4), flags: 0 },
                "op 0 (DRAW): profile rule 4 out of range",
            ),
            (Op::Iso { iso: IsoId(0), xf: TransformId(0), flags: 0 }, "op 0 (ISO): isosurface 0 out of range"),
            (Op::Arg { expr: ExprId(2) }, "op 0 (ARG): expression 2 out of range"),
            (Op::Jump { target: OpIndex(7) }, "op 0 (JUMP): op 7 out of range"),
        ];
        for (op, want) in cases {
            let mut b = bundle();
            b.code.insert(0, op);
            let e = verify(&b).expect_err(want).to_string();
            assert!(e.contains(want), "{e}, wanted {want}");
        }
    }
}
