//! The recovered terms of the fixed-point loop at levels 5–7 of the paper's
//! sphere (Q1, S-term on: k2 = 0.01, A = 1%), with the cost per cut cell:
//! - T: SPR stress recovery on the patches of the Dirichlet points' nodes and
//!   the recovered tractions `t̂` at the Dirichlet points;
//! - S: the constrained displacement recovery on the vertex patches of Ω* and
//!   the right-hand side `F_S`.
//!
//! Both must scale with the number of cut cells, not of all cells. Each is
//! timed as the best of a few repetitions on a smooth field (the interpolant
//! of the exact solution), as the loop's recoveries after its first run:
//! every patch reuses the fit the first recovery accepted and factored.
//!
//! `cargo bench --bench recovery` (levels: `CGFEM_BENCH_LEVELS=5,6`).

use std::sync::OnceLock;
use std::time::Instant;

use cgfem_gpu::case::Case;
use cgfem_gpu::discrete::field::interpolate;
use cgfem_gpu::driver::recovery::{recover_stress, recovered_tractions, traction_patch_nodes};
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::driver::share::Whole;
use cgfem_gpu::driver::stabilisation::{recover_displacement, s_rhs};

fn best_of<T>(reps: usize, mut f: impl FnMut() -> T) -> f64 {
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(f());
            t.elapsed().as_secs_f64()
        })
        .fold(f64::MAX, f64::min)
}

fn main() {
    let levels: Vec<u32> = std::env::var("CGFEM_BENCH_LEVELS")
        .unwrap_or_else(|_| "5,6,7".into())
        .split(',')
        .filter_map(|s| s.trim().parse().ok())
        .collect();
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/sphere.toml");
    let case = Case::from_file_with(&path, &["stabilisation.k2=0.01".to_string()]).unwrap();
    println!(
        "{:>5} {:>9} {:>8} {:>12} {:>9} {:>12} {:>12} {:>12} {:>12}",
        "level",
        "dofs",
        "cut",
        "pathological",
        "T (s)",
        "T/cut (µs)",
        "S (s)",
        "S/cut (µs)",
        "S/Ω* (µs)"
    );
    for level in levels {
        let setup = Setup::new(&case, Some(level)).unwrap();
        let exact = setup.problem.exact.clone().unwrap();
        let u = interpolate(&setup.grid, &setup.op.dofs, &exact);
        let nodes = traction_patch_nodes(&setup);
        // The fixed point's recoveries after its first: each patch reuses
        // the fit the first one accepted and factored.
        let (stress_plans, displacement_plans) = (OnceLock::new(), OnceLock::new());
        recover_stress(&setup, &u, &nodes, Some(&stress_plans)).unwrap();
        let omega_star = &setup.omega_star;
        recover_displacement(&setup, &u, omega_star, Some(&displacement_plans)).unwrap();
        let t = best_of(3, || {
            let sigma = recover_stress(&setup, &u, &nodes, Some(&stress_plans)).unwrap();
            recovered_tractions(&setup.dirichlet, &sigma).unwrap()
        });
        let s = best_of(3, || {
            let rec =
                recover_displacement(&setup, &u, omega_star, Some(&displacement_plans)).unwrap();
            s_rhs(
                &setup,
                &setup.omega_star,
                &u,
                &rec,
                setup.s_factor,
                true,
                &Whole,
            )
            .unwrap()
        });
        let (cut, path_cells) = (setup.cells.cut.len(), setup.omega_star.len());
        println!(
            "{level:>5} {:>9} {cut:>8} {path_cells:>12} {t:>9.3} {:>12.2} {s:>12.3} {:>12.2} {:>12.2}",
            setup.op.dofs.ndofs(),
            1e6 * t / cut as f64,
            1e6 * s / cut as f64,
            1e6 * s / path_cells.max(1) as f64,
        );
    }
}
