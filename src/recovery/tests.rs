//! Tests of the monomial basis and of the patch fit, unconstrained and
//! constrained, on random point clouds.

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

fn random_point(r: &mut ChaCha8Rng) -> [f64; 3] {
    [0, 1, 2].map(|_| r.gen_range(-1.0..1.0))
}

/// The polynomial with stacked coefficients `a` at `xi`.
fn poly<const NC: usize>(basis: &Monomials, a: &[f64], xi: [f64; 3]) -> [f64; NC] {
    let mut phi = vec![0.0; basis.len()];
    basis.values(xi, &mut phi);
    let nb = basis.len();
    std::array::from_fn(|c| (0..nb).map(|j| a[c * nb + j] * phi[j]).sum())
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn monomials_are_complete_graded_and_differentiate_right() {
    for (p, n) in [(0, 1), (1, 4), (2, 10), (3, 20), (4, 35)] {
        let m = Monomials::new(p);
        assert_eq!(m.len(), n);
        assert!(m.exponents().iter().all(|e| e.iter().sum::<usize>() <= p));
        let mut sorted = m.exponents().to_vec();
        sorted.dedup();
        assert_eq!(sorted.len(), n, "distinct terms");
    }
    let m = Monomials::new(2);
    assert_eq!(m.exponents()[1], [1, 0, 0]);
    assert_eq!(m.exponents()[5], [1, 1, 0]);
    let xi = [0.3, -0.7, 1.4];
    let mut v = vec![0.0; m.len()];
    m.values(xi, &mut v);
    assert!((v[5] - 0.3 * -0.7).abs() < 1e-15 && (v[9] - 1.4 * 1.4).abs() < 1e-15);
    let m = Monomials::new(3);
    let mut g = vec![[0.0; 3]; m.len()];
    m.gradients(xi, &mut g);
    let (mut vp, mut vm) = (vec![0.0; m.len()], vec![0.0; m.len()]);
    let eps = 1e-6;
    for k in 0..3 {
        let (mut xp, mut xm) = (xi, xi);
        xp[k] += eps;
        xm[k] -= eps;
        m.values(xp, &mut vp);
        m.values(xm, &mut vm);
        for j in 0..m.len() {
            let fd = (vp[j] - vm[j]) / (2.0 * eps);
            assert!((fd - g[j][k]).abs() < 1e-8, "term {j} axis {k}");
        }
    }
}

#[test]
fn unconstrained_fit_reproduces_polynomials_and_rejects_bad_clouds() {
    let mut r = rng(1);
    for p in 1..=3 {
        let basis = Monomials::new(p);
        let a: Vec<f64> = (0..2 * basis.len())
            .map(|_| r.gen_range(-1.0..1.0))
            .collect();
        let samples: Vec<([f64; 3], [f64; 2])> = (0..3 * basis.len())
            .map(|_| {
                let x = random_point(&mut r);
                (x, poly(&basis, &a, x))
            })
            .collect();
        let fit = fit_polynomial(&basis, &samples, None, &FitOptions::default()).unwrap();
        assert!(max_diff(&fit, &a) < 1e-11, "degree {p}");
        // Too few points for the ratio.
        let few = &samples[..basis.len() + 1];
        assert!(matches!(
            fit_polynomial(&basis, few, None, &FitOptions::default()),
            Err(FitFailure::TooFewPoints { .. })
        ));
    }
    // Coplanar points cannot determine a z-dependence.
    let basis = Monomials::new(1);
    let flat: Vec<([f64; 3], [f64; 1])> = (0..20)
        .map(|_| {
            let x = random_point(&mut r);
            ([x[0], x[1], 0.25], [x[0]])
        })
        .collect();
    assert!(matches!(
        fit_polynomial(&basis, &flat, None, &FitOptions::default()),
        Err(FitFailure::Unstable { .. })
    ));
}

/// A random cloud of smooth, non-polynomial 3-component data.
fn smooth_cloud(r: &mut ChaCha8Rng, n: usize) -> Vec<([f64; 3], [f64; 3])> {
    (0..n)
        .map(|_| {
            let x = random_point(r);
            (
                x,
                [x[0].sin() + x[2], (x[1] * x[2]).exp(), x[0] * x[1] * x[2]],
            )
        })
        .collect()
}

fn random_constraints(r: &mut ChaCha8Rng, rows: usize, cols: usize) -> LinearConstraints {
    LinearConstraints {
        c: DMatrix::from_fn(rows, cols, |_, _| r.gen_range(-1.0..1.0)),
        d: DVector::from_fn(rows, |_, _| r.gen_range(-1.0..1.0)),
    }
}

#[test]
fn constrained_fit_satisfies_its_constraints() {
    let mut r = rng(2);
    for p in 1..=3 {
        let basis = Monomials::new(p);
        let samples = smooth_cloud(&mut r, 4 * basis.len());
        let k = random_constraints(&mut r, 5, 3 * basis.len());
        let opts = FitOptions::default();
        let a = fit_polynomial(&basis, &samples, Some(&k), &opts).unwrap();
        let residual = (&k.c * DVector::from_vec(a.clone()) - &k.d).amax();
        assert!(residual < 1e-12, "degree {p}: residual {residual:e}");
        // The constraints bind: the unconstrained fit violates them.
        let free = fit_polynomial(&basis, &samples, None, &opts).unwrap();
        assert!((&k.c * DVector::from_vec(free) - &k.d).amax() > 1e-3);
    }
}

#[test]
fn constrained_fit_equals_free_fit_when_the_data_satisfy_the_constraints() {
    let mut r = rng(3);
    let basis = Monomials::new(2);
    let n = 3 * basis.len();
    let opts = FitOptions::default();
    // Noisy (non-polynomial) data: constraints built to hold at the free fit.
    let samples = smooth_cloud(&mut r, 40);
    let free = fit_polynomial(&basis, &samples, None, &opts).unwrap();
    let mut k = random_constraints(&mut r, 6, n);
    k.d = &k.c * DVector::from_vec(free.clone());
    let tied = fit_polynomial(&basis, &samples, Some(&k), &opts).unwrap();
    assert!(max_diff(&tied, &free) < 1e-11);
    // Polynomial data: the constrained fit is the polynomial itself.
    let a: Vec<f64> = (0..n).map(|_| r.gen_range(-1.0..1.0)).collect();
    let exact: Vec<([f64; 3], [f64; 3])> = samples
        .iter()
        .map(|(x, _)| (*x, poly(&basis, &a, *x)))
        .collect();
    k.d = &k.c * DVector::from_vec(a.clone());
    let tied = fit_polynomial(&basis, &exact, Some(&k), &opts).unwrap();
    assert!(max_diff(&tied, &a) < 1e-11);
}

#[test]
fn bad_constraints_are_reported() {
    let mut r = rng(4);
    let basis = Monomials::new(1);
    let samples = smooth_cloud(&mut r, 30);
    let opts = FitOptions::default();
    let wrong = random_constraints(&mut r, 2, 5);
    assert!(matches!(
        fit_polynomial(&basis, &samples, Some(&wrong), &opts),
        Err(FitFailure::BadConstraints { .. })
    ));
    // The same row twice with different right-hand sides: inconsistent.
    let mut k = random_constraints(&mut r, 2, 12);
    for j in 0..12 {
        k.c[(1, j)] = k.c[(0, j)];
    }
    k.d[1] = k.d[0] + 1.0;
    assert_eq!(
        fit_polynomial(&basis, &samples, Some(&k), &opts),
        Err(FitFailure::Singular)
    );
}

/// An inside cell's moments as one product with its nodal values
/// ([`InsideMoments`]) equal the moments of its samples: a trilinear field
/// at the 2³ Gauss points, about the cell's centre.
#[test]
fn inside_moments_equal_the_moments_of_the_samples() {
    use crate::element::{shape_values, tensor_gauss_rule, ElementOrder};
    let rule = tensor_gauss_rule(2);
    let xi: Vec<[f64; 3]> = rule.iter().map(|(x, _)| *x).collect();
    let shape = |q: usize, a: usize| {
        let mut n = [0.0; 8];
        shape_values(ElementOrder::Q1, xi[q], &mut n);
        n[a]
    };
    let unit = |q: usize, c: usize, k: usize| if k % 3 == c { shape(q, k / 3) } else { 0.0 };
    let inside = InsideMoments::new(2, &xi, 3, 24, unit);
    let u: Vec<f64> = (0..24).map(|k| (0.7 * k as f64).sin()).collect();
    let basis = Monomials::new(2);
    let mut got = vec![0.0; basis.len() * 3];
    assert!(inside.moments(&basis, &u, &mut got));
    let mut want = vec![0.0; basis.len() * 3];
    let mut phi = vec![0.0; basis.len()];
    for (q, x) in xi.iter().enumerate() {
        basis.values(x.map(|v| v - 0.5), &mut phi);
        for c in 0..3 {
            let v: f64 = (0..8).map(|a| shape(q, a) * u[3 * a + c]).sum();
            for (j, p) in phi.iter().enumerate() {
                want[j * 3 + c] += p * v;
            }
        }
    }
    for (a, b) in want.iter().zip(&got) {
        assert!((a - b).abs() <= 1e-14, "{a} {b}");
    }
    assert!(!inside.moments(&Monomials::new(1), &u, &mut got[..12]));
}
