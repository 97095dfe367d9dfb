//! Contact with Q2 bodies on the Newton path, end to end: the shipped
//! contact cases with `element = "q2"` on every body converge at every load
//! step and carry the Q1 force of the grid one level finer (same nodes per
//! axis). The fast tier runs the two annuli (plane strain) at level 3; the
//! long tier (`CGFEM_LONG=1`) adds Hertz at levels 2 and 3 with the S-term
//! on (with `k2 = 0` the Q2 ball's sliver cells stall its Krylov solves,
//! README "Case file"). Hertz's errors are printed, not asserted beyond 10 %
//! on the radius: docs/verification.md, "Hertz with Q2 elements", has the
//! figures against Q1.

use std::path::Path;

use cgfem_gpu::bodies::run::run;
use cgfem_gpu::case::Case;
use cgfem_gpu::contact::ContactRow;
use cgfem_gpu::progress::Silent;

/// The shipped case `name` with every body Q2 (and `set`), run at `level`:
/// the contact rows of its converged steps and the ball's (first body's) h.
fn contact_rows(name: &str, q2: bool, level: u32, set: &[String]) -> (Vec<ContactRow>, f64) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("cases/{name}.toml"));
    let text = std::fs::read_to_string(path).unwrap();
    let material = "material = { young = 1000.0, poisson = 0.3 }";
    let text = match q2 {
        true => text.replace(material, &format!("{material}\nelement = \"q2\"")),
        false => text,
    };
    assert_eq!(text.matches("\"q2\"").count(), 2 * q2 as usize, "{name}");
    let case = Case::from_str_with(&format!("{name}.toml"), &text, set).unwrap();
    let outcome = run(&case, Some(level), None, &Silent).unwrap();
    outcome.result.unwrap();
    let report = &outcome.report;
    assert_eq!(
        report.load.as_ref().unwrap().converged_steps,
        case.spec.load.steps
    );
    (report.contact.clone(), outcome.setup.bodies[0].grid.h)
}

/// The annuli's last contact force per unit slab thickness (the slab is one
/// cell thick, so the force scales with h).
fn annuli_force(q2: bool, level: u32) -> f64 {
    let (rows, h) = contact_rows("annuli_contact", q2, level, &[]);
    rows.last().unwrap().normal_force / h
}

#[test]
fn contact_cases_with_q2_converge_every_step_and_carry_the_q1_force() {
    let (q2, q1) = (annuli_force(true, 3), annuli_force(false, 4));
    println!("annuli, force per thickness: Q2 level 3 {q2:.5}, Q1 level 4 {q1:.5}");
    // Measured: 3.8 % apart. A Q2 master meshed on the Q1 lattice (loaded
    // at its vertex nodes only) carried 40 % less on the pressed blocks.
    assert!((q2 / q1 - 1.0).abs() < 0.1, "{q2} vs {q1}");
    if std::env::var_os("CGFEM_LONG").is_none() {
        return;
    }
    let e_star = 1000.0 / (2.0 * (1.0 - 0.3f64.powi(2)));
    for level in [2, 3] {
        let set = ["stabilisation.k2=0.01".to_string()];
        let (rows, _) = contact_rows("hertz", true, level, &set);
        let row = rows.last().unwrap();
        let force = 4.0 * row.normal_force;
        let a = (3.0 * force / (4.0 * e_star)).cbrt();
        let p0 = 3.0 * force / (2.0 * std::f64::consts::PI * a * a);
        let radius = (4.0 * row.reference_contact_area / std::f64::consts::PI).sqrt();
        let peak = row.peak_recovered_nominal_pressure;
        println!(
            "Hertz Q2 level {level}: F = {force:.4}, radius {:+.2} %, recovered peak {:+.2} %",
            100.0 * (radius / a - 1.0),
            100.0 * (peak / p0 - 1.0)
        );
        assert!(
            (radius / a - 1.0).abs() < 0.1,
            "level {level}: {radius} vs {a}"
        );
    }
}
