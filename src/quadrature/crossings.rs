//! Where two curves on a face of a box cross: the points at which the lower
//! dimension of Saye's algorithm ([`super::saye`]) splits its outer integral,
//! since its integrand has a kink there.

use crate::geometry::scalar::{Dual, Interval};
use crate::geometry::Geometry;
use crate::spatial::Aabb;

use super::restricted::Restricted;

/// The `x_m` coordinates, strictly inside `b`, of the points where two of the
/// curves `fns` (functions of `x_k` and `x_m` on a face) cross: Newton from a
/// 3×3 grid of seeds, sorted and distinct.
pub(super) fn crossings(
    g: &Geometry,
    fns: &[(Restricted, Dual<Interval>)],
    b: &Aabb,
    k: usize,
    m: usize,
) -> Vec<f64> {
    let size = (b.hi[k] - b.lo[k]).max(b.hi[m] - b.lo[m]);
    let tol = 1e-9 * size;
    let mut out: Vec<f64> = Vec::new();
    for (i, (fa, _)) in fns.iter().enumerate() {
        // Curves of one leaf (its restrictions to two faces) cross where a
        // smooth surface leaves the box through an edge: no kink of the
        // integrand worth a split, and the smooth case stays as it was.
        for (fb, _) in fns[i + 1..]
            .iter()
            .filter(|(fb, _)| fb.surface() != fa.surface())
        {
            for seed in 0..9 {
                // Seeds at a quarter, half and three quarters of each side.
                let mut x = b.lo;
                x[k] += 0.25 * (1 + seed % 3) as f64 * (b.hi[k] - b.lo[k]);
                x[m] += 0.25 * (1 + seed / 3) as f64 * (b.hi[m] - b.lo[m]);
                let Some(p) = newton_2d(g, fa, fb, x, k, m, size) else {
                    continue;
                };
                let inside = p[k] > b.lo[k] - tol && p[k] < b.hi[k] + tol;
                if inside
                    && p[m] > b.lo[m] + tol
                    && p[m] < b.hi[m] - tol
                    && out.iter().all(|c| (c - p[m]).abs() > tol)
                {
                    out.push(p[m]);
                }
            }
        }
    }
    out.sort_by(f64::total_cmp);
    out
}

/// A common zero of `fa` and `fb` near `x` (Newton in `x_k`, `x_m`).
fn newton_2d(
    g: &Geometry,
    fa: &Restricted,
    fb: &Restricted,
    mut x: [f64; 3],
    k: usize,
    m: usize,
    size: f64,
) -> Option<[f64; 3]> {
    for _ in 0..30 {
        let (va, da) = fa.value_grad(g, x);
        let (vb, db) = fb.value_grad(g, x);
        let det = da[k] * db[m] - da[m] * db[k];
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let dk = (va * db[m] - vb * da[m]) / det;
        let dm = (da[k] * vb - db[k] * va) / det;
        x[k] -= dk;
        x[m] -= dm;
        if !(dk.is_finite() && dm.is_finite()) || dk.abs().max(dm.abs()) > 4.0 * size {
            return None;
        }
        if dk.abs().max(dm.abs()) <= 1e-14 * size {
            return Some(x);
        }
    }
    None
}
