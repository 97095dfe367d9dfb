//! Coulomb friction against its closed form: a block pressed onto
//! a plate, then pushed sideways (`cases/friction_block.toml`, μ = 0.3, the
//! press on load factors 0–0.25, the push on 0.25–1, one run).
//!
//! - While pressed, no tangential force.
//! - The tangential contact force `T` equals the force the top face applies
//!   (its `reactions` row) at every step.
//! - In stick it grows with the push, by equal increments per equal push
//!   step (elastic), and stays below μ N.
//! - Once no point sticks, the block slides: `T = μ N` (within 1 % from the
//!   second sliding step on; the slip directions align with the push over
//!   the first), and `T` never exceeds μ N.
//!
//! The Cattaneo–Mindlin partial slip of a sphere is in `tests/suite/contact/mindlin.rs`.

use cgfem_gpu::bodies::run::run;
use cgfem_gpu::case::Case;
use cgfem_gpu::progress::Silent;

const MU: f64 = 0.3;

/// Per converged step: normal force, tangential contact force, the top
/// face's applied force along x, contact and stick areas.
struct Step {
    normal: f64,
    tangential: f64,
    applied: f64,
    area: f64,
    stick: f64,
}

fn steps() -> Vec<Step> {
    let text = include_str!(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/cases/friction_block.toml"
    ));
    let case = Case::from_str_with("cases/friction_block.toml", text, &[]).unwrap();
    let out = run(&case, None, None, &Silent).unwrap();
    out.result.as_ref().unwrap();
    assert_eq!(out.report.load.as_ref().unwrap().converged_steps, 16);
    out.report
        .contact
        .iter()
        .map(|row| {
            let applied = out.report.reactions.iter().find(|r| {
                (r.body.as_str(), r.part.as_str(), r.step) == ("block", "zmax", row.step)
            });
            Step {
                normal: row.normal_force,
                tangential: row.slave_force[0],
                applied: applied.expect("the top face's reaction").force[0],
                area: row.contact_area,
                stick: row.stick_area,
            }
        })
        .collect()
}

#[test]
fn a_pressed_block_sticks_then_slides_at_mu_times_the_normal_force() {
    let steps = steps();
    for (k, s) in steps.iter().enumerate() {
        eprintln!(
            "step {}: N {:.4} T {:.5} T/N {:.5} applied {:.5} area {:.4} stick {:.4}",
            k + 1,
            s.normal,
            s.tangential,
            s.tangential / s.normal,
            s.applied,
            s.area,
            s.stick
        );
        assert!(s.normal > 0.0, "step {}", k + 1);
        assert!(
            (s.applied - s.tangential).abs() < 1e-5 * s.normal,
            "step {}",
            k + 1
        );
        assert!(s.tangential <= MU * s.normal * 1.001, "step {}", k + 1);
    }
    // Pressed (steps 1–4): no tangential force.
    for s in &steps[..4] {
        assert!(s.tangential.abs() < 1e-4 * s.normal);
    }
    // The first two push steps stick on nearly all the contact: equal
    // increments of T.
    let (first, second) = (
        steps[4].tangential - steps[3].tangential,
        steps[5].tangential - steps[4].tangential,
    );
    assert!(steps[4].stick > 0.95 * steps[4].area && steps[5].stick > 0.9 * steps[5].area);
    assert!((second / first - 1.0).abs() < 0.01, "{first} then {second}");
    // The stick area shrinks as the push grows, and while some point sticks
    // T stays below μ N.
    for w in steps[4..].windows(2) {
        assert!(w[1].stick <= w[0].stick + 1e-12);
    }
    for s in steps.iter().filter(|s| s.stick > 0.0) {
        assert!(s.tangential < MU * s.normal);
    }
    // Sliding: no point sticks; T = μ N from the second sliding step on.
    let sliding = (4..steps.len()).find(|&k| steps[k].stick == 0.0);
    let sliding = sliding.expect("the block slides");
    assert!(
        sliding + 3 <= steps.len(),
        "slides from step {}",
        sliding + 1
    );
    assert!(steps[sliding].tangential / steps[sliding].normal > 0.97 * MU);
    for s in &steps[sliding + 1..] {
        assert_eq!(s.stick, 0.0);
        assert!(
            (s.tangential / (MU * s.normal) - 1.0).abs() < 0.01,
            "T/N = {}",
            s.tangential / s.normal
        );
    }
}
