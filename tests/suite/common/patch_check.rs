//! What the patch tests share (`tests/suite/fem/patch_exact.rs`,
//! `tests/suite/fem/boundary_conditions.rs`, `tests/suite/runs/surface_output.rs`): tight solver
//! settings, the residual of the exact field's interpolant in the discrete
//! system, the energy error.
#![allow(dead_code)] // each test crate uses a part

use cgfem_gpu::backend::LinearOperator;
use cgfem_gpu::discrete::field::{error_norms, interpolate};
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::driver::solve::RecoveredLoad;

/// Tight solves, so that what is left is the discretisation's: the outer
/// FGMRES to a residual of 1e-14 (at 1e-13 the rotated bracket kept 2e-10 of
/// solver error in the energy; at 2e-14 the rotated STL plate kept 1.1e-10).
pub const SOLVER: &str = r#"
[solver]
method = "cg"
preconditioner = "jacobi"
rel_tol = 1e-12
min_rel_tol = 1e-14
max_iterations = 50000
fixed_point_tol = 1e-14
max_fixed_point = 500
"#;

/// `‖A U_I − F(U_I)‖ / ‖F(U_I)‖` for the interpolant `U_I` of the exact
/// field, `F = fixed_rhs + recovered_load`: the patch test without a solver.
pub fn interpolant_residual(setup: &Setup) -> f64 {
    let exact = setup.problem.exact.as_ref().unwrap();
    let ui = interpolate(&setup.grid, &setup.op.dofs, exact);
    let mut f = RecoveredLoad::new(setup).at(&ui).unwrap();
    for (a, b) in f.iter_mut().zip(&setup.fixed_rhs) {
        *a += b;
    }
    let mut au = vec![0.0; ui.len()];
    setup.op.apply(&ui, &mut au);
    let r: Vec<f64> = au.iter().zip(&f).map(|(a, b)| a - b).collect();
    norm(&r) / norm(&f)
}

/// The relative energy error of `u` against the exact field of `setup`.
pub fn energy_error(setup: &Setup, u: &[f64]) -> f64 {
    error_norms(
        &setup.grid,
        &setup.cells,
        &setup.op.dofs,
        u,
        setup.problem.exact.as_ref().unwrap(),
        setup.problem.lambda,
        setup.problem.mu,
    )
    .energy_relative
}

/// The Euclidean norm.
pub fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}
