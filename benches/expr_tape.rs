//! Nanoseconds per point of the paper's exact displacement field (the sphere
//! of `cases/sphere.toml`): its `u_x` alone and the whole vector field, value
//! and gradient (first order) and value, gradient and Hessian (second order;
//! for the field, the body load), evaluated point by point by the recursive
//! evaluator and in batches by the compiled tape.
//!
//! `cargo bench --bench expr_tape`.

use std::time::Instant;

use cgfem_gpu::expr::{body_load_from_displacement, Expr, VectorExpr};

const POINTS: usize = 1 << 18;
const REPS: usize = 5;

/// Best of [`REPS`] timings of `f`, in nanoseconds per point.
fn ns_per_point<T>(mut f: impl FnMut() -> T) -> f64 {
    let best = (0..REPS)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(f());
            t.elapsed().as_secs_f64()
        })
        .fold(f64::MAX, f64::min);
    best * 1e9 / POINTS as f64
}

fn field(components: [&str; 3]) -> VectorExpr {
    VectorExpr(components.map(|s| Expr::parse(s).expect("the paper's field parses")))
}

fn main() {
    let ux = "x + x^2 - 2*x*y + x^3 - 3*x*y^2 + x^2*y";
    let uy = "-y - 2*x*y - 3*x^2*y + y^3 - x*y^2";
    let (lambda, mu) = (576.9230769230769, 384.61538461538464);
    let xs: Vec<[f64; 3]> = (0..POINTS)
        .map(|i| {
            let t = i as f64 / POINTS as f64;
            [t - 0.5, (7.0 * t).sin(), (3.0 * t).cos()]
        })
        .collect();
    let mut values = vec![[0.0; 3]; POINTS];
    let mut grads = vec![[[0.0; 3]; 3]; POINTS];
    println!(
        "{:<28} {:>12} {:>12} {:>8}",
        "ns per point", "recursive", "tape", "ratio"
    );
    for (name, u) in [
        ("u_x", field([ux, "0", "0"])),
        ("u (paper)", field([ux, uy, "0"])),
    ] {
        let tape = u.tape();
        let row = |what: &str, recursive: f64, batched: f64| {
            let label = format!("{name}, {what}");
            println!(
                "{label:<28} {recursive:>12.1} {batched:>12.1} {:>8.1}",
                recursive / batched
            );
        };
        let recursive = ns_per_point(|| {
            xs.iter()
                .map(|&x| u.value_and_gradient(x).1[0][0])
                .sum::<f64>()
        });
        let batched = ns_per_point(|| tape.values_and_gradients(&xs, &mut values, &mut grads));
        row("value+gradient", recursive, batched);
        let recursive = ns_per_point(|| {
            xs.iter()
                .map(|&x| body_load_from_displacement(&u, lambda, mu, x)[0])
                .sum::<f64>()
        });
        let batched = ns_per_point(|| tape.body_loads(lambda, mu, &xs, &mut values));
        row("Hessian (body load)", recursive, batched);
    }
}
