//! Tests of the factored Q1 cut-cell forms.

use super::*;
use crate::fem::cut_apply::CutKernel;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Random weights of `cells` cells (random rules inside the unit cube).
fn random_weights(basis: &FitBasis, cells: usize, rng: &mut ChaCha8Rng) -> CutWeights {
    let nq = basis.num_points();
    let mut data = vec![0.0; 2 * nq * cells];
    for cw in data.chunks_exact_mut(2 * nq) {
        let (wk, wm) = cw.split_at_mut(nq);
        for _ in 0..12 {
            let x = [0; 3].map(|_| rng.gen::<f64>());
            basis.add_point(x, rng.gen::<f64>(), wk);
            let y = [0; 3].map(|_| rng.gen::<f64>());
            basis.add_point(y, rng.gen::<f64>(), wm);
        }
    }
    CutWeights { nq, data }
}

/// The factored forms against the weights: expansion, diagonal, and the
/// batched apply against the generic sum-factorised kernel.
#[test]
fn forms_equal_the_weights_matrices_and_kernel() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let basis = FitBasis::new(ElementOrder::Q1);
    let (lame, h) = ((1.7, 0.9), 0.25);
    let cells = 11;
    let w = random_weights(&basis, cells, &mut rng);
    let mut forms = Q1Forms::new(&basis, &w, lame, h);
    let mut w2 = w.clone();
    for s in [2, 7] {
        forms.add_cell_mass(s, 0.3);
        w2.add_cell_mass(&basis, s, 0.3);
    }
    for s in 0..cells {
        let (wk, wm) = w2.cell(s);
        let dense = basis.expand(wk, wm, lame, 1.0 / h);
        let scale = dense.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, b) in forms.expand(s).iter().zip(&dense) {
            assert!((a - b).abs() <= 1e-14 * scale, "cell {s}: {a} vs {b}");
        }
        let diag = basis.diagonal(wk, wm, lame, 1.0 / h);
        for (a, b) in forms.diagonal(s).iter().zip(&diag) {
            assert!((a - b).abs() <= 1e-14 * scale);
        }
    }
    let x: Vec<f64> = (0..24 * cells).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let gather = |s: usize, xe: &mut [f64]| xe.copy_from_slice(&x[24 * s..24 * s + 24]);
    let nodes: Vec<[u32; 8]> = (0..cells as u32)
        .map(|s| std::array::from_fn(|q| 8 * s + q as u32))
        .collect();
    let (mut z1, mut z2) = (vec![0.0; 24 * cells], vec![0.0; 24 * cells]);
    forms.apply(&nodes, &x, &mut z1);
    CutKernel::new(&basis, lame, h).apply(&w2, gather, &mut z2);
    let scale = z2.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (a, b) in z1.iter().zip(&z2) {
        assert!((a - b).abs() <= 1e-13 * scale, "{a} vs {b}");
    }
}

/// The whole cell's form is `h K_ref`, and its uniform apply is that matrix
/// times each cell's dofs (gathered through node indices, shared nodes
/// included).
#[test]
fn inside_form_is_the_reference_matrix() {
    let basis = FitBasis::new(ElementOrder::Q1);
    let (young, poisson, h) = (1000.0, 0.3, 0.125);
    let lame = crate::element::reference::lame(young, poisson);
    let k = crate::element::reference::reference_stiffness(ElementOrder::Q1, young, poisson) * h;
    let forms = Q1Forms::inside(&basis, lame, h);
    let scale = k.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let dense = forms.expand(0);
    for r in 0..24 {
        for c in 0..24 {
            let d = (dense[24 * r + c] - k[(r, c)]).abs();
            assert!(
                d <= 1e-13 * scale,
                "({r}, {c}): {} vs {}",
                dense[24 * r + c],
                k[(r, c)]
            );
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let cells = 7;
    let nodes: Vec<[u32; 8]> = (0..cells as u32)
        .map(|s| std::array::from_fn(|q| 3 * s + q as u32))
        .collect();
    let x: Vec<f64> = (0..3 * (3 * cells + 8))
        .map(|_| rng.gen_range(-1.0..1.0))
        .collect();
    let mut z = vec![0.0; 24 * cells];
    forms.apply_uniform(&nodes, &x, &mut z);
    for (s, cell) in nodes.iter().enumerate() {
        for r in 0..24 {
            let want: f64 = (0..24)
                .map(|c| k[(r, c)] * x[3 * cell[c / 3] as usize + c % 3])
                .sum();
            let got = z[24 * s + r];
            assert!(
                (got - want).abs() <= 1e-12 * scale,
                "cell {s} row {r}: {got} vs {want}"
            );
        }
    }
}
