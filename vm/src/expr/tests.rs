//! Unit tests of the expression machine: lazy choices, bindings, function blocks
//! and their limits, the verifier, and the math functions on hostile values.
use super::*;

/// A fixed stream (the draws do not matter here, only that nothing panics).
struct Half;

impl Random for Half {
    fn uniform(&mut self) -> f64 {
        0.5
    }
    fn normal(&mut self) -> f64 {
        0.5
    }
}

/// Values one `log(-1)`, `0/0`, `1e308*10` or an underflow away.
const HOSTILE: [f64; 12] =
    [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e308, -1e308, 0.0, -0.0, 1.0, -1.0, 5e-324, 1e-300, 0.5];

/// A stream that counts its draws.
struct Counting(u32);

impl Random for Counting {
    fn uniform(&mut self) -> f64 {
        self.0 += 1;
        0.25
    }
    fn normal(&mut self) -> f64 {
        self.0 += 1;
        0.0
    }
}

fn rand_01() -> [ExprOp; 3] {
    [ExprOp::Push(0.0), ExprOp::Push(1.0), ExprOp::Call(Func::Rand as u8)]
}

/// `if(s0, 10, rand(0, 1))`, as the compiler lowers it.
fn if_code() -> Vec<ExprOp> {
    let mut c = vec![ExprOp::Slot(0), ExprOp::SkipUnless(2), ExprOp::Push(10.0), ExprOp::Skip(3)];
    c.extend(rand_01());
    c
}

#[test]
fn if_runs_only_the_chosen_branch() {
    let code = if_code();
    assert_eq!(verify(&code), Ok(()));
    let (mut rng, mut stack) = (Counting(0), Machine::default());
    assert_eq!(eval(&code, &[0.0; 6], &[1.0], &mut rng, &mut stack), 10.0);
    assert_eq!(rng.0, 0, "the untaken branch draws nothing");
    assert_eq!(eval(&code, &[0.0; 6], &[0.0], &mut rng, &mut stack), 0.25);
    assert_eq!(eval(&code, &[0.0; 6], &[f64::NAN], &mut rng, &mut stack), 0.25, "NaN is false");
    assert_eq!(rng.0, 2);
}

#[test]
fn let_bindings_are_picked_and_slid_off() {
    // let(a = s0 * 2; b = a + 1; a * b)
    let code = [
        ExprOp::Slot(0),
        ExprOp::Push(2.0),
        ExprOp::Bin(BinOp::Mul),
        ExprOp::Pick(0),
        ExprOp::Push(1.0),
        ExprOp::Bin(BinOp::Add),
        ExprOp::Pick(1),
        ExprOp::Pick(1),
        ExprOp::Bin(BinOp::Mul),
        ExprOp::Slide(2),
        // … + 1: the bindings are gone from under the value.
        ExprOp::Push(1.0),
        ExprOp::Bin(BinOp::Add),
    ];
    assert_eq!(verify(&code), Ok(()));
    let mut stack = Machine::default();
    assert_eq!(eval(&code, &[0.0; 6], &[3.0], &mut Half, &mut stack), 43.0);
}

#[test]
fn select_floors_and_clamps_its_index() {
    // select(s0, 10, 20, 30): the index stays under the branches.
    let branch = |k: f64| [ExprOp::Pick(0), ExprOp::Push(k), ExprOp::Bin(BinOp::Lt), ExprOp::SkipUnless(2)];
    let mut code = vec![ExprOp::Slot(0)];
    code.extend(branch(1.0));
    code.extend([ExprOp::Push(10.0), ExprOp::Skip(7)]);
    code.extend(branch(2.0));
    code.extend([ExprOp::Push(20.0), ExprOp::Skip(1)]);
    code.extend([ExprOp::Push(30.0), ExprOp::Slide(1)]);
    assert_eq!(verify(&code), Ok(()));
    let mut stack = Machine::default();
    let at = |i: f64, stack: &mut Machine| eval(&code, &[0.0; 6], &[i], &mut Half, stack);
    let got: Vec<f64> = [-3.0, 0.0, 0.9, 1.0, 1.5, 2.0, 7.0, f64::NAN].iter().map(|&i| at(i, &mut stack)).collect();
    assert_eq!(got, [10.0, 10.0, 10.0, 20.0, 20.0, 30.0, 30.0, 30.0]);
}

#[test]
fn verify_refuses_bad_skips_and_picks() {
    let bad = |code: &[ExprOp]| verify(code).err().map_or(String::new(), |e| e.to_string());
    // A skip past the end: the error is data (which skip), its message says so.
    assert_eq!(verify(&[ExprOp::Push(1.0), ExprOp::Skip(5)]), Err(CodeError::SkipBeyondEnd { from: 1 }));
    assert_eq!(verify(&[ExprOp::Var(9)]), Err(CodeError::UnknownVariable { var: 9, at: 0 }));
    assert_eq!(verify(&[ExprOp::Push(1.0), ExprOp::Push(2.0)]), Err(CodeError::LeavesValues(2)));
    assert!(bad(&[ExprOp::Push(1.0), ExprOp::Skip(5)]).contains("beyond the end"));
    // Branches that leave different depths.
    let uneven = [ExprOp::Push(1.0), ExprOp::SkipUnless(2), ExprOp::Push(1.0), ExprOp::Push(2.0)];
    assert!(bad(&uneven).contains("meet"), "{}", bad(&uneven));
    // An instruction no path reaches.
    let dead = [ExprOp::Push(1.0), ExprOp::Skip(1), ExprOp::Neg];
    assert!(bad(&dead).contains("unreachable"), "{}", bad(&dead));
    // A pick below the bottom, a slide of more than there is.
    assert!(bad(&[ExprOp::Push(1.0), ExprOp::Pick(1), ExprOp::Bin(BinOp::Add)]).contains("pick 1"));
    assert!(bad(&[ExprOp::Push(1.0), ExprOp::Slide(1)]).contains("underflow"));
    // Malformed code never panics in evaluation.
    for code in [&[ExprOp::Skip(9)][..], &[ExprOp::Pick(3)], &[ExprOp::Slide(4)], &[ExprOp::SkipUnless(1)]] {
        let _ = eval(code, &[0.0; 6], &[], &mut Half, &mut Machine::default());
    }
}

/// `fact(n) = if(n <= 1, 1, n * fact(n - 1))` as the compiler lays it out: a
/// block with the body (its argument at the bottom of its frame), then the
/// main code `fact(s0)`.
fn fact_code() -> Vec<ExprOp> {
    let body = [
        ExprOp::Enter(1),
        ExprOp::Pick(0),
        ExprOp::Push(1.0),
        ExprOp::Bin(BinOp::Le),
        ExprOp::SkipUnless(2),
        ExprOp::Push(1.0),
        ExprOp::Skip(6),
        ExprOp::Pick(0),
        ExprOp::Pick(1),
        ExprOp::Push(1.0),
        ExprOp::Bin(BinOp::Sub),
        ExprOp::Fn(-11),
        ExprOp::Bin(BinOp::Mul),
        ExprOp::Slide(1),
        ExprOp::Ret,
    ];
    let mut code = vec![ExprOp::Funcs(body.len() as u32)];
    code.extend(body);
    code.extend([ExprOp::Slot(0), ExprOp::Fn(-(body.len() as i32) - 1)]);
    code
}

#[test]
fn recursive_functions_run_within_their_limits() {
    let code = fact_code();
    assert_eq!(verify(&code), Ok(()));
    let mut m = Machine::default();
    let fact = |n: f64, m: &mut Machine| eval(&code, &[0.0; 6], &[n], &mut Half, m);
    assert_eq!(fact(5.0, &mut m), 120.0);
    assert_eq!(fact(1.0, &mut m), 1.0);
    assert_eq!(fact(20.0, &mut m), 2432902008176640000.0);
    assert_eq!(m.cut, CallsCut::default());
    // Past the depth limit: NaN, counted.
    m.limits.depth = 10;
    assert_eq!(fact(10.0, &mut m), 3628800.0, "10 nested calls fit a limit of 10");
    assert!(fact(11.0, &mut m).is_nan());
    assert_eq!(m.cut, CallsCut { depth: 1, calls: 0 });
    // Past the call limit.
    m.limits = CallLimits { depth: 100, calls: 5 };
    assert!(fact(6.0, &mut m).is_nan());
    assert_eq!(m.cut, CallsCut { depth: 1, calls: 1 });
    assert_eq!(fact(5.0, &mut m), 120.0, "the count starts again with each evaluation");
}

#[test]
fn a_runaway_recursion_ends_at_the_depth_limit() {
    // f(a) = f(a + 1): no way out.
    let code = vec![
        ExprOp::Funcs(7),
        ExprOp::Enter(1),
        ExprOp::Pick(0),
        ExprOp::Push(1.0),
        ExprOp::Bin(BinOp::Add),
        ExprOp::Fn(-4),
        ExprOp::Slide(1),
        ExprOp::Ret,
        ExprOp::Push(0.0),
        ExprOp::Fn(-8),
    ];
    assert_eq!(verify(&code), Ok(()));
    let mut m = Machine::default();
    assert!(eval(&code, &[0.0; 6], &[], &mut Half, &mut m).is_nan());
    assert_eq!(m.cut.depth, 1);
}

#[test]
fn verify_refuses_malformed_function_blocks() {
    let bad = |code: &[ExprOp]| verify(code).err().map_or(String::new(), |e| e.to_string());
    let mut code = fact_code();
    // A call that does not land on a body's start.
    let n = code.len();
    code[n - 1] = ExprOp::Fn(-3);
    assert!(bad(&code).contains("no function body"), "{}", bad(&code));
    // A body that returns two values.
    let two = [ExprOp::Funcs(3), ExprOp::Enter(1), ExprOp::Push(1.0), ExprOp::Ret, ExprOp::Push(1.0), ExprOp::Fn(-4)];
    assert!(bad(&two).contains("returns 2"), "{}", bad(&two));
    // Falling into a body, a body without a return, a return in main code.
    assert!(bad(&[ExprOp::Push(1.0), ExprOp::Enter(0), ExprOp::Push(1.0), ExprOp::Ret]).contains("outside"));
    assert!(
        bad(&[ExprOp::Funcs(2), ExprOp::Enter(0), ExprOp::Push(1.0), ExprOp::Push(2.0)]).contains("without a return")
    );
    assert!(bad(&[ExprOp::Push(1.0), ExprOp::Ret]).contains("return outside"));
    // A skip out of a body into the main code.
    let out = [ExprOp::Funcs(4), ExprOp::Enter(0), ExprOp::Push(1.0), ExprOp::Skip(1), ExprOp::Ret, ExprOp::Push(1.0)];
    assert!(bad(&out).contains("leaves or enters"), "{}", bad(&out));
    // A body read below its arguments.
    let below = [
        ExprOp::Funcs(4),
        ExprOp::Enter(1),
        ExprOp::Pick(1),
        ExprOp::Slide(1),
        ExprOp::Ret,
        ExprOp::Push(1.0),
        ExprOp::Push(2.0),
        ExprOp::Fn(-6),
        ExprOp::Bin(BinOp::Add),
    ];
    assert!(bad(&below).contains("pick 1"), "{}", bad(&below));
    // Malformed code never panics in evaluation.
    for code in [&[ExprOp::Ret][..], &[ExprOp::Fn(-5)], &[ExprOp::Fn(7)], &[ExprOp::Enter(2), ExprOp::Ret]] {
        let _ = eval(code, &[0.0; 6], &[], &mut Half, &mut Machine::default());
    }
}

#[test]
fn clamp_with_a_nan_argument_is_nan() {
    let nan = f64::NAN;
    for args in [[1.0, nan, nan], [1.0, nan, 0.0], [1.0, 0.0, nan], [nan, 0.0, 1.0], [nan, nan, nan]] {
        let v = Func::Clamp.apply(&args, &mut Half);
        assert!(v.is_nan(), "clamp{args:?} = {v}");
        assert!(call("clamp", &args).is_some_and(f64::is_nan), "the folder's clamp{args:?}");
    }
}

#[test]
fn clamp_orders_its_bounds_and_takes_infinite_ones() {
    let clamp = |a: [f64; 3]| Func::Clamp.apply(&a, &mut Half);
    assert_eq!(clamp([5.0, 0.0, 1.0]), 1.0);
    assert_eq!(clamp([5.0, 1.0, 0.0]), 1.0);
    assert_eq!(clamp([-5.0, 1.0, 0.0]), 0.0);
    assert_eq!(clamp([0.25, 1.0, 0.0]), 0.25);
    assert_eq!(clamp([f64::NEG_INFINITY, 0.0, 1.0]), 0.0);
    assert_eq!(clamp([0.5, f64::NEG_INFINITY, f64::INFINITY]), 0.5);
    assert_eq!(clamp([f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY]), f64::INFINITY);
}

/// Every function of the table (so a function added later is covered) on every
/// combination of NaN, infinite, huge, tiny and plain arguments: no panic, and the
/// constant folder (`call`) gives what evaluation gives.
#[test]
fn operators_are_named_and_numbered_by_one_table() {
    assert_eq!(BinOp::ALL.len(), BINOPS.len());
    for (i, &op) in BinOp::ALL.iter().enumerate() {
        assert_eq!(op.id() as usize, i);
        assert_eq!(BinOp::from_id(op.id()), Some(op));
        assert_eq!(BinOp::from_symbol(op.symbol()), Some(op));
    }
    assert_eq!(BinOp::from_id(BINOPS.len() as u8), None);
    // The ids a bundle holds (docs/bytecode.md): `*` is 2, `||` is 12.
    assert_eq!((BinOp::Mul.id(), BinOp::Or.id()), (2, 12));
    assert_eq!(
        (BinOp::Pow.apply(2.0, 10.0), BinOp::Le.apply(1.0, 1.0), BinOp::And.apply(f64::NAN, 1.0)),
        (1024.0, 1.0, 0.0)
    );
    // Serialised as the id (the creature table's JSON), and read back.
    assert_eq!(serde_json::to_string(&BinOp::Ge).ok().as_deref(), Some("8"));
    assert_eq!(serde_json::from_str::<BinOp>("8").ok(), Some(BinOp::Ge));
    assert!(serde_json::from_str::<BinOp>("13").is_err());
}

#[test]
fn every_function_takes_non_finite_and_huge_arguments() {
    for &f in Func::ALL {
        let n = f.arity();
        let combos = HOSTILE.len().pow(n as u32);
        for k in 0..combos {
            let args: [f64; 3] = std::array::from_fn(|i| {
                if i < n {
                    HOSTILE[k / HOSTILE.len().pow(i as u32) % HOSTILE.len()]
                } else {
                    f64::NAN
                }
            });
            let v = f.apply(&args, &mut Half);
            if let Some(folded) = call(f.name(), &args[..n]) {
                assert!(folded.to_bits() == v.to_bits() || (folded.is_nan() && v.is_nan()), "{}{args:?}", f.name());
            }
        }
    }
    for &op in BinOp::ALL {
        for a in HOSTILE {
            for b in HOSTILE {
                let _ = op.apply(a, b);
            }
        }
    }
}
