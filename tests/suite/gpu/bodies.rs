//! A multi-body Newton solve with the bodies' inside-cell tangents on a real
//! adapter (lavapipe in CI, `src/gpu/hyper.rs`) against the same solve on the
//! CPU: the same steps, Newton iterations and displacements to round-off.
//! Without an adapter with f64 the test prints "skipped: no GPU adapter" and
//! passes, unless `CI=true`.

use cgfem_gpu::bodies::run::run_on;
use cgfem_gpu::case::Case;
use cgfem_gpu::gpu::{context_or_skip, PrecisionChoice};
use cgfem_gpu::progress::Silent;

/// Two boxes apart, each stretched by prescribed displacements (one
/// neo-Hookean, one St Venant–Kirchhoff), both with inside and cut cells.
const TWO: &str = r#"
name = "two_boxes_gpu"
[load]
steps = 2
[newton]
rel_tol = 1e-11
energy_tol = 1e-22
[solver]
method = "bicgstab"
rel_tol = 1e-12
[[body]]
name = "left"
geometry = { type = "cuboid", min = [0.05, 0.05, 0.05], max = [1.95, 0.95, 0.95] }
grid = { level = 3, box_min = [0, 0, 0], box_max = [2, 1, 1] }
material = { model = "neo_hookean", young = 1000.0, poisson = 0.3 }
dirichlet.xmin = { value = ["0", "0", "0"] }
dirichlet.xmax = { value = ["0.4", "0.1", "free"] }
[[body]]
name = "right"
geometry = { type = "sphere", center = [4, 0.5, 0.5], radius = 0.5 }
grid = { level = 3 }
material = { model = "st_venant_kirchhoff", young = 500.0, poisson = 0.25 }
dirichlet.surface = { value = ["0.05 * z", "0", "-0.05 * x + 0.2"], region = { max = [4, inf, inf] } }
"#;

#[test]
fn inside_cell_tangents_on_the_device_give_the_cpu_solution() {
    let Some(ctx) = context_or_skip(PrecisionChoice::F64) else {
        return;
    };
    let case = Case::from_str_with("two_boxes_gpu.toml", TWO, &[]).unwrap();
    let cpu = run_on(&case, None, None, None, &Silent).unwrap();
    let gpu = run_on(&case, None, None, Some(ctx), &Silent).unwrap();
    cpu.result.unwrap();
    gpu.result.unwrap();
    assert_eq!(cpu.report.backend, "cpu");
    assert_eq!(gpu.report.backend, "gpu");
    let inside: usize = gpu.report.bodies.iter().map(|b| b.cells.inside).sum();
    assert!(inside > 10, "the bodies need inside cells: {inside}");
    assert_eq!(cpu.solution.converged_steps, 2);
    assert_eq!(gpu.solution.converged_steps, 2);
    assert_eq!(
        cpu.solution.newton_iterations(),
        gpu.solution.newton_iterations()
    );
    let (a, b) = (&cpu.solution.u, &gpu.solution.u);
    let diff = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt();
    let norm = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    println!(
        "relative difference {:.3e}; Krylov iterations cpu {} gpu {}",
        diff / norm,
        cpu.solution.krylov_iterations(),
        gpu.solution.krylov_iterations()
    );
    assert!(diff <= 1e-9 * norm, "{}", diff / norm);
}
