//! `reproduce::table2` at level 3 only (the default levels 3–5 are minutes),
//! CGS with Jacobi and with the bodies' multigrid: every run converges, the rows add up to their load-step histories, the
//! S-term run has Ω* cells, each attempt is one Newton loop with its
//! recovered terms evaluated at its start (step recovery), and the files are
//! written; multigrid needs fewer Krylov iterations than Jacobi.

use cgfem_gpu::case::Case;
use cgfem_gpu::progress::Silent;
use cgfem_gpu::reproduce::table2::{paper_iterations, table2, K2};
use cgfem_gpu::solver::{KrylovMethod, Preconditioner};

const CASE: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/cases/annuli_contact.toml"
));

#[test]
fn table2_at_level_3_is_consistent() {
    let case = Case::from_str_with("cases/annuli_contact.toml", CASE, &[]).unwrap();
    let out = std::env::temp_dir().join(format!("cgfem-table2-{}", std::process::id()));
    let solvers = [
        (KrylovMethod::Cgs, Preconditioner::Jacobi),
        (KrylovMethod::Cgs, Preconditioner::Multigrid),
    ];
    let rows = table2(&case, &[3], &solvers, &out, &Silent).unwrap();
    assert_eq!(rows.len(), 4);
    let (without, with) = (&rows[0], &rows[1]);
    assert_eq!(rows[2].preconditioner, "multigrid");
    for (jacobi, multigrid) in rows[..2].iter().zip(&rows[2..]) {
        assert_eq!(jacobi.k2, multigrid.k2);
        assert!(
            multigrid.krylov_iterations < jacobi.krylov_iterations,
            "k2 = {}: multigrid {} against Jacobi {}",
            jacobi.k2,
            multigrid.krylov_iterations,
            jacobi.krylov_iterations
        );
    }
    assert_eq!((without.k2, with.k2), (0.0, K2));
    for r in &rows {
        assert!(r.converged, "level 3, k2 = {}: {:?}", r.k2, r.failure);
        assert_eq!(r.load_steps, 5);
        assert_eq!(r.method, "cgs");
        assert_eq!(
            r.pathological, with.pathological,
            "Ω* does not depend on k2"
        );
        // The accumulated iterations are the sum over the report's steps,
        // and over each step's passes.
        let steps: usize = r.steps.iter().flat_map(|s| &s.krylov_iterations).sum();
        assert_eq!(r.krylov_iterations, steps);
        let passes: usize = r
            .steps
            .iter()
            .flat_map(|s| &s.passes)
            .map(|p| p.krylov_iterations)
            .sum();
        assert_eq!(r.krylov_iterations, passes);
        let solves: usize = r.steps.iter().map(|s| s.krylov_iterations.len()).sum();
        assert_eq!(r.solves, solves);
        assert!(
            r.solves > r.newton_iterations,
            "one solve more than updates per pass"
        );
        let newton: usize = r.steps.iter().map(|s| s.newton.iterations).sum();
        assert_eq!(r.newton_iterations, newton);
        assert_eq!(
            r.passes,
            r.steps.iter().map(|s| s.passes.len()).sum::<usize>()
        );
        assert_eq!(r.paper_iterations, paper_iterations(3, r.k2 > 0.0));
    }
    assert!(with.pathological > 0, "the rings have Ω* cells at level 3");
    // Step recovery: one Newton loop per attempt, the recovered terms
    // (contact traction in both runs, S in one) evaluated at its start.
    for r in &rows {
        assert_eq!(r.passes, r.steps.len(), "one pass per attempt");
        assert!(r.steps.iter().all(|s| s.passes[0].change.is_some()));
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("table2.json")).unwrap()).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), 4);
    let md = std::fs::read_to_string(out.join("table2.md")).unwrap();
    for solver in ["cgs + jacobi", "cgs + multigrid"] {
        assert!(md.contains(&format!("| {solver} | 3 | without |")));
        assert!(md.contains(&format!("| {solver} | 3 | with |")));
    }
    assert!(std::fs::read_to_string(out.join("table2.svg"))
        .unwrap()
        .contains("<svg"));
    std::fs::remove_dir_all(&out).ok();
}
