//! The nonlinear solves: uniaxial stretch of a grid-aligned box against the
//! closed-form neo-Hookean and St Venant–Kirchhoff stresses, quadratic
//! convergence of Newton on a twisted ring, and step cutting.

use std::sync::Arc;

use cgfem_gpu::cells::{cut_rule_points, Cells};
use cgfem_gpu::element::ElementOrder;
use cgfem_gpu::error::Error;
use cgfem_gpu::geometry::Geometry;
use cgfem_gpu::grid::Grid;
use cgfem_gpu::hyper::material::{Material, MaterialModel};
use cgfem_gpu::hyper::newton::{solve_load_steps, CpuTangentSolver, HyperSolution, NewtonOptions};
use cgfem_gpu::hyper::problem::{DirichletCondition, HyperProblem, Loads, Ramp, VectorField};
use cgfem_gpu::hyper::residual::{point_fields, residual};
use cgfem_gpu::progress::{Event, Progress, Silent};
use cgfem_gpu::solver::{KrylovMethod, KrylovOptions, Preconditioner};
use cgfem_gpu::spatial::Aabb;

use super::{BETA, E, NU};

const LENGTH: f64 = 2.0;

fn zero() -> VectorField {
    Arc::new(|_| [0.0; 3])
}

/// Rollers on the three min faces, `u_x = δ` on `xmax`: the box
/// `[0, 2] × [0, 1]²` stretched along x with free lateral faces.
fn stretched_box(material: Material, level: u32, delta: f64, beta: f64) -> HyperProblem {
    let hi = [LENGTH, 1.0, 1.0];
    let g = Geometry::cuboid([0.0; 3], hi).unwrap();
    let grid = Grid::new(&Aabb::new([0.0; 3], hi), level, [0.0; 3]).unwrap();
    let cells = Cells::classify(&grid, &g, cut_rule_points(ElementOrder::Q1)).unwrap();
    let roller = |name: &str, axis: usize, value: VectorField| {
        let mut components = [false; 3];
        components[axis] = true;
        DirichletCondition {
            tag: g.tag_id(name).unwrap(),
            components,
            value,
            ramps: [Ramp::LINEAR; 3],
        }
    };
    let dirichlet = [
        roller("xmin", 0, zero()),
        roller("ymin", 1, zero()),
        roller("zmin", 2, zero()),
        roller("xmax", 0, Arc::new(move |_| [delta, 0.0, 0.0])),
    ];
    HyperProblem::new(
        &grid,
        &cells,
        ElementOrder::Q1,
        material,
        beta,
        &dirichlet,
        &Loads::default(),
    )
    .unwrap()
}

fn options(steps: usize) -> NewtonOptions {
    NewtonOptions {
        steps,
        residual_tol: 1e-10,
        energy_tol: 1e-20,
        krylov: KrylovOptions {
            method: KrylovMethod::Cg,
            preconditioner: Preconditioner::Jacobi,
            rel_tol: 1e-12,
            max_iterations: 20_000,
        },
        ..NewtonOptions::default()
    }
}

fn run(p: &HyperProblem, opts: &NewtonOptions) -> (HyperSolution, Result<(), Error>) {
    let mut solution = HyperSolution::zero(p);
    let r = solve_load_steps(
        p,
        opts,
        &mut CpuTangentSolver::default(),
        &Silent,
        &mut solution,
    );
    (solution, r)
}

/// Lateral stretch `λ2` and `P11` of a homogeneous uniaxial stress state with
/// axial stretch `l1` (`F = diag(l1, λ2, λ2)`, `P22 = P33 = 0`).
fn uniaxial(m: &Material, l1: f64) -> (f64, f64) {
    match m.model {
        MaterialModel::NeoHookean => {
            // λ2 P22 = μ (λ2² − 1) + λ ln(l1 λ2²) = 0, increasing in λ2: bisection.
            let f = |l2: f64| m.mu * (l2 * l2 - 1.0) + m.lambda * (l1 * l2 * l2).ln();
            let (mut a, mut b) = (1e-3, 2.0);
            for _ in 0..200 {
                let c = 0.5 * (a + b);
                if f(c) > 0.0 {
                    b = c;
                } else {
                    a = c;
                }
            }
            let l2 = 0.5 * (a + b);
            let ln_j = (l1 * l2 * l2).ln();
            (l2, m.mu * (l1 - 1.0 / l1) + m.lambda * ln_j / l1)
        }
        MaterialModel::StVenantKirchhoff => {
            // S22 = 0 gives E22 = −ν E11; then S11 = E_young E11, P11 = l1 S11.
            let e11 = 0.5 * (l1 * l1 - 1.0);
            let e22 = -NU * e11;
            ((1.0 + 2.0 * e22).sqrt(), l1 * E * e11)
        }
        MaterialModel::Linear => {
            // ε11 = l1 − 1, ε22 = −ν ε11, P11 = σ11 = E ε11.
            let e11 = l1 - 1.0;
            (1.0 - NU * e11, E * e11)
        }
    }
}

#[test]
fn uniaxial_stretch_matches_the_closed_form() {
    for material in [
        Material::neo_hookean(E, NU),
        Material::st_venant_kirchhoff(E, NU),
        Material::linear(E, NU),
    ] {
        let p = stretched_box(material, 2, 0.5 * LENGTH, BETA);
        let (sol, r) = run(&p, &options(4));
        r.unwrap();
        let fields = point_fields(&p, &sol.u).unwrap();
        // The penalty lets the faces lag: measure the axial stretch.
        let l1 = fields[0][0].0[(0, 0)];
        let (l2, p11) = uniaxial(&material, l1);
        println!(
            "{:?}: λ1 = {l1:.6}, λ2 = {l2:.6}, P11 = {p11:.6}",
            material.model
        );
        assert!(l1 > 1.45 && l1 < 1.5, "stretch {l1}");
        let mut worst = 0.0f64;
        for (f, stress) in fields.iter().flatten() {
            for i in 0..3 {
                for j in 0..3 {
                    let f_exact = [l1, l2, l2][i] * if i == j { 1.0 } else { 0.0 };
                    let p_exact = if (i, j) == (0, 0) { p11 } else { 0.0 };
                    worst = worst.max((f[(i, j)] - f_exact).abs() / l1);
                    worst = worst.max((stress[(i, j)] - p_exact).abs() / p11);
                }
            }
        }
        println!(
            "{:?}: max relative error of F and P at the points {worst:.1e}",
            material.model
        );
        assert!(worst < 1e-6, "{:?}: {worst:e}", material.model);
        // The reaction on xmax: the internal forces of its nodes, ∫ P11 dA.
        let free = stretched_box(material, 2, 0.0, 0.0);
        let internal = residual(&free, &sol.u, 0.0).unwrap();
        let reaction: f64 = (0..p.dofs.num_active())
            .filter(|&a| {
                let node = p.dofs.active_to_node[a] as usize;
                (p.grid.node_position(ElementOrder::Q1, node)[0] - LENGTH).abs() < 1e-12
            })
            .map(|a| internal[3 * a])
            .sum();
        let err = (reaction - p11).abs() / p11;
        println!(
            "{:?}: reaction {reaction:.9} vs P11 A = {p11:.9}: {err:.1e}",
            material.model
        );
        assert!(
            err < 1e-6,
            "{:?}: reaction {reaction} vs {p11}",
            material.model
        );
    }
}

/// A ring (inner radius 0.6, outer 1, thickness 0.25) held on its inner
/// face, its outer face turned by `angle` about z: a large shear.
fn twisted_ring(level: u32, angle: f64) -> HyperProblem {
    let g = Geometry::annulus([0.0, 0.0, -0.125], [0.0, 0.0, 0.125], 0.6, 1.0).unwrap();
    let grid = Grid::new(
        &Aabb::new([-1.0, -1.0, -0.125], [1.0, 1.0, 0.125]),
        level,
        [0.21, 0.37, 0.0],
    )
    .unwrap();
    let cells = Cells::classify(&grid, &g, cut_rule_points(ElementOrder::Q1)).unwrap();
    let (c, s) = (angle.cos(), angle.sin());
    let dirichlet = [
        DirichletCondition {
            tag: g.tag_id("inner").unwrap(),
            components: [true; 3],
            value: zero(),
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
    HyperProblem::new(
        &grid,
        &cells,
        ElementOrder::Q1,
        material,
        BETA,
        &dirichlet,
        &Loads::default(),
    )
    .unwrap()
}

/// The convergence order `log(r₂/r₁) / log(r₁/r₀)` of consecutive residuals.
fn order(r: &[f64]) -> f64 {
    (r[2] / r[1]).ln() / (r[1] / r[0]).ln()
}

#[test]
fn newton_converges_quadratically() {
    let p = twisted_ring(4, 0.35);
    for method in [KrylovMethod::Cg, KrylovMethod::BiCgStab] {
        let mut opts = options(3);
        opts.krylov.method = method;
        let (sol, r) = run(&p, &opts);
        r.unwrap();
        assert_eq!(sol.converged_steps, 3);
        println!(
            "{method}: {} Newton iterations, {} Krylov iterations",
            sol.newton_iterations(),
            sol.krylov_iterations()
        );
        assert_quadratic(&sol);
    }
}

fn assert_quadratic(sol: &HyperSolution) {
    for (k, step) in sol.attempts.iter().enumerate() {
        println!(
            "step {k}: residuals {}, Krylov iterations {:?}",
            Sci(&step.residuals),
            step.krylov_iterations
        );
        assert!(step.converged && step.alphas.iter().all(|&a| a == 1.0));
        // The residuals above round-off and below 1e-2: r_{k+1} ≤ C r_k²
        // with a moderate C, and an observed order near 2.
        let r: Vec<f64> = step
            .residuals
            .iter()
            .copied()
            .filter(|&v| v > 1e-14 && v < 1e-2)
            .collect();
        assert!(r.len() >= 3, "step {k}: too few iterations to see the rate");
        for w in r.windows(2) {
            assert!(
                w[1] <= 50.0 * w[0] * w[0],
                "step {k}: {w:?} is not quadratic"
            );
        }
        let best = r.windows(3).map(order).fold(0.0, f64::max);
        println!("step {k}: observed order {best:.2}");
        assert!(best > 1.75, "step {k}: order {best}");
    }
}

/// A 150% stretch in one step of at most five Newton iterations.
fn hard_single_step(max_cuts: usize) -> (HyperProblem, NewtonOptions) {
    let p = stretched_box(Material::neo_hookean(E, NU), 2, 1.5 * LENGTH, BETA);
    let opts = NewtonOptions {
        max_iterations: 5,
        max_cuts,
        ..options(1)
    };
    (p, opts)
}

#[test]
fn a_failed_step_is_cut_until_it_converges() {
    let (p, opts) = hard_single_step(5);
    let (sol, r) = run(&p, &opts);
    for (k, a) in sol.attempts.iter().enumerate() {
        println!(
            "attempt {k}: {:.4} → {:.4}, cuts {}, converged {}, residuals {}, {:?}",
            a.from,
            a.to,
            a.cuts,
            a.converged,
            Sci(&a.residuals),
            a.failure
        );
    }
    r.unwrap();
    assert!(!sol.attempts[0].converged && sol.attempts[0].failure.is_some());
    assert!(sol.attempts.iter().any(|a| a.cuts > 0 && a.converged));
    // A converged step short of the load that failed keeps the cut increment
    // (it does not aim at the failed load again at once).
    let mut failed_at: Option<f64> = None;
    for w in sol.attempts.windows(2) {
        let (prev, next) = (&w[0], &w[1]);
        if !prev.converged {
            failed_at = Some(prev.to);
            continue;
        }
        if failed_at.is_some_and(|f| prev.to < f - 1e-12) {
            let kept = (next.to - next.from) - (prev.to - prev.from);
            assert!(
                kept.abs() < 1e-12 || next.to == 1.0,
                "{prev:?} then {next:?}"
            );
        } else {
            failed_at = None;
        }
    }
    assert_eq!(sol.load_factor, 1.0);
    // The same equilibrium as a smooth run in 8 steps.
    let (reference, r) = run(&p, &options(8));
    r.unwrap();
    let d = sol
        .u
        .iter()
        .zip(&reference.u)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    let scale = reference.u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    println!("cut run vs 8 steps: max |Δu| / max |u| = {:.1e}", d / scale);
    assert!(d < 1e-8 * scale, "{d:e}");
}

#[test]
fn a_step_that_fails_after_every_cut_is_a_typed_error() {
    let (p, opts) = hard_single_step(0);
    let (sol, r) = run(&p, &opts);
    let e = r.unwrap_err();
    println!("{e}");
    assert_eq!(e.exit_code(), 3);
    match e {
        Error::LoadStepFailed {
            step,
            cuts,
            last_converged_step,
            last_converged_load,
            ..
        } => {
            assert_eq!((step, cuts, last_converged_step), (1, 0, 0));
            assert_eq!(last_converged_load, 0.0);
        }
        other => panic!("expected LoadStepFailed, got {other:?}"),
    }
    // The solution holds the last converged state: the undeformed start.
    assert_eq!(sol.load_factor, 0.0);
    assert!(sol.u.iter().all(|&v| v == 0.0));
    // Stopped by the observer (Ctrl-C): the undeformed start is kept.
    let (sol, r) = {
        let mut solution = HyperSolution::zero(&p);
        let r = solve_load_steps(
            &p,
            &options(2),
            &mut CpuTangentSolver::default(),
            &Stop,
            &mut solution,
        );
        (solution, r)
    };
    assert_eq!(r.unwrap_err().exit_code(), 130);
    assert_eq!(sol.converged_steps, 0);
    // Zero steps is bad input.
    let zero_steps = NewtonOptions {
        steps: 0,
        ..options(1)
    };
    let e = run(&p, &zero_steps).1.unwrap_err();
    assert_eq!(e.exit_code(), 2, "{e}");
}

/// An observer that stops the run at once.
struct Stop;

impl Progress for Stop {
    fn event(&self, _: &Event) {}
    fn should_stop(&self) -> bool {
        true
    }
}

/// Residual histories printed in scientific notation.
struct Sci<'a>(&'a [f64]);

impl std::fmt::Display for Sci<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let items: Vec<String> = self.0.iter().map(|v| format!("{v:.2e}")).collect();
        write!(f, "[{}]", items.join(", "))
    }
}
