//! Values: the random stream, expressions evaluated in a state, transforms with
//! run-time arguments, and the record of non-finite values and their fallbacks.

use super::*;

pub(super) struct Pcg(pub(super) Pcg64);

impl Random for Pcg {
    fn uniform(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// Where an expression is evaluated: the state its position and scale are read from,
/// the rule depth, and the running rule's frame.
pub(super) struct Env<'a> {
    pub(super) at: &'a State,
    pub(super) depth: u32,
    pub(super) slots: &'a [f64],
}

impl Env<'_> {
    #[inline]
    pub(super) fn eval(&self, code: &[ExprOp], rng: &mut Pcg, stack: &mut expr::Machine) -> f64 {
        match expr::quick(code, self.slots) {
            Some(v) => v,
            None => self.eval_full(code, rng, stack),
        }
    }

    /// [`Env::eval`] on the expression stack (code [`expr::quick`] does not take).
    pub(super) fn eval_full(&self, code: &[ExprOp], rng: &mut Pcg, stack: &mut expr::Machine) -> f64 {
        let p = self.at.f.u;
        let vars = [p.x as f64, p.y as f64, p.z as f64, self.depth as f64, self.at.scale() as f64, 0.0];
        expr::eval(code, &vars, self.slots, rng, stack)
    }
}

/// Values computed at run time that were NaN or infinite where a finite number is
/// needed, each replaced by a fallback the run reports once per kind, at the first
/// place it happened.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct NonFinite {
    /// Per [`Fallback`]: how many, and where the first was.
    pub(super) count: [u64; 5],
    pub(super) first: [Option<Site>; 5],
}

/// What a value that was not a finite number was replaced by.
#[derive(Clone, Copy, Debug)]
pub(super) enum Fallback {
    /// An adjustment argument that was NaN: 0.
    NanArgument,
    /// An adjustment argument that was infinite: 0.
    InfiniteArgument,
    /// A definition weight: 0.
    Weight,
    /// A function selector's value: the first definition.
    Selector,
    /// A NaN iterator count: no runs.
    Count,
}

/// Where a fallback happened: in an adjustment list (a dynamic transform), a rule's
/// selection, or an op.
#[derive(Clone, Copy, Debug)]
pub(super) enum Site {
    Transform(u32),
    Rule(u32),
    Op(u32),
}

impl NonFinite {
    #[cold]
    #[inline(never)]
    pub(super) fn note(&mut self, what: Fallback, at: Site) {
        let k = what as usize;
        self.count[k] += 1;
        self.first[k].get_or_insert(at);
    }

    /// An adjustment argument `v` of transform `xf` that is not finite.
    #[cold]
    #[inline(never)]
    pub(super) fn argument(&mut self, xf: u32, v: f64) {
        let what = if v.is_nan() { Fallback::NanArgument } else { Fallback::InfiniteArgument };
        self.note(what, Site::Transform(xf));
    }

    /// The warnings for what was noted, each naming the rule and line of its first
    /// occurrence.
    pub(super) fn warnings(&self, b: &Bundle) -> Vec<String> {
        let op_at = |pc: usize| where_op(b, pc as u32);
        let at = |site: Site| match site {
            Site::Transform(xf) => b
                .code
                .iter()
                .position(|op| match *op {
                    Op::Call { xf: x, .. } | Op::Draw { xf: x, .. } | Op::Iso { xf: x, .. } => x.0 == xf,
                    Op::Loop { step, .. } | Op::LoopN { step, .. } => step.0 == xf,
                    _ => false,
                })
                .map(op_at)
                .unwrap_or_default(),
            Site::Rule(r) => b
                .rules
                .get(r as usize)
                .map(|rule| match rule.defs.first() {
                    Some(d) => where_op(b, d.start),
                    None => format!(" in rule `{}`", b.string(rule.name)),
                })
                .unwrap_or_default(),
            Site::Op(pc) => op_at(pc as usize),
        };
        let mut w = Vec::new();
        for (k, (&n, first)) in self.count.iter().zip(&self.first).enumerate() {
            let Some(site) = *first else { continue };
            let at = at(site);
            w.push(match k {
                0 => format!(
                    "{n} adjustment argument(s) computed as NaN (not a number: `0/0`, `log(-1)`, `sqrt(-1)`…){at}: used as 0"
                ),
                1 => format!(
                    "{n} adjustment argument(s) computed as infinite (an overflow or a division by 0){at}: used as 0"
                ),
                2 => format!("{n} definition weight(s) computed as NaN or infinite{at}: used as 0"),
                3 => format!(
                    "{n} selector function value(s) computed as NaN or infinite{at}: the first definition was chosen"
                ),
                _ => format!("{n} iterator count(s) computed as NaN{at}: no runs"),
            });
        }
        w
    }
}

/// Evaluates transform `xf`: a constant composite, or a dynamic list with its random
/// draws taken from `rng`.
#[inline]
pub(super) fn eval_transform(
    b: &Bundle,
    xf: TransformId,
    rng: &mut Pcg,
    stack: &mut expr::Machine,
    env: &Env,
    bad: &mut NonFinite,
) -> Composite {
    match &b.transforms[xf] {
        Transform::Const(c) => *c,
        Transform::Dynamic { adjs, divisor } => {
            // As `compose_prims` over the evaluated arguments (same operations, same
            // order of random draws), without building the argument lists.
            let mut f = Affine::identity();
            let mut c = Composite::IDENTITY;
            for a in adjs {
                let mut vals = [0.0f32; 4];
                for (v, arg) in vals.iter_mut().zip(&a.args) {
                    *v = match arg {
                        bundle::Arg::Const(v) => *v,
                        bundle::Arg::Expr(e) => {
                            let code: &[ExprOp] = &b.exprs[*e as usize];
                            let v = env.eval(code, rng, stack);
                            if v.is_finite() {
                                v as f32
                            } else {
                                bad.argument(xf.0, v);
                                0.0
                            }
                        }
                    };
                }
                apply_prim(&mut f, &mut c, a.kind, a.axis, &vals, a.args.len(), *divisor);
            }
            set_frame(&mut c, &f);
            c
        }
    }
}
