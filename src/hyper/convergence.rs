//! The observed order of convergence of a Newton step, from its history.
//!
//! **Measure.** The size of the correction Newton would make at `u_k`,
//! `δ_k = √|Δu_k · R(u_k)| / √|Δu_0 · R(u_0)|` — the energy norm
//! `‖Δu_k‖_K` of the correction, relative to the step's first, i.e. the
//! square root of the step's `energies`. Near a solution `u*` with an
//! invertible tangent, `Δu_k = −K⁻¹R(u_k) = u* − u_k + O(‖u_k − u*‖²)`, so
//! `δ_k` measures the error in the energy norm, and quadratic convergence
//! reads `δ_{k+1} ≤ C δ_k²`. (The residual norm `‖R_k‖` weighs the error by
//! `K`: with a stiff tangent — penalty Dirichlet and contact terms — its
//! ratios mix components of very different stiffness, and the order read off
//! the residuals scatters between 1.2 and 2.2 on the same quadratic
//! iterations.)
//!
//! **Estimate.** From the last three corrections `δ_{n−2} > δ_{n−1}`, `δ_n`
//! above the round-off floor [`ROUND_OFF`]:
//! ```text
//! q = ln(δ_n / δ_{n−1}) / ln(δ_{n−1} / δ_{n−2}),      C = δ_n / δ_{n−1}²
//! ```
//! (`q → 2` for quadratic convergence, 1 for linear. For `δ_{k+1} = C δ_k²`
//! with one `C`, `q = 2` exactly; where the ratio `C_k = δ_{k+1}/δ_k²` moves
//! from `C₁` to `C₂` over the two transitions,
//! `q = 2 + ln(C₂/C₁) / ln(C₁ δ_{n−2})`: below 2 where it grows, above 2
//! where it falls, by less the smaller `C₁ δ_{n−2}`.)

/// Corrections at or below this relative size are round-off, not Newton:
/// the correction at a state whose residual is at machine precision.
pub const ROUND_OFF: f64 = 1e-14;

/// The estimated order `q` and constant `C` of the last iterations of a
/// step with relative correction energies `energies` (`|Δu_k·R_k| /
/// |Δu_0·R_0|`, one per linear solve); `None` with fewer than three
/// corrections above [`ROUND_OFF`], or when they do not decrease.
pub fn convergence_order(energies: &[f64]) -> Option<(f64, f64)> {
    let sizes: Vec<f64> = energies.iter().map(|e| e.abs().sqrt()).collect();
    let last = sizes.iter().rposition(|&d| d > ROUND_OFF)?;
    if last < 2 {
        return None;
    }
    let [a, b, c] = [sizes[last - 2], sizes[last - 1], sizes[last]];
    if !(b < a && c < b) {
        return None;
    }
    Some(((c / b).ln() / (b / a).ln(), c / (b * b)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Energies `δ_k²` of the sizes `δ_k`, with two round-off entries after.
    fn energies(sizes: &[f64]) -> Vec<f64> {
        let mut e: Vec<f64> = sizes.iter().map(|d| d * d).collect();
        e.extend([1e-31, 4e-32]);
        e
    }

    #[test]
    fn a_quadratic_sequence_has_order_two_and_its_constant() {
        // δ_{k+1} = 3 δ_k² from δ = 10⁻²: q = 2 exactly.
        let mut d = vec![1.0, 1e-2];
        while d.len() < 5 {
            let last = d[d.len() - 1];
            d.push(3.0 * last * last);
        }
        let (q, c) = convergence_order(&energies(&d)).unwrap();
        assert!((c - 3.0).abs() < 1e-9, "{c}");
        assert!((q - 2.0).abs() < 1e-9, "{q}");
    }

    #[test]
    fn a_quadratic_constant_that_grows_reads_below_two() {
        // C = 14 then 71 from δ = 1.6e-4 (the annuli's lowest step, level 3):
        // q = 2 + ln(71/14) / ln(14 · 1.6e-4) = 1.73.
        let (c1, c2, d0) = (14.0, 71.0, 1.6e-4);
        let d1 = c1 * d0 * d0;
        let d = [1.0, d0, d1, c2 * d1 * d1];
        let (q, c) = convergence_order(&energies(&d)).unwrap();
        let expected = 2.0 + (c2 / c1).ln() / (c1 * d0).ln();
        assert!(
            (q - expected).abs() < 1e-9 && (q - 1.73).abs() < 0.01,
            "{q}"
        );
        assert!((c - c2).abs() < 1e-9 * c2, "{c}");
    }

    #[test]
    fn a_linear_sequence_has_order_one() {
        let d: Vec<f64> = (0..6).map(|k| 0.1f64.powi(k)).collect();
        let (q, c) = convergence_order(&energies(&d)).unwrap();
        assert!((q - 1.0).abs() < 1e-9, "{q}");
        assert!((c - 0.1 / 1e-4).abs() < 1e-6 * c, "{c}");
    }

    #[test]
    fn too_short_or_stalled_histories_have_no_order() {
        assert_eq!(convergence_order(&[1.0, 1e-4]), None);
        assert_eq!(convergence_order(&energies(&[1.0, 1e-3])), None);
        assert_eq!(convergence_order(&[1.0, 1e-4, 2e-4, 1e-8]), None);
    }
}
