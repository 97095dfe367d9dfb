//! The fixed point on recovered terms around Newton (`refresh_recovered`), on
//! a small algebraic problem whose coupled solution is known to round-off:
//! `R_i(u) = u_i + u_i³ − c s_i − t f_i` with `s = P u` (a cyclic average of
//! the neighbours) recovered at each pass and held fixed in `R` and `K_T`.

use std::sync::Mutex;

use cgfem_gpu::backend::LinearOperator;
use cgfem_gpu::case::physics::RecoveryMode;
use cgfem_gpu::error::Result;
use cgfem_gpu::hyper::newton::{
    solve_load_steps, CpuTangentSolver, HyperSolution, NewtonOptions, NonlinearProblem,
};
use cgfem_gpu::progress::Silent;
use cgfem_gpu::solver::{KrylovMethod, KrylovOptions, Preconditioner};

const N: usize = 16;
const C: f64 = 0.4;

struct Cubic {
    f: Vec<f64>,
    /// The recovered `s`, `None` for the problem without recovered terms.
    recovered: Option<Mutex<Vec<f64>>>,
}

/// `(P u)_i = (u_{i−1} + u_{i+1}) / 2`, cyclic.
fn average(u: &[f64]) -> Vec<f64> {
    (0..N)
        .map(|i| 0.5 * (u[(i + N - 1) % N] + u[(i + 1) % N]))
        .collect()
}

struct Diagonal(Vec<f64>);

impl LinearOperator for Diagonal {
    fn nrows(&self) -> usize {
        self.0.len()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        y.iter_mut()
            .zip(x.iter().zip(&self.0))
            .for_each(|(y, (x, d))| *y = d * x);
    }
    fn diagonal(&self) -> Vec<f64> {
        self.0.clone()
    }
}

impl NonlinearProblem for Cubic {
    fn ndofs(&self) -> usize {
        N
    }
    fn residual(&self, u: &[f64], t: f64) -> Option<Vec<f64>> {
        let s = self
            .recovered
            .as_ref()
            .map_or_else(|| vec![0.0; N], |s| s.lock().unwrap().clone());
        Some(
            (0..N)
                .map(|i| u[i] + u[i].powi(3) - C * s[i] - t * self.f[i])
                .collect(),
        )
    }
    fn tangent<'a>(&'a self, u: &[f64], _t: f64) -> Option<Box<dyn LinearOperator + 'a>> {
        Some(Box::new(Diagonal(
            u.iter().map(|x| 1.0 + 3.0 * x * x).collect(),
        )))
    }
    fn refresh_recovered(&self, u: &[f64], _t: f64) -> Result<bool> {
        match &self.recovered {
            Some(s) => {
                *s.lock().unwrap() = average(u);
                Ok(true)
            }
            None => Ok(false),
        }
    }
}

fn options() -> NewtonOptions {
    NewtonOptions {
        steps: 2,
        residual_tol: 1e-12,
        energy_tol: 1e-24,
        fixed_point_tol: 1e-10,
        krylov: KrylovOptions {
            method: KrylovMethod::Cg,
            preconditioner: Preconditioner::Jacobi,
            rel_tol: 1e-14,
            max_iterations: 100,
        },
        ..NewtonOptions::default()
    }
}

fn solve_with(problem: &Cubic, opts: &NewtonOptions) -> HyperSolution {
    let mut sol = HyperSolution::zero(problem);
    solve_load_steps(
        problem,
        opts,
        &mut CpuTangentSolver::default(),
        &Silent,
        &mut sol,
    )
    .unwrap();
    sol
}

fn solve(problem: &Cubic) -> HyperSolution {
    solve_with(problem, &options())
}

/// `max_i |u_i + u_i³ − C (P u)_i − f_i|` at `u`.
fn coupled_residual(problem: &Cubic, u: &[f64]) -> f64 {
    let s = average(u);
    (0..N)
        .map(|i| (u[i] + u[i].powi(3) - C * s[i] - problem.f[i]).abs())
        .fold(0.0, f64::max)
}

fn loads() -> Vec<f64> {
    (0..N).map(|i| 1.0 + (i as f64).sin()).collect()
}

#[test]
fn recovered_terms_converge_to_the_coupled_solution_in_passes() {
    let problem = Cubic {
        f: loads(),
        recovered: Some(Mutex::new(vec![0.0; N])),
    };
    let sol = solve(&problem);
    // The coupled equation u + u³ − C P u = f at t = 1, with P u of the solution.
    let coupled = coupled_residual(&problem, &sol.u);
    println!("coupled residual {coupled:.3e}");
    assert!(coupled < 1e-9, "{coupled}");
    for step in &sol.attempts {
        let passes = &step.passes;
        println!(
            "step to {}: {} passes, ε = {:?}",
            step.to,
            passes.len(),
            passes.iter().map(|p| p.change.unwrap()).collect::<Vec<_>>()
        );
        // A contraction of rate about C: several passes, ε falling each time.
        assert!(passes.len() >= 5, "{}", passes.len());
        let eps: Vec<f64> = passes.iter().map(|p| p.change.unwrap()).collect();
        assert!(eps.windows(2).all(|w| w[1] < w[0]), "{eps:?}");
        assert!(*eps.last().unwrap() < 1e-10);
        // The passes' histories are the step's, concatenated.
        let newton: usize = passes.iter().map(|p| p.newton_iterations).sum();
        let krylov: usize = passes.iter().map(|p| p.krylov_iterations).sum();
        assert_eq!(newton, step.alphas.len());
        assert_eq!(krylov, step.krylov_iterations.iter().sum::<usize>());
    }
}

#[test]
fn without_recovered_terms_a_step_is_one_newton_pass() {
    let problem = Cubic {
        f: loads(),
        recovered: None,
    };
    let sol = solve(&problem);
    for step in &sol.attempts {
        assert_eq!(step.passes.len(), 1);
        assert_eq!(step.passes[0].change, None);
        assert_eq!(step.passes[0].newton_iterations, step.alphas.len());
    }
    let worst = (0..N)
        .map(|i| (sol.u[i] + sol.u[i].powi(3) - problem.f[i]).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-11, "{worst}");
}

#[test]
fn embedded_recovery_reaches_the_same_fixed_point_in_one_newton_loop() {
    let problem = Cubic {
        f: loads(),
        recovered: Some(Mutex::new(vec![0.0; N])),
    };
    let opts = NewtonOptions {
        recovery: RecoveryMode::Embedded,
        max_iterations: 200,
        ..options()
    };
    let embedded = solve_with(&problem, &opts);
    let passes = solve(&Cubic {
        f: loads(),
        recovered: Some(Mutex::new(vec![0.0; N])),
    });
    let coupled = coupled_residual(&problem, &embedded.u);
    println!(
        "embedded: coupled residual {coupled:.3e}, {} Newton iterations against {} in passes",
        embedded.newton_iterations(),
        passes.newton_iterations()
    );
    assert!(coupled < 1e-9, "{coupled}");
    for step in &embedded.attempts {
        assert_eq!(step.passes.len(), 1);
        assert_eq!(step.passes[0].newton_iterations, step.alphas.len());
    }
    let diff = embedded
        .u
        .iter()
        .zip(&passes.u)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(diff < 1e-9, "{diff}");
}

#[test]
fn step_recovery_holds_the_terms_of_the_step_start() {
    // One load step from u = 0: the terms recovered there (s = P 0 = 0) are
    // held, so the solution is the one without recovered terms.
    let opts = NewtonOptions {
        steps: 1,
        recovery: RecoveryMode::Step,
        ..options()
    };
    let held = solve_with(
        &Cubic {
            f: loads(),
            recovered: Some(Mutex::new(vec![0.0; N])),
        },
        &opts,
    );
    let plain = solve_with(
        &Cubic {
            f: loads(),
            recovered: None,
        },
        &opts,
    );
    let step = &held.attempts[0];
    assert_eq!(step.passes.len(), 1);
    assert!(step.passes[0].change.is_some());
    let diff = held
        .u
        .iter()
        .zip(&plain.u)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(diff < 1e-12, "{diff}");
}
