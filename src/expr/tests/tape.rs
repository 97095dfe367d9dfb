//! The tape evaluated in batches against the recursive evaluator: random
//! expressions over every operation, every function on its own, integer
//! powers against `powi`, partial batches, and the vector field's values,
//! gradients and body loads.
//!
//! The contract ([`crate::expr::lanes`]): values equal bit for bit (NaN
//! included), derivatives equal as numbers (`-0 == 0`) wherever the
//! recursive evaluator's derivatives are all finite.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::parsed;
use crate::expr::dual::Dual;
use crate::expr::jet::Jet;
use crate::expr::lanes::LANES;
use crate::expr::tape::{Order, Tape, HESSIAN};
use crate::expr::{body_load_from_displacement, Expr, VectorExpr};

/// Equal values, NaN included.
fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

/// The recursive evaluator's components `0..order.components()` of `e` at
/// `x` (value, gradient, Hessian's upper triangle).
fn reference(e: &Expr, order: Order, x: [f64; 3]) -> Vec<f64> {
    let mut out = vec![e.eval(x)];
    if order >= Order::Gradient {
        let dual: Dual = e.root.eval(x);
        assert!(same(dual.value, out[0]));
        out.extend(dual.grad);
    }
    if order == Order::Hessian {
        let jet: Jet = e.root.eval(x);
        out.extend(HESSIAN.map(|(i, j)| jet.hess[i][j]));
    }
    out
}

/// Compiles `exprs` into one tape, evaluates it over `xs` at every order
/// and checks the contract against the recursive evaluator; returns how
/// many (expression, point, order) triples had finite derivatives, all of
/// whose components were compared.
fn check(exprs: &[Expr], xs: &[[f64; 3]]) -> usize {
    let tape = Tape::compile(&exprs.iter().map(|e| &e.root).collect::<Vec<_>>());
    let mut compared = 0;
    for order in [Order::Value, Order::Gradient, Order::Hessian] {
        let plan = tape.plan(order);
        let mut ws = plan.workspace();
        for batch in xs.chunks(LANES) {
            plan.run(&mut ws, batch);
            for (o, e) in exprs.iter().enumerate() {
                for (l, &x) in batch.iter().enumerate() {
                    let want = reference(e, order, x);
                    let got: Vec<f64> = (0..want.len()).map(|k| plan.lane(&ws, o, k)[l]).collect();
                    let at = || {
                        format!(
                            "{} at {x:?}, {order:?}: {got:?} against {want:?}",
                            e.source()
                        )
                    };
                    assert!(same(got[0], want[0]), "value of {}", at());
                    if want[1..].iter().all(|d| d.is_finite()) {
                        assert!(
                            got[1..].iter().zip(&want[1..]).all(|(g, w)| g == w),
                            "{}",
                            at()
                        );
                        compared += 1;
                    }
                }
            }
        }
    }
    compared
}

fn random_points(rng: &mut ChaCha8Rng, count: usize) -> Vec<[f64; 3]> {
    let mut xs: Vec<[f64; 3]> = (0..count)
        .map(|_| std::array::from_fn(|_| rng.gen_range(-2.5..2.5)))
        .collect();
    // Zeros and integers, where branches (abs, min, powers) turn.
    xs.extend([
        [0.0; 3],
        [1.0, -1.0, 2.0],
        [0.0, 1.0, -2.0],
        [-1.0, 0.0, 0.5],
    ]);
    xs
}

#[test]
fn every_operation_on_its_own() {
    let sources = [
        "sin(x*y)",
        "cos(x+z)",
        "tan(x/3)",
        "exp(x*y - z)",
        "log(x^2 + 1 + y*y)",
        "sqrt(x^2 + y^2 + 1)",
        "abs(x - y)",
        "sinh(x)",
        "cosh(y*z)",
        "tanh(x*z)",
        "atan(x*y)",
        "atan2(y, x + 3)",
        "min(x, y*z)",
        "max(x*x, y)",
        "pow(x^2 + 1, y)",
        "(x*x + 1)^(z - y)",
        "-x*y + z",
        "+x - -y",
        "pi*x/e",
        "e^x",
        "x^3 - y^2*z",
        "x^-2",
        "(x^2 + 1)^0.5",
        "(y*y + 1)^-1.5",
        "x^70",
        "x^(1 + 1) * y",
        "y^0 + z^1",
        "sqrt(0)*x",
        "2^3*x - 1/4",
        "x / (y*y + 1)",
        "1 / (x*x + 2)",
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let xs = random_points(&mut rng, 96);
    for src in sources {
        let compared = check(&[parsed(src)], &xs);
        // `sqrt(0)` has an infinite slope: its product's derivatives are NaN.
        let orders = if src.starts_with("sqrt(0)") { 1 } else { 2 };
        assert!(
            compared >= orders * xs.len(),
            "{src}: only {compared} compared"
        );
    }
}

/// Random expressions of the grammar: every function and operator, with
/// shared subexpressions likely (few leaves).
fn random_expr(rng: &mut ChaCha8Rng, depth: u32) -> String {
    const LEAVES: &[&str] = &["x", "y", "z", "2", "0.5", "pi", "e", "3"];
    const ONE: &[&str] = &[
        "sin", "cos", "tan", "exp", "log", "sqrt", "abs", "sinh", "cosh", "tanh", "atan", "-",
    ];
    const TWO: &[&str] = &["+", "-", "*", "/", "^", "atan2", "min", "max", "pow"];
    if depth == 0 || rng.gen_bool(0.2) {
        return LEAVES.choose(rng).copied().unwrap_or("x").to_string();
    }
    if rng.gen_bool(0.35) {
        let f = ONE.choose(rng).copied().unwrap_or("sin");
        return format!("{f}({})", random_expr(rng, depth - 1));
    }
    let (a, b) = (random_expr(rng, depth - 1), random_expr(rng, depth - 1));
    match TWO.choose(rng).copied().unwrap_or("+") {
        op @ ("atan2" | "min" | "max" | "pow") => format!("{op}({a}, {b})"),
        op => format!("({a}) {op} ({b})"),
    }
}

#[test]
fn random_expressions_match_the_recursive_evaluator() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let xs = random_points(&mut rng, 60);
    let mut compared = 0;
    for _ in 0..300 {
        let exprs: Vec<Expr> = (0..3).map(|_| parsed(&random_expr(&mut rng, 5))).collect();
        compared += check(&exprs, &xs);
    }
    // Most triples have finite derivatives: the comparison is not vacuous.
    assert!(compared > 300 * 3 * 64 * 3 / 2, "only {compared} compared");
}

#[test]
fn integer_powers_equal_powi() {
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let xs = random_points(&mut rng, 40);
    for n in -64..=64 {
        let e = parsed(&format!("x^({n})"));
        check(&[e], &xs);
    }
}

#[test]
fn partial_batches_and_shared_subexpressions() {
    let paper = paper_field();
    let tape = paper.tape();
    let separate: usize = paper
        .0
        .iter()
        .map(|e| {
            VectorExpr([e.clone(), parsed("0"), parsed("0")])
                .tape()
                .operations()
        })
        .sum();
    assert!(
        tape.operations() < separate,
        "{} against {separate}",
        tape.operations()
    );
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    for count in [1, LANES - 1, LANES, LANES + 1, 2 * LANES + 3] {
        let xs = random_points(&mut rng, count - 4.min(count));
        let xs = &xs[..count];
        let mut values = vec![[0.0; 3]; count];
        let mut grads = vec![[[0.0; 3]; 3]; count];
        let mut loads = vec![[0.0; 3]; count];
        tape.values(xs, &mut values);
        for (x, v) in xs.iter().zip(&values) {
            assert_eq!(*v, paper.eval(*x));
        }
        tape.values_and_gradients(xs, &mut values, &mut grads);
        for ((x, v), g) in xs.iter().zip(&values).zip(&grads) {
            assert_eq!((*v, *g), paper.value_and_gradient(*x));
        }
        tape.body_loads(LAMBDA, MU, xs, &mut loads);
        for (x, b) in xs.iter().zip(&loads) {
            assert_eq!(*b, body_load_from_displacement(&paper, LAMBDA, MU, *x));
        }
    }
}

const LAMBDA: f64 = 576.9230769230769;
const MU: f64 = 384.61538461538464;

fn paper_field() -> VectorExpr {
    VectorExpr(
        [
            "x + x^2 - 2*x*y + x^3 - 3*x*y^2 + x^2*y",
            "-y - 2*x*y - 3*x^2*y + y^3 - x*y^2",
            "0",
        ]
        .map(parsed),
    )
}
