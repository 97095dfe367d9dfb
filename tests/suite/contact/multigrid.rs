//! The bodies' multigrid preconditioner against Jacobi on
//! the two annuli of `cases/annuli_contact.toml` at level 4, BiCGStab: the
//! same converged answer (the contact force of every load step and the
//! clamp reactions to 1e-8 relative, the same Newton iterations per step)
//! with at least 5× fewer accumulated Krylov iterations.

use cgfem_gpu::bodies::run::run;
use cgfem_gpu::case::Case;
use cgfem_gpu::progress::Silent;
use cgfem_gpu::report::Report;

const CASE: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/cases/annuli_contact.toml"
));

/// The annuli at level 4 with `preconditioner`: the report and the
/// accumulated Krylov iterations. Every linear solve is converged to
/// `solver.rel_tol` (`newton.forcing = "fixed"`), so that the two
/// preconditioners solve the same systems to the same tolerance (the
/// adaptive tolerances follow each run's own residuals).
fn annuli(preconditioner: &str) -> (Report, usize) {
    let set = [
        format!("solver.preconditioner=\"{preconditioner}\""),
        "newton.forcing=\"fixed\"".to_string(),
    ];
    let case = Case::from_str_with("cases/annuli_contact.toml", CASE, &set).unwrap();
    let out = run(&case, Some(4), None, &Silent).unwrap();
    if let Err(e) = &out.result {
        panic!("{preconditioner}: {e}");
    }
    (out.report, out.solution.krylov_iterations())
}

fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= 1e-8 * scale
}

#[test]
fn multigrid_gives_jacobis_answer_with_5x_fewer_iterations() {
    let (jacobi, jacobi_its) = annuli("jacobi");
    let (multigrid, multigrid_its) = annuli("multigrid");
    assert_eq!(jacobi.contact.len(), 5);
    assert_eq!(multigrid.contact.len(), 5);
    for (j, m) in jacobi.contact.iter().zip(&multigrid.contact) {
        let scale = j.normal_force.abs();
        assert!(
            close(j.normal_force, m.normal_force, scale),
            "step {}: contact force {} (Jacobi) against {} (multigrid)",
            j.step,
            j.normal_force,
            m.normal_force
        );
    }
    assert_eq!(jacobi.reactions.len(), multigrid.reactions.len());
    for (j, m) in jacobi.reactions.iter().zip(&multigrid.reactions) {
        let scale = j.force.iter().map(|f| f.abs()).fold(0.0, f64::max);
        for c in 0..3 {
            assert!(
                close(j.force[c], m.force[c], scale),
                "step {} body {}: reaction {:?} against {:?}",
                j.step,
                j.body,
                j.force,
                m.force
            );
        }
    }
    let newton =
        |r: &Report| -> Vec<usize> { r.load_steps().iter().map(|s| s.newton.iterations).collect() };
    assert_eq!(newton(&jacobi), newton(&multigrid));
    assert!(
        5 * multigrid_its <= jacobi_its,
        "Krylov iterations: multigrid {multigrid_its}, Jacobi {jacobi_its}"
    );
    assert!(multigrid.timings.contains_key("multigrid"));
}
