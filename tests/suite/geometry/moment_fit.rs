//! The moment-fitted cut-cell matrices (`src/fem/moment_fit.rs`) against the
//! direct quadrature of the cut cells' own rules, on every cut cell of the
//! paper's sphere, Q1 and Q2: with the Dirichlet penalty, without it, and with
//! the S-term's whole-cell mass added; and the Q2 apply (sum-factorised cut
//! cells) against the assembled matrix.

use cgfem_gpu::backend::LinearOperator;
use cgfem_gpu::case::Case;
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::driver::stabilisation::cell_s_matrix;
use cgfem_gpu::element::reference::{add_btdb, elasticity_matrix, strain_displacement};
use cgfem_gpu::element::{shape_values, ElementOrder};
use cgfem_gpu::fem::operator::{AssembledOperator, ElasticOperator, OperatorParams};
use nalgebra::DMatrix;

fn sphere(overrides: &[&str]) -> Case {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/sphere.toml");
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    Case::from_file_with(&path, &overrides).unwrap()
}

/// `Σ_vol w BᵀDB + Σ_{Dirichlet points} w (β/h) NᵀN ⊗ I₃` of cut cell `i` by
/// its own quadrature points (`beta = 0`: no penalty), row-major.
fn direct_matrix(setup: &Setup, i: usize, order: ElementOrder, beta: f64) -> Vec<f64> {
    let (grid, cells) = (&setup.grid, &setup.cells);
    let npc = order.nodes_per_cell();
    let ne = 3 * npc;
    let x0 = grid.cell_box(cells.cut[i]).lo;
    let inv_h = 1.0 / grid.h;
    let d = elasticity_matrix(setup.problem.young, setup.problem.poisson);
    let xi = |x: [f64; 3]| [0, 1, 2].map(|a| (x[a] - x0[a]) * inv_h);
    let mut k = DMatrix::zeros(ne, ne);
    let mut b = DMatrix::zeros(6, ne);
    for q in cells.volume_points(i) {
        strain_displacement(order, xi(q.x), inv_h, &mut b);
        add_btdb(&mut k, &b, &d, q.w);
    }
    let mut n = vec![0.0; npc];
    for q in cells.surface_points(i) {
        shape_values(order, xi(q.x), &mut n);
        for a in 0..npc {
            for c in 0..npc {
                for e in 0..3 {
                    k[(3 * a + e, 3 * c + e)] += q.w * beta * inv_h * n[a] * n[c];
                }
            }
        }
    }
    (0..ne * ne).map(|r| k[(r / ne, r % ne)]).collect()
}

/// The largest `max |K_fit − K_direct| / max |K_direct|` over the cut cells,
/// `extra(cell)` added to the direct matrix.
fn worst(setup: &Setup, op: &ElasticOperator, beta: f64, extra: impl Fn(usize) -> Vec<f64>) -> f64 {
    let order = op.dofs.order;
    let mut worst = 0.0f64;
    for (i, &c) in setup.cells.cut.iter().enumerate() {
        let mut direct = direct_matrix(setup, i, order, beta);
        for (d, e) in direct.iter_mut().zip(extra(c)) {
            *d += e;
        }
        let fitted = op.cell_matrix(c).unwrap();
        let scale = direct.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = fitted
            .iter()
            .zip(&direct)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        worst = worst.max(diff / scale);
    }
    worst
}

fn check(order: ElementOrder, level: u32) {
    let name = format!(
        "element={}",
        if order == ElementOrder::Q1 {
            "q1"
        } else {
            "q2"
        }
    );
    let offset = "grid.offset=[0.45, 0.1, 0.6]";
    let case = sphere(&[
        &name,
        offset,
        "stabilisation.k2=0.01",
        "stabilisation.A=0.1",
    ]);
    let setup = Setup::new(&case, Some(level)).unwrap();
    assert!(setup.cells.cut.len() > 50, "too few cut cells");
    assert!(!setup.omega_star.is_empty(), "no pathological cell");
    let p = &setup.problem;
    let held = |tag, x| p.dirichlet_mask(tag, x);
    assert!(
        (0..setup.cells.cut.len())
            .flat_map(|i| setup.cells.surface_points(i))
            .all(|q| held(q.tag, q.x) == Some([true; 3])),
        "the sphere is Dirichlet everywhere"
    );
    let (young, poisson, beta) = (p.young, p.poisson, setup.beta);
    let (grid, cells) = (&setup.grid, &setup.cells);
    let none = |_| vec![0.0; 9 * order.nodes_per_cell().pow(2)];

    // The setup's operator: penalty and S-term mass on Ω*.
    let ks = cell_s_matrix(order, setup.s_factor, grid.h);
    let s_term = |c| {
        if setup.omega_star.binary_search(&c).is_ok() {
            ks.clone()
        } else {
            none(c)
        }
    };
    let e = worst(&setup, &setup.op, beta, s_term);
    println!("{order:?} penalty + S-term: {e:.1e}");
    assert!(e < 1e-13, "{order:?} penalty + S-term: {e:e}");

    // With the penalty, no S-term.
    let params = OperatorParams {
        young,
        poisson,
        beta,
        dirichlet: &held,
    };
    let op = ElasticOperator::new(grid, cells, order, &params);
    let e = worst(&setup, &op, beta, none);
    println!("{order:?} penalty: {e:.1e}");
    assert!(e < 1e-13, "{order:?} penalty: {e:e}");

    // No Dirichlet part at all.
    let params = OperatorParams {
        dirichlet: &|_, _| None,
        ..params
    };
    let op = ElasticOperator::new(grid, cells, order, &params);
    let e = worst(&setup, &op, 0.0, none);
    println!("{order:?} stiffness only: {e:.1e}");
    assert!(e < 1e-13, "{order:?} stiffness only: {e:e}");
}

#[test]
fn fitted_q1_cut_matrices_equal_direct_quadrature() {
    check(ElementOrder::Q1, 4);
}

#[test]
fn fitted_q2_cut_matrices_equal_direct_quadrature() {
    check(ElementOrder::Q2, 3);
}

#[test]
fn q2_apply_matches_the_assembled_matrix() {
    let case = sphere(&["element=q2", "stabilisation.k2=0.01", "stabilisation.A=0.1"]);
    let setup = Setup::new(&case, Some(3)).unwrap();
    let op = &setup.op;
    let n = op.nrows();
    let x: Vec<f64> = (0..n)
        .map(|i| ((i * 7919) % 1000) as f64 / 500.0 - 1.0)
        .collect();
    let (mut y, mut expected) = (vec![f64::NAN; n], vec![0.0; n]);
    op.apply(&x, &mut y);
    AssembledOperator(op.assemble()).apply(&x, &mut expected);
    let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = y
        .iter()
        .zip(&expected)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    println!("Q2 apply vs assembled: {:.1e}", diff / scale);
    assert!(diff <= 1e-12 * scale, "{:e}", diff / scale);
    let diag = op.diagonal();
    let assembled_diag = AssembledOperator(op.assemble()).diagonal();
    for (a, b) in diag.iter().zip(&assembled_diag) {
        assert!((a - b).abs() <= 1e-12 * scale);
    }
}
