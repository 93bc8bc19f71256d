//! Prototypes: runs of `VERTEX`/`FACENORMALS` ops that an `INST` op turns into one
//! instance record (issue 20: "instances as the evaluator's output").
//!
//! A run qualifies when every op in it is a `VERTEX` or `FACENORMALS` draw whose
//! transform is a constant without a non-uniform scale or an HSB change, so that the
//! vertices it makes are a fixed mesh in the frame the run starts from: positions,
//! normals, colour and weight deltas never vary from call to call. The run must be
//! made of whole triangles, every three `VERTEX` closing one and any `FACENORMALS`
//! following a closed triangle, so that the instance's triangles are its own
//! (triangles are formed by counting vertices across the whole mesh).
//!
//! The compiler asks [`run_length`] where to put `INST` ops; the verifier checks
//! with [`is_run`] that an `INST` covers such a run; the evaluator builds the
//! prototype mesh from the ops themselves and, where the conditions hold at run
//! time (a model run, a similarity frame, no pending continuation, a whole number of
//! triangles so far), emits the instance instead of running them.

use super::{Drawable, Op, Transform};

/// Whether `op` may be part of a prototype run.
pub fn is_prototype_op(op: &Op, transforms: &[Transform]) -> bool {
    match *op {
        Op::Draw { kind: Drawable::Vertex | Drawable::FaceNormals, xf, .. } => {
            matches!(transforms.get(xf.index()), Some(Transform::Const(c)) if c.n.is_none() && c.hsb.is_none() && c.set.is_none())
        }
        _ => false,
    }
}

/// Walks prototype ops from the start of `ops`; calls `end(len, vertices)` after every
/// op that ends a whole number of triangles (a `VERTEX` making the count a multiple of
/// three, or a `FACENORMALS` right after one). Stops at the first op that cannot
/// continue a run.
fn walk(ops: &[Op], transforms: &[Transform], mut end: impl FnMut(usize, usize)) {
    let mut vertices = 0usize;
    for (i, op) in ops.iter().enumerate() {
        if !is_prototype_op(op, transforms) {
            return;
        }
        match op {
            Op::Draw { kind: Drawable::Vertex, .. } => vertices += 1,
            // A FACENORMALS inside a triangle would reach back into the vertices before
            // the run.
            _ if vertices == 0 || !vertices.is_multiple_of(3) => return,
            _ => {}
        }
        if vertices.is_multiple_of(3) {
            end(i + 1, vertices);
        }
    }
}

/// The length of the longest prototype run at the start of `ops` (0 if none).
pub fn run_length(ops: &[Op], transforms: &[Transform]) -> usize {
    let mut longest = 0;
    walk(ops, transforms, |len, _| longest = len);
    longest
}

/// Whether `ops` is exactly one prototype run (what an `INST` may cover).
pub fn is_run(ops: &[Op], transforms: &[Transform]) -> bool {
    let mut whole = false;
    walk(ops, transforms, |len, _| whole = len == ops.len());
    whole
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bundle::{Composite, NsId, Profile, TransformId, NONE};

    fn draw(kind: Drawable, xf: u32) -> Op {
        Op::Draw { kind, xf: TransformId(xf), ns: NsId(0), profile: Profile(NONE), flags: 0 }
    }

    #[test]
    fn runs_are_whole_triangles_of_constant_draws() {
        let nonuniform = Composite { n: Some([2.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]), ..Composite::IDENTITY };
        let xfs = vec![Transform::Const(Composite::IDENTITY), Transform::Const(nonuniform)];
        let v = draw(Drawable::Vertex, 0);
        let f = draw(Drawable::FaceNormals, 0);
        let ret = Op::Ret {};
        assert_eq!(run_length(&[v, v, v, f, v, v, v, f, ret], &xfs), 8);
        assert_eq!(run_length(&[v, v, v, v, v, ret], &xfs), 3, "a partial triangle stays out");
        assert_eq!(run_length(&[v, v, ret], &xfs), 0);
        assert_eq!(run_length(&[f, v, v, v], &xfs), 0, "FACENORMALS first reaches before the run");
        assert_eq!(run_length(&[v, v, v, v, f, v, v], &xfs), 3, "FACENORMALS inside a triangle ends the run");
        assert_eq!(run_length(&[v, v, draw(Drawable::Vertex, 1), v, v, v], &xfs), 0, "non-uniform scale");
        assert_eq!(run_length(&[v, v, v, draw(Drawable::LineTo, 0)], &xfs), 3);
        assert!(is_run(&[v, v, v, f, f], &xfs));
        assert!(is_run(&[v, v, v], &xfs));
        assert!(!is_run(&[v, v, v, v], &xfs));
        assert!(!is_run(&[], &xfs));
        assert!(!is_run(&[v, v, v, ret], &xfs));
    }
}
