//! The contact tangent `K_c` in factored form: per active slave point, its
//! local dofs, `A = ∂y/∂u` (one column of 24 per local dof) and the 24 × 24
//! `K_y`, so that the point's block is `Aᵀ K_y A` (rank ≤ 24).
//!
//! A Q1 point touches 48–72 dofs, a Q2 point 162–243: the dense blocks
//! (2 304 to 59 049 entries) cost far more than the factors (`24 n + 576`),
//! so the tangent is kept factored and applied matrix-free,
//! `K v = Σ_p Aᵀ (K_y (A v_p))` in `O(24 n)` per point; its diagonal (for
//! Jacobi) and the assembled triplets are available too.

use faer::sparse::Triplet;

use super::enforce_gap::NVAR;

/// One active point's factors.
#[derive(Clone, Debug)]
pub struct PointTangent {
    /// Global dofs of the local columns (repeats allowed; they add up).
    pub(super) dofs: Vec<usize>,
    /// `A`'s column per local dof.
    pub(super) columns: Vec<[f64; NVAR]>,
    /// `K_y`, row-major.
    pub(super) k_y: Vec<[f64; NVAR]>,
}

fn dot(a: &[f64; NVAR], b: &[f64; NVAR]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl PointTangent {
    /// `K_y A`, one column of 24 per local dof.
    fn k_y_times_columns(&self) -> Vec<[f64; NVAR]> {
        self.columns
            .iter()
            .map(|c| {
                let mut out = [0.0; NVAR];
                (0..NVAR).for_each(|r| out[r] = dot(&self.k_y[r], c));
                out
            })
            .collect()
    }
}

/// `K_c` as the sum of its points' factored blocks.
#[derive(Clone, Debug, Default)]
pub struct ContactTangent {
    pub(super) points: Vec<PointTangent>,
}

impl ContactTangent {
    /// No active point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// `out += K_c v` (global vectors).
    pub fn apply_add(&self, v: &[f64], out: &mut [f64]) {
        for p in &self.points {
            let mut av = [0.0; NVAR];
            for (c, &d) in p.columns.iter().zip(&p.dofs) {
                (0..NVAR).for_each(|r| av[r] += c[r] * v[d]);
            }
            let kav: [f64; NVAR] = std::array::from_fn(|r| dot(&p.k_y[r], &av));
            for (c, &d) in p.columns.iter().zip(&p.dofs) {
                out[d] += dot(c, &kav);
            }
        }
    }

    /// `out += diag(K_c)`. A dof may appear in several local columns (a
    /// master node shared by the hit cell and the anchor cell): its diagonal
    /// entry sums every pair of its columns.
    pub fn add_diagonal(&self, out: &mut [f64]) {
        for p in &self.points {
            let ka = p.k_y_times_columns();
            for (ca, &da) in p.columns.iter().zip(&p.dofs) {
                for (kb, &db) in ka.iter().zip(&p.dofs) {
                    if da == db {
                        out[da] += dot(ca, kb);
                    }
                }
            }
        }
    }

    /// The assembled entries `(row, column, value)`, repeats to be summed.
    pub fn triplets(&self) -> Vec<Triplet<usize, usize, f64>> {
        let mut out = Vec::new();
        for p in &self.points {
            let ka = p.k_y_times_columns();
            for (ca, &da) in p.columns.iter().zip(&p.dofs) {
                for (kb, &db) in ka.iter().zip(&p.dofs) {
                    out.push(Triplet::new(da, db, dot(ca, kb)));
                }
            }
        }
        out
    }
}
