//! The stacked problem with a coupling term and held dofs: its tangent
//! against central differences of its residual, and its diagonal.

use cgfem_gpu::bodies::problem::{Coupling, CouplingTangent, Triplets};
use cgfem_gpu::contact::{ContactRow, SlaveSample};
use cgfem_gpu::hyper::material::Material;

use super::alone;

/// A nonlinear spring `k (a − b)³` between dof `a` of body 0 and dof `b`
/// of body 1, standing in for the contact coupling.
struct Spring {
    a: usize,
    b: usize,
    k: f64,
}

impl Coupling for Spring {
    fn step_converged(&self, u: &[f64], step: usize) -> Vec<ContactRow> {
        let gap = u[self.b] - u[self.a];
        let sample = SlaveSample {
            weight: 1.0,
            gap,
            pressure: self.k * gap.powi(3),
            sticking: false,
        };
        vec![ContactRow::from_samples("spring", step, &[sample])]
    }

    fn residual_add(&self, u: &[f64], t: f64, r: &mut [f64]) -> Option<()> {
        let f = t * self.k * (u[self.a] - u[self.b]).powi(3);
        r[self.a] += f;
        r[self.b] -= f;
        Some(())
    }

    fn tangent<'a>(&'a self, u: &[f64], t: f64) -> Option<Box<dyn CouplingTangent + 'a>> {
        let d = 3.0 * t * self.k * (u[self.a] - u[self.b]).powi(2);
        Some(Box::new(Triplets(vec![
            (self.a, self.a, d),
            (self.a, self.b, -d),
            (self.b, self.a, -d),
            (self.b, self.b, d),
        ])))
    }
}

#[test]
fn the_stacked_tangent_with_coupling_and_held_dofs_is_the_derivative_of_the_residual() {
    use cgfem_gpu::bodies::problem::BodiesProblem;
    use cgfem_gpu::hyper::newton::NonlinearProblem;
    let left = alone(
        [0.0; 3],
        Material::neo_hookean(1000.0, 0.3),
        1000.0,
        0.5,
        None,
    );
    let right = alone(
        [3.0, 0.0, 0.0],
        Material::st_venant_kirchhoff(500.0, 0.25),
        500.0,
        -0.3,
        None,
    );
    let n0 = left.ndofs();
    let mut p = BodiesProblem::new(vec![left, right]);
    p.set_coupling(Box::new(Spring {
        a: 4,
        b: n0 + 7,
        k: 1e5,
    }));
    p.hold(1, 2);
    p.hold(0, 5);
    let n = p.ndofs();
    let pseudo = |i: usize, s: f64| (i as f64 * s).sin() * 0.02;
    let mut u: Vec<f64> = (0..n).map(|i| pseudo(i, 1.3)).collect();
    u[5] = 0.0;
    u[n0 + 2] = 0.0;
    let v: Vec<f64> = (0..n).map(|i| pseudo(i, 0.7) * 50.0).collect();
    let t = 0.7;
    let k = p.tangent(&u, t).unwrap();
    let mut kv = vec![0.0; n];
    k.apply(&v, &mut kv);
    let eps = 1e-6;
    let shifted = |s: f64| {
        let mut w: Vec<f64> = u.iter().zip(&v).map(|(x, d)| x + s * d).collect();
        w[5] = 0.0;
        w[n0 + 2] = 0.0;
        p.residual(&w, t).unwrap()
    };
    let (plus, minus) = (shifted(eps), shifted(-eps));
    let fd: Vec<f64> = plus
        .iter()
        .zip(&minus)
        .map(|(a, b)| (a - b) / (2.0 * eps))
        .collect();
    // Held rows: the identity, and no residual.
    assert_eq!((kv[5], kv[n0 + 2]), (v[5], v[n0 + 2]));
    assert_eq!((fd[5], fd[n0 + 2]), (0.0, 0.0));
    let free = |x: &[f64]| -> Vec<f64> {
        x.iter()
            .enumerate()
            .filter(|(i, _)| *i != 5 && *i != n0 + 2)
            .map(|(_, v)| *v)
            .collect()
    };
    let (a, b) = (free(&kv), free(&fd));
    let diff = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt();
    let norm = b.iter().map(|x| x * x).sum::<f64>().sqrt();
    println!(
        "stacked tangent vs central differences: {:.2e}",
        diff / norm
    );
    assert!(diff < 1e-6 * norm, "{diff:e} of {norm:e}");
    // The diagonal is the apply of unit vectors, coupling and held dofs included.
    let d = k.diagonal();
    for i in [4, 5, n0 + 2, n0 + 7, n - 1] {
        let mut e = vec![0.0; n];
        e[i] = 1.0;
        let mut ke = vec![0.0; n];
        k.apply(&e, &mut ke);
        assert!(
            (ke[i] - d[i]).abs() <= 1e-12 * d[i].abs(),
            "dof {i}: {} vs {}",
            ke[i],
            d[i]
        );
    }
}

/// A run with a coupling: it is told every converged step, and its rows are
/// the report's `contact`.
#[test]
fn the_coupling_reports_a_row_per_converged_step() {
    use cgfem_gpu::bodies::run::run_setup;
    use cgfem_gpu::bodies::setup::BodiesSetup;
    use cgfem_gpu::case::Case;
    use cgfem_gpu::progress::Silent;
    let case = Case::from_str_with("two.toml", &super::case_text("0.5"), &[]).unwrap();
    let mut setup = BodiesSetup::new(&case, Some(1), &Silent).unwrap();
    let n0 = setup.problem.bodies[0].ndofs();
    let spring = Spring {
        a: 3,
        b: n0,
        k: 10.0,
    };
    setup.problem.set_coupling(Box::new(spring));
    let outcome = run_setup(&case, setup, None, &Silent).unwrap();
    outcome.result.unwrap();
    let u = &outcome.solution.u;
    let rows = &outcome.report.contact;
    assert_eq!(rows.iter().map(|r| r.step).collect::<Vec<_>>(), [1, 2]);
    assert_eq!(rows[1].max_penetration, (u[3] - u[n0]).max(0.0));
    assert!(rows.iter().all(|r| r.pair == "spring"));
}

/// A block pressed 0.1 down onto a wider one, 0.01 apart, frictionless. The
/// upper grid is offset: with both grids aligned, slave Gauss points lie on
/// the master triangles' edges and Newton stalls near 1e-6 (see docs/verification.md).
const PRESS: &str = r#"
[load]
steps = 4
[newton]
rel_tol = 1e-9
energy_tol = 1e-14
[solver]
rel_tol = 1e-12
[[body]]
name = "lower"
geometry = { type = "cuboid", min = [-1, -1, -1], max = [1, 1, 0] }
grid = { level = 2 }
material = { young = 1000.0, poisson = 0.3 }
dirichlet.zmin = { value = ["0", "0", "0"] }
[[body]]
name = "upper"
geometry = { type = "cuboid", min = [-0.5, -0.5, 0.01], max = [0.5, 0.5, 1.01] }
grid = { level = 2, offset = [0.13, 0.29, 0.0] }
material = { young = 1000.0, poisson = 0.3 }
dirichlet.zmax = { value = ["0", "0", "-0.1"] }
[[contact]]
slave = "upper.zmin"
master = "lower.zmax"
"#;

/// The stacked tangent with the case's contact pair against central
/// differences of the stacked residual, at a state in contact; Q1 and Q2.
#[test]
fn the_stacked_tangent_with_contact_is_the_derivative_of_the_residual() {
    let material = "material = { young = 1000.0, poisson = 0.3 }";
    let q2 = PRESS.replace(material, &format!("{material}\nelement = \"q2\""));
    assert_eq!(q2.matches("q2").count(), 2);
    for text in [PRESS, &q2] {
        stacked_tangent_against_central_differences(text);
    }
}

fn stacked_tangent_against_central_differences(text: &str) {
    use cgfem_gpu::bodies::setup::BodiesSetup;
    use cgfem_gpu::case::Case;
    use cgfem_gpu::hyper::newton::NonlinearProblem;
    use cgfem_gpu::progress::Silent;
    let case = Case::from_str_with("press.toml", text, &[]).unwrap();
    let setup = BodiesSetup::new(&case, None, &Silent).unwrap();
    let p = &setup.problem;
    let n = p.ndofs();
    let mut u = vec![0.0; n];
    for b in 0..2 {
        let body = &p.bodies[b];
        for (a, &node) in body.dofs.active_to_node.iter().enumerate() {
            let x = body.grid.node_position(body.order(), node as usize);
            let d = &mut u[p.offsets[b] + 3 * a..p.offsets[b] + 3 * a + 3];
            if b == 1 {
                d[0] = 0.002 * x[1];
                d[2] = -0.015 - 0.01 * x[2] + 0.003 * x[0] * x[1];
            } else {
                d[2] = 0.001 * x[2] * (1.0 - x[0] * x[0]);
            }
        }
    }
    let t = 0.5;
    let k = p.tangent(&u, t).unwrap();
    let v: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
    let mut kv = vec![0.0; n];
    k.apply(&v, &mut kv);
    let eps = 1e-6;
    let shifted = |s: f64| {
        let w: Vec<f64> = u.iter().zip(&v).map(|(x, d)| x + s * d).collect();
        p.residual(&w, t).unwrap()
    };
    let (plus, minus) = (shifted(eps), shifted(-eps));
    let fd: Vec<f64> = plus
        .iter()
        .zip(&minus)
        .map(|(a, b)| (a - b) / (2.0 * eps))
        .collect();
    let diff = kv
        .iter()
        .zip(&fd)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    let norm = fd.iter().map(|a| a * a).sum::<f64>().sqrt();
    println!(
        "{:?}: stacked tangent with contact vs central differences: {:.2e}",
        p.bodies[0].order(),
        diff / norm
    );
    assert!(diff < 1e-8 * norm, "{diff:e} of {norm:e}");
    // The state is in contact: the contact rows see pressure.
    let rows = p.step_converged(&u, 1);
    assert!(
        rows[0].normal_force > 0.0 && rows[0].contact_area > 0.5,
        "{:?}",
        rows[0]
    );
}

/// Frictionless hyperelastic contact is path independent: 4 and 8 load steps
/// end with the same contact force. Without the S-term (`k2 = 0`): its
/// recovered displacement is converged only to the fixed-point tolerance
/// (1e-6), and with the default S-term the two forces differ by 3.6e-6
/// relative (measured: 68.087111 and 68.086867).
#[test]
fn a_pressed_block_ends_with_the_same_contact_force_in_4_and_8_steps() {
    use cgfem_gpu::bodies::run::run;
    use cgfem_gpu::case::Case;
    use cgfem_gpu::progress::Silent;
    let force = |steps: &str| {
        let set = [format!("load.steps={steps}"), "stabilisation.k2=0".into()];
        let case = Case::from_str_with("press.toml", PRESS, &set).unwrap();
        let outcome = run(&case, None, None, &Silent).unwrap();
        outcome.result.unwrap();
        let rows = &outcome.report.contact;
        assert_eq!(rows.len(), steps.parse::<usize>().unwrap());
        assert!(rows
            .windows(2)
            .all(|w| w[1].normal_force > w[0].normal_force));
        let last = rows.last().unwrap().clone();
        assert!(last.max_penetration < 0.01 * 0.25, "{last:?}");
        last.normal_force
    };
    let (f4, f8) = (force("4"), force("8"));
    println!("contact force: {f4:.9} (4 steps), {f8:.9} (8 steps)");
    assert!(f4 > 50.0 && (f4 - f8).abs() < 1e-6 * f4, "{f4} vs {f8}");
}
