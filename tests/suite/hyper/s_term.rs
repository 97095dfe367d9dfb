//! The S-term of the large-deformation residual (src/hyper/stabilisation.rs):
//! its residual, tangent and energy against finite differences with the
//! recovered `S` held fixed, exact recovery of fields of the fit space on
//! Ω* (also on a one-cell-thick slab), Q1 and Q2, and a twisted ring solved
//! with it in fixed-point passes.

use std::sync::Arc;

use cgfem_gpu::backend::LinearOperator;
use cgfem_gpu::cells::{cut_rule_points, Cells};
use cgfem_gpu::element::{tensor_gauss_rule, ElementOrder};
use cgfem_gpu::geometry::Geometry;
use cgfem_gpu::grid::Grid;
use cgfem_gpu::hyper::material::Material;
use cgfem_gpu::hyper::newton::{solve_load_steps, CpuTangentSolver, HyperSolution, NewtonOptions};
use cgfem_gpu::hyper::problem::{DirichletCondition, HyperProblem, Loads, Ramp};
use cgfem_gpu::hyper::residual::{energy, residual};
use cgfem_gpu::hyper::tangent::TangentOperator;
use cgfem_gpu::progress::Silent;
use cgfem_gpu::solver::{KrylovMethod, KrylovOptions, Preconditioner};
use cgfem_gpu::spatial::Aabb;

const E: f64 = 1000.0;
const NU: f64 = 0.3;
const K2: f64 = 0.01;

/// The unit sphere on a shifted grid, fixed on its surface, with Q1 elements
/// and the S-term at threshold `a`.
fn sphere(level: u32, a: f64) -> HyperProblem {
    sphere_of(ElementOrder::Q1, level, a)
}

/// [`sphere`] with elements of `order`.
fn sphere_of(order: ElementOrder, level: u32, a: f64) -> HyperProblem {
    let g = Geometry::sphere([0.0; 3], 1.0).unwrap();
    let grid = Grid::new(&Aabb::new([-1.0; 3], [1.0; 3]), level, [0.13, 0.29, 0.41]).unwrap();
    let cells = Cells::classify(&grid, &g, cut_rule_points(order)).unwrap();
    let dirichlet = [DirichletCondition {
        tag: 0,
        components: [true; 3],
        value: Arc::new(|x: [f64; 3]| [0.1 * x[0] * x[1], -0.05 * x[2], 0.08 * x[0]]),
        ramps: [Ramp::LINEAR; 3],
    }];
    let material = Material::neo_hookean(E, NU);
    let mut p = HyperProblem::new(
        &grid,
        &cells,
        order,
        material,
        30.0 * E,
        &dirichlet,
        &Loads::default(),
    )
    .unwrap();
    p.set_s_term(&cells, &g, K2, E, a);
    p
}

/// A ring (radii 0.6 and 1) one cell thick, held on its inner face, its
/// outer face turned by `angle` about z, with the S-term at threshold `a`.
fn twisted_ring(level: u32, angle: f64, k2: f64, a: f64) -> HyperProblem {
    twisted_ring_cells(level, angle, k2, a).0
}

/// [`twisted_ring`] and its cells.
fn twisted_ring_cells(level: u32, angle: f64, k2: f64, a: f64) -> (HyperProblem, Cells) {
    let g = Geometry::annulus([0.0, 0.0, -0.125], [0.0, 0.0, 0.125], 0.6, 1.0).unwrap();
    let lo_hi = Aabb::new([-1.0, -1.0, -0.125], [1.0, 1.0, 0.125]);
    let grid = Grid::new(&lo_hi, level, [0.21, 0.37, 0.0]).unwrap();
    let cells = Cells::classify(&grid, &g, cut_rule_points(ElementOrder::Q1)).unwrap();
    let (c, s) = (angle.cos(), angle.sin());
    let dirichlet = [
        DirichletCondition {
            tag: g.tag_id("inner").unwrap(),
            components: [true; 3],
            value: Arc::new(|_| [0.0; 3]),
            ramps: [Ramp::LINEAR; 3],
        },
        DirichletCondition {
            tag: g.tag_id("outer").unwrap(),
            components: [true, true, false],
            value: Arc::new(move |x: [f64; 3]| {
                [c * x[0] - s * x[1] - x[0], s * x[0] + c * x[1] - x[1], 0.0]
            }),
            ramps: [Ramp::LINEAR; 3],
        },
    ];
    let material = Material::neo_hookean(E, NU);
    let mut p = HyperProblem::new(
        &grid,
        &cells,
        ElementOrder::Q1,
        material,
        30.0 * E,
        &dirichlet,
        &Loads::default(),
    )
    .unwrap();
    p.set_s_term(&cells, &g, k2, E, a);
    (p, cells)
}

/// A complete quadratic field (every term of the fit space).
fn quadratic(x: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = x;
    [
        0.1 + 0.2 * x - 0.1 * y + 0.05 * z + 0.3 * x * x - 0.2 * x * y + 0.1 * z * z,
        -0.05 + 0.1 * y + 0.15 * x * z - 0.25 * y * y + 0.05 * y * z,
        0.02 * x + 0.3 * z + 0.1 * x * y - 0.2 * z * z + 0.05 * x * x,
    ]
}

/// A complete cubic field (the Q2 fit space's top terms and some below).
fn cubic(x: [f64; 3]) -> [f64; 3] {
    let [a, b, c] = quadratic(x);
    let [x, y, z] = x;
    [
        a + 0.2 * x * x * x - 0.1 * x * y * z + 0.05 * y * y * z,
        b - 0.15 * y * y * y + 0.1 * x * x * z,
        c + 0.1 * z * z * z - 0.2 * x * z * z + 0.1 * x * y * y,
    ]
}

/// The nodal interpolant of `f`.
fn interpolate(p: &HyperProblem, f: impl Fn([f64; 3]) -> [f64; 3]) -> Vec<f64> {
    let mut u = vec![0.0; p.ndofs()];
    for (a, &node) in p.dofs.active_to_node.iter().enumerate() {
        let v = f(p.grid.node_position(p.order(), node as usize));
        u[3 * a..3 * a + 3].copy_from_slice(&v);
    }
    u
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// `R` of `p` minus `R` of `p` without its S-term: `R_S`.
fn s_residual(p: &HyperProblem, bare: &HyperProblem, u: &[f64]) -> Vec<f64> {
    let (r, r0) = (
        residual(p, u, 1.0).unwrap(),
        residual(bare, u, 1.0).unwrap(),
    );
    r.iter().zip(&r0).map(|(a, b)| a - b).collect()
}

#[test]
fn s_residual_tangent_and_energy_match_finite_differences() {
    for (order, level, a) in [(ElementOrder::Q1, 3, 0.05), (ElementOrder::Q2, 2, 0.2)] {
        s_term_against_finite_differences(order, level, a);
    }
}

fn s_term_against_finite_differences(order: ElementOrder, level: u32, a: f64) {
    let p = sphere_of(order, level, a);
    let s = p.s_term.as_ref().unwrap();
    assert!(!s.omega_star.is_empty(), "the shifted sphere has Ω* cells");
    let mut bare = sphere_of(order, level, a);
    bare.s_term = None;
    // S from one displacement, R_S at another: S held fixed.
    let u0 = interpolate(&p, quadratic);
    assert!(p.refresh_s_term(&u0).unwrap());
    let u: Vec<f64> = u0
        .iter()
        .enumerate()
        .map(|(i, x)| 0.9 * x + 1e-3 * (i % 7) as f64)
        .collect();
    let v: Vec<f64> = (0..u.len())
        .map(|i| ((i * 37 % 11) as f64 - 5.0) / 5.0)
        .collect();
    let eps = 1e-4;
    let shifted =
        |sign: f64| -> Vec<f64> { u.iter().zip(&v).map(|(x, d)| x + sign * eps * d).collect() };
    let (rp, rm) = (
        s_residual(&p, &bare, &shifted(1.0)),
        s_residual(&p, &bare, &shifted(-1.0)),
    );
    let fd: Vec<f64> = rp
        .iter()
        .zip(&rm)
        .map(|(a, b)| (a - b) / (2.0 * eps))
        .collect();
    let (mut kv, mut kv0) = (vec![0.0; u.len()], vec![0.0; u.len()]);
    TangentOperator::new(&p, &u).unwrap().apply(&v, &mut kv);
    TangentOperator::new(&bare, &u).unwrap().apply(&v, &mut kv0);
    let ksv: Vec<f64> = kv.iter().zip(&kv0).map(|(a, b)| a - b).collect();
    assert!(norm(&ksv) > 0.0);
    let diff: Vec<f64> = fd.iter().zip(&ksv).map(|(a, b)| a - b).collect();
    // R_S is affine in u: central differences are exact up to round-off.
    assert!(
        norm(&diff) < 1e-7 * norm(&ksv),
        "{} vs {}",
        norm(&diff),
        norm(&ksv)
    );
    // The diagonal of K_S, and R_S as the gradient of Π_S.
    let (d, d0) = (
        TangentOperator::new(&p, &u).unwrap().diagonal(),
        TangentOperator::new(&bare, &u).unwrap().diagonal(),
    );
    let mut unit = vec![0.0; u.len()];
    for i in (0..u.len()).filter(|&i| d[i] != d0[i]).take(20) {
        unit[i] = 1.0;
        let (mut y, mut y0) = (vec![0.0; u.len()], vec![0.0; u.len()]);
        TangentOperator::new(&p, &u).unwrap().apply(&unit, &mut y);
        TangentOperator::new(&bare, &u)
            .unwrap()
            .apply(&unit, &mut y0);
        assert!(((d[i] - d0[i]) - (y[i] - y0[i])).abs() < 1e-9 * (d[i] - d0[i]).abs());
        unit[i] = 0.0;
    }
    // Π_S is quadratic: central differences are exact but for the round-off
    // of the two total energies, which a larger step keeps small.
    let pi_s = |w: &[f64]| energy(&p, w, 1.0).unwrap() - energy(&bare, w, 1.0).unwrap();
    let big = 1e-2;
    let at =
        |sign: f64| -> Vec<f64> { u.iter().zip(&v).map(|(x, d)| x + sign * big * d).collect() };
    let de = (pi_s(&at(1.0)) - pi_s(&at(-1.0))) / (2.0 * big);
    let rs = s_residual(&p, &bare, &u);
    let rv: f64 = rs.iter().zip(&v).map(|(a, b)| a * b).sum();
    assert!(
        (de - rv).abs() < 1e-7 * rv.abs(),
        "dΠ_S = {de}, R_S·v = {rv}"
    );
}

/// `S − f` at the 3×3×3 Gauss points of every Ω* cell (whole cells), largest.
fn recovery_error(p: &HyperProblem, f: fn([f64; 3]) -> [f64; 3]) -> f64 {
    let s = p.s_term.as_ref().unwrap();
    let rec = s.recover_of(p, |_, x| f(x)).unwrap();
    let mut worst: f64 = 0.0;
    for &c in &s.omega_star {
        let lo = p.grid.cell_box(c).lo;
        for (xi, _) in tensor_gauss_rule(3) {
            let x = [0, 1, 2].map(|a| lo[a] + p.grid.h * xi[a]);
            let (sx, fx) = (rec.eval(c, x).unwrap(), f(x));
            worst = (0..3).fold(worst, |w, i| w.max((sx[i] - fx[i]).abs()));
        }
    }
    worst
}

#[test]
fn fields_of_the_fit_space_are_recovered_exactly_on_omega_star() {
    let q2 = sphere_of(ElementOrder::Q2, 2, 0.2);
    assert!(!q2.s_term.as_ref().unwrap().omega_star.is_empty());
    let err = recovery_error(&q2, cubic);
    assert!(err < 1e-11, "Q2: |S − u| = {err:.3e} on Ω*");
    for p in [sphere(3, 0.05), twisted_ring(4, 0.2, K2, 0.05), q2] {
        let s = p.s_term.as_ref().unwrap();
        assert!(!s.omega_star.is_empty());
        let err = recovery_error(&p, quadratic);
        assert!(err < 1e-11, "|S − u| = {err:.3e} on Ω*");
        // A linear u_h is its own S: R_S(u) = M u − f = 0 on Ω* after a refresh.
        let linear = |x: [f64; 3]| [0.1 * x[0] - 0.2 * x[1], 0.3 * x[2] + 0.05, 0.1 * x[1]];
        let u = interpolate(&p, linear);
        p.refresh_s_term(&u).unwrap();
        let mut bare_targets = 0.0f64;
        for (slot, &k) in s.entries().iter().enumerate() {
            let n = p.nodes_per_cell();
            let mut buffer = [[0.0; 3]; 27];
            let ue = p.gather(k, &u, &mut buffer);
            let mut r = [[0.0; 3]; 27];
            let r = &mut r[..n];
            s.add_cell_residual(k, ue, &s.targets(), r);
            let f = &s.targets()[n * slot..n * (slot + 1)];
            let scale = f.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            bare_targets = bare_targets.max(scale);
            for v in r.iter().flatten() {
                assert!(
                    v.abs() < 1e-11 * scale.max(1.0),
                    "R_S = {v:.3e} (f ~ {scale:.3e})"
                );
            }
        }
        assert!(bare_targets > 0.0);
    }
}

#[test]
fn a_twisted_ring_with_the_s_term_converges_in_fixed_point_passes() {
    let opts = NewtonOptions {
        steps: 2,
        residual_tol: 1e-10,
        energy_tol: 1e-20,
        fixed_point_tol: 1e-8,
        krylov: KrylovOptions {
            method: KrylovMethod::Cg,
            preconditioner: Preconditioner::Jacobi,
            rel_tol: 1e-12,
            max_iterations: 20_000,
        },
        ..NewtonOptions::default()
    };
    let solve = |p: &HyperProblem| {
        let mut sol = HyperSolution::zero(p);
        solve_load_steps(
            p,
            &opts,
            &mut CpuTangentSolver::default(),
            &Silent,
            &mut sol,
        )
        .unwrap();
        sol
    };
    let (with, cells) = twisted_ring_cells(4, 0.3, K2, 0.05);
    assert!(!with.s_term.as_ref().unwrap().omega_star.is_empty());
    let without = twisted_ring(4, 0.3, 0.0, 0.05);
    let (a, b) = (solve(&with), solve(&without));
    assert_eq!(a.converged_steps, 2);
    for step in a.attempts.iter().filter(|s| s.converged) {
        assert!(step.passes.len() >= 2, "S changes after the first pass");
        let last = step.passes.last().unwrap().change.unwrap();
        assert!(last < opts.fixed_point_tol, "ε = {last:.3e}");
        // The passes' reports add up to the step's.
        let krylov: usize = step.passes.iter().map(|p| p.krylov_iterations).sum();
        assert_eq!(krylov, step.krylov_iterations.iter().sum::<usize>());
    }
    for step in &b.attempts {
        assert_eq!(step.passes.len(), 1, "no S-term: one pass per step");
    }
    // The S-term is consistent: it moves the solution in the body (at the
    // nodes of cells at least half inside) only a little.
    let mut inside = vec![false; with.ndofs()];
    let bulk = |k: usize| with.cut_index[k].is_none_or(|i| cells.fraction[i] > 0.5);
    for k in (0..with.cells.len()).filter(|&k| bulk(k)) {
        for &n in with.cell_nodes(k) {
            inside[3 * n as usize..3 * n as usize + 3].fill(true);
        }
    }
    let pick = |u: &[f64]| -> Vec<f64> {
        u.iter()
            .zip(&inside)
            .filter(|(_, &i)| i)
            .map(|(x, _)| *x)
            .collect()
    };
    let (ua, ub) = (pick(&a.u), pick(&b.u));
    let d: Vec<f64> = ua.iter().zip(&ub).map(|(x, y)| x - y).collect();
    let rel = norm(&d) / norm(&ub);
    assert!(rel < 1e-3, "with/without S differ by {rel:.3e}");
    assert!(rel > 0.0);
}
