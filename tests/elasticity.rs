//! Linear elasticity on the immersed grid, CPU: the matrix-free operator
//! against the assembled one, and solves against exact fields.

use cgfem_gpu::backend::LinearOperator;
use cgfem_gpu::case::Case;
use cgfem_gpu::fem::operator::AssembledOperator;
use cgfem_gpu::fem::setup::Setup;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const PAPER_FIELD: &str = r#"
[exact]
displacement = ["x + x^2 - 2*x*y + x^3 - 3*x*y^2 + x^2*y", "-y - 2*x*y - 3*x^2*y + y^3 - x*y^2", "0"]
[material]
young = 1000.0
poisson = 0.3
"#;

fn sphere_case(extra: &str) -> Case {
    let text = format!(
        "[geometry]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\n[dirichlet.surface]\nvalue = \"exact\"\n{PAPER_FIELD}{extra}"
    );
    Case::from_str("sphere.toml", &text).unwrap()
}

fn csg_case() -> Case {
    let text = format!(
        r#"[geometry]
type = "difference"
of = [
  {{ type = "cuboid", min = [-1, -1, -0.5], max = [1, 1, 0.5] }},
  {{ type = "rotate", axis = [1, 1, 0], angle_deg = 20, of = {{ type = "cylinder", start = [0, 0, -1], end = [0, 0, 1], radius = 0.35 }} }},
]
[grid]
offset = [0.3, 0.7, 0.1]
[dirichlet.xmin]
value = "exact"
[dirichlet.side]
value = "exact"
[neumann.xmax]
traction = "exact"
{PAPER_FIELD}"#
    );
    Case::from_str("csg.toml", &text).unwrap()
}

fn max_relative_difference(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter().zip(b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / scale
}

#[test]
fn matrix_free_equals_assembled_on_random_vectors() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for (name, case, level) in [("sphere", sphere_case(""), 4), ("csg", csg_case(), 4)] {
        let setup = Setup::new(&case, Some(level)).unwrap();
        let assembled = AssembledOperator(setup.op.assemble());
        let n = setup.op.nrows();
        for _ in 0..3 {
            let x: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let mut y_mf = vec![0.0; n];
            let mut y_as = vec![0.0; n];
            setup.op.apply(&x, &mut y_mf);
            assembled.apply(&x, &mut y_as);
            let d = max_relative_difference(&y_mf, &y_as);
            assert!(d < 1e-12, "{name}: {d}");
        }
        let dm = setup.op.diagonal();
        let da = assembled.diagonal();
        assert!(max_relative_difference(&dm, &da) < 1e-14, "{name}: diagonals differ");
        // Symmetry: x·Ay = y·Ax.
        let x: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let y: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let (mut ax, mut ay) = (vec![0.0; n], vec![0.0; n]);
        setup.op.apply(&x, &mut ax);
        setup.op.apply(&y, &mut ay);
        let xay: f64 = x.iter().zip(&ay).map(|(a, b)| a * b).sum();
        let yax: f64 = y.iter().zip(&ax).map(|(a, b)| a * b).sum();
        assert!((xay - yax).abs() < 1e-12 * xay.abs().max(1.0), "{name}: not symmetric");
    }
}
