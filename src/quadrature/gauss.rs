//! Gauss rules on the unit interval, no table to keep in sync: Gauss–Legendre
//! by Newton's method on the Legendre polynomials, and Gauss–Jacobi for the
//! weight `u` (the Jacobian of a collapsed triangle) by Golub–Welsch.

use nalgebra::{DMatrix, SymmetricEigen};

/// `n`-point Gauss–Legendre rule on `[0, 1]`: points ascending, weights summing to 1.
///
/// Exact for polynomials of degree `2n − 1`. `n = 0` gives an empty rule.
pub fn gauss_legendre_unit(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut points = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        // Tricomi's initial guess for the i-th root of P_n on [-1, 1], descending.
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (p, d) = legendre_with_derivative(n, x);
            dp = d;
            let dx = p / d;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let (_, d) = legendre_with_derivative(n, x);
        if d != 0.0 {
            dp = d;
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        // Map [-1, 1] -> [0, 1]; x is the (n-1-i)-th point in ascending order.
        points[n - 1 - i] = 0.5 * (1.0 + x);
        weights[n - 1 - i] = 0.5 * w;
        points[i] = 0.5 * (1.0 - x);
        weights[i] = 0.5 * w;
    }
    (points, weights)
}

/// `n`-point Gauss rule for `∫_0^1 f(u) u du`: points ascending, weights
/// summing to ½; exact for polynomials `f` of degree `2n − 1`.
///
/// Golub–Welsch: the points are the eigenvalues of the Jacobi matrix of the
/// Jacobi polynomials `P^(0,1)` on `[−1, 1]` (weight `1 + x`), diagonal
/// `1/((2k+1)(2k+3))`, off-diagonal `√(k(k+1))/(2k+1)`, the weights `μ₀ v₀ᵢ²`
/// with `μ₀ = 2`; `u = (1 + x)/2` scales the weights by ¼.
pub fn gauss_jacobi_u_unit(n: usize) -> (Vec<f64>, Vec<f64>) {
    let jacobi = DMatrix::from_fn(n, n, |i, j| {
        let k = i.max(j) as f64;
        if i == j {
            1.0 / ((2.0 * k + 1.0) * (2.0 * k + 3.0))
        } else if i.abs_diff(j) == 1 {
            (k * (k + 1.0)).sqrt() / (2.0 * k + 1.0)
        } else {
            0.0
        }
    });
    let eigen = SymmetricEigen::new(jacobi);
    let mut rule: Vec<(f64, f64)> = (0..n)
        .map(|i| {
            let v0 = eigen.eigenvectors[(0, i)];
            (0.5 * (1.0 + eigen.eigenvalues[i]), 0.5 * v0 * v0)
        })
        .collect();
    rule.sort_by(|a, b| a.0.total_cmp(&b.0));
    rule.into_iter().unzip()
}

/// `P_n(x)` and `P_n'(x)` by the three-term recurrence.
fn legendre_with_derivative(n: usize, x: f64) -> (f64, f64) {
    let mut p0 = 1.0;
    let mut p1 = x;
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    let nf = n as f64;
    let d = nf * (x * p1 - p0) / (x * x - 1.0);
    (p1, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobi_u_integrates_monomials_times_u_exactly() {
        for n in 1..=12 {
            let (x, w) = gauss_jacobi_u_unit(n);
            assert!(x.windows(2).all(|p| p[0] < p[1]), "ascending for n={n}");
            assert!(x.iter().all(|&u| u > 0.0 && u < 1.0), "inside for n={n}");
            for deg in 0..(2 * n) {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(deg as i32)).sum();
                let exact = 1.0 / (deg as f64 + 2.0);
                assert!((q - exact).abs() < 1e-14, "n={n} deg={deg}: {q} vs {exact}");
            }
        }
    }

    #[test]
    fn integrates_monomials_exactly() {
        for n in 1..=12 {
            let (x, w) = gauss_legendre_unit(n);
            assert!(x.windows(2).all(|p| p[0] < p[1]), "ascending for n={n}");
            for deg in 0..(2 * n) {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(deg as i32)).sum();
                let exact = 1.0 / (deg as f64 + 1.0);
                assert!((q - exact).abs() < 1e-14, "n={n} deg={deg}: {q} vs {exact}");
            }
        }
    }
}
