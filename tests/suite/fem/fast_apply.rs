//! The fast apply (interior stencils + boundary gather), Q1 and Q2, against
//! the generic node-centred gather and the assembled faer matrix, on the
//! paper's sphere with and without a grid offset and with the S-term on; and
//! the Q2 multigrid solve's iteration counts.

use cgfem_gpu::backend::LinearOperator;
use cgfem_gpu::case::Case;
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::fem::operator::AssembledOperator;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn sphere(overrides: &[&str]) -> Case {
    case("cases/sphere.toml", overrides)
}

fn case(file: &str, overrides: &[&str]) -> Case {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    Case::from_file_with(&path, &overrides).unwrap()
}

/// `max |a − b| / max |b|`.
fn relative_difference(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    diff / scale
}

/// Checks the fast apply on seeded random vectors; returns the setup.
fn check(name: &str, case: &Case, level: u32, seed: u64) -> Setup {
    let setup = Setup::new(case, Some(level)).unwrap();
    let op = &setup.op;
    let n = op.nrows();
    let plan = op.fast_apply();
    assert!(plan.num_interior() > 0, "{name}: no interior node");
    assert!(plan.num_interior() < n / 3, "{name}: no boundary node");
    let assembled = AssembledOperator(op.assemble());
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for _ in 0..2 {
        let x: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let (mut fast, mut gather, mut csc) = (vec![f64::NAN; n], vec![0.0; n], vec![0.0; n]);
        op.apply(&x, &mut fast);
        op.apply_gather(&x, &mut gather);
        assembled.apply(&x, &mut csc);
        let d_gather = relative_difference(&fast, &gather);
        let d_csc = relative_difference(&fast, &csc);
        assert!(
            d_gather < 1e-13,
            "{name} level {level}: vs gather {d_gather:e}"
        );
        assert!(
            d_csc < 1e-13,
            "{name} level {level}: vs assembled {d_csc:e}"
        );
    }
    setup
}

#[test]
fn fast_apply_matches_gather_and_assembled_on_the_sphere() {
    for level in [3, 4] {
        check("sphere", &sphere(&[]), level, 11 + level as u64);
        let shifted = sphere(&["grid.offset=[0.31, 0.77, 0.12]"]);
        check("shifted sphere", &shifted, level, 21 + level as u64);
    }
}

#[test]
fn fast_apply_matches_on_long_runs_with_two_threads() {
    // Level 5: runs of interior nodes span several 12-node tiles and their
    // 4-node tails; two threads split the cell products and the chunks.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    pool.install(|| check("sphere", &sphere(&[]), 5, 31));
}

#[test]
fn fast_apply_reads_cut_matrices_changed_after_construction() {
    // The S-term is added to the pathological cut cells after the plan exists.
    let case = sphere(&[
        "stabilisation.k2=0.01",
        "stabilisation.A=0.1",
        "grid.offset=[0.45, 0.1, 0.6]",
    ]);
    let setup = check("sphere with S-term", &case, 4, 5);
    assert!(!setup.omega_star.is_empty(), "no pathological cell to test");
    assert!(setup.s_factor > 0.0);
}

#[test]
fn fast_apply_reuses_its_scratch_and_allows_concurrent_applies() {
    let setup = Setup::new(&sphere(&[]), Some(3)).unwrap();
    let op = &setup.op;
    let n = op.nrows();
    let x: Vec<f64> = (0..n)
        .map(|i| ((i * 7919) % 1000) as f64 / 1000.0)
        .collect();
    let mut expected = vec![0.0; n];
    op.apply_gather(&x, &mut expected);
    let results: Vec<Vec<f64>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..3)
            .map(|_| {
                s.spawn(|| {
                    let mut y = vec![0.0; n];
                    for _ in 0..4 {
                        op.apply(&x, &mut y);
                    }
                    y
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for y in &results {
        assert!(relative_difference(y, &expected) < 1e-12);
    }
    // A clone (fresh scratch) applies the same operator.
    let mut y = vec![0.0; n];
    op.clone().apply(&x, &mut y);
    assert!(relative_difference(&y, &expected) < 1e-12);
}

#[test]
fn fast_q2_apply_matches_gather_and_assembled_on_the_sphere() {
    // The case's Dirichlet penalty on the whole surface and S-term (k2 = 0.01,
    // A = 0.2) are on; level 3 with a grid offset, level 4 (halves of runs
    // longer than a 12-node tile) at two threads.
    for (level, threads) in [(3, 1), (4, 2)] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let name = format!("sphere_q2 at {threads} threads");
            let offset = ["grid.offset=[0.31, 0.77, 0.12]"];
            let overrides: &[&str] = if level == 3 { &offset } else { &[] };
            let setup = check(&name, &case("cases/sphere_q2.toml", overrides), level, 41);
            assert!(!setup.omega_star.is_empty(), "no S-term");
        });
    }
}

/// CG + multigrid on the Q2 sphere at level 3 (the fast apply on the Q2
/// level, its smoother and residual), three fixed-point iterations with
/// inner solves to 1e-3: the iteration counts the generic gather gave.
#[test]
fn q2_multigrid_iterations_are_unchanged() {
    use cgfem_gpu::driver::fixed_point::FixedPointReport;
    use cgfem_gpu::driver::solve::solve;
    let case = case(
        "cases/sphere_q2.toml",
        &[
            "solver.preconditioner=\"multigrid\"",
            "solver.fixed_point_tol=1e-4",
            "solver.inner_rel_tol=1e-3",
        ],
    );
    let setup = Setup::new(&case, Some(3)).unwrap();
    assert!(setup.multigrid.is_some());
    let mut report = FixedPointReport::default();
    solve(&setup, &case.spec.solver, &mut report).unwrap();
    assert_eq!(
        (report.iterations, report.total_iterations),
        (3, 10),
        "fixed-point and CG iterations"
    );
}
