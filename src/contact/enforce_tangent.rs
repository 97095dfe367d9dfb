//! The contact tangent `K_c` in factored form: per active slave point, its
//! local dofs, `A = ∂y/∂u` (one column of 33 per local dof), the 33 × 33
//! `K_y`, and the second derivatives of the master's corner normals
//! ([`NormalTerms`]), so that the point's block is `Aᵀ K_y A` plus those.
//!
//! A Q1 point touches a hundred or more dofs (the slave cell, the master
//! cells of the hit patch's corners and of the vertices around them): the
//! dense blocks cost far more than the factors (`33 n + 1 089`), so the
//! tangent is kept factored and applied matrix-free,
//! `K v = Σ_p Aᵀ (K_y (A v_p))` in `O(33 n)` per point, `A` by its
//! nonzero entries (a few per column); its diagonal (for Jacobi) and the
//! assembled triplets are available too.

use faer::sparse::Triplet;

use super::enforce_gap::NVAR;
use crate::spatial::vec3::cross;

/// One active point's factors.
#[derive(Clone, Debug)]
pub struct PointTangent {
    /// Global dofs of the local columns (repeats allowed; they add up).
    dofs: Vec<usize>,
    /// `A`'s column per local dof, by its nonzero entries (a slave dof
    /// moves `x1` and one row of `F`, a master dof one corner or the
    /// anchor: a few of the 33): column `j` is `rows`/`values`
    /// `[starts[j]..starts[j + 1]]`, by increasing row.
    starts: Vec<u32>,
    rows: Vec<u8>,
    values: Vec<f64>,
    /// `K_y`, row-major.
    k_y: Vec<[f64; NVAR]>,
    /// The corner normals' second-derivative term.
    normals: NormalTerms,
}

/// A master vertex's current position as a function of the dofs:
/// `q = X + Σ_b weights[b] (u[dofs[b]], u[dofs[b] + 1], u[dofs[b] + 2])`.
#[derive(Clone, Debug)]
pub struct VertexShape {
    /// The first (x) global dof of each node of the vertex's cell.
    pub(super) dofs: Vec<usize>,
    pub(super) weights: Vec<f64>,
}

impl VertexShape {
    fn gather(&self, v: &[f64]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (&d, &w) in self.dofs.iter().zip(&self.weights) {
            (0..3).for_each(|c| out[c] += w * v[d + c]);
        }
        out
    }

    fn scatter(&self, x: [f64; 3], out: &mut [f64]) {
        for (&d, &w) in self.dofs.iter().zip(&self.weights) {
            (0..3).for_each(|c| out[d + c] += w * x[c]);
        }
    }
}

/// One term `μ · (δq_a × δq_b)` of the quadratic form (counted twice: the
/// form is `2 Σ μ·(δq_a × δq_b)`), between the vertices in slots `a`, `b`.
#[derive(Clone, Copy, Debug)]
pub struct NormalPair {
    pub(super) a: usize,
    pub(super) b: usize,
    pub(super) mu: [f64; 3],
}

/// `Σ_k μ_k · ∇²_u m_k` for the corner normals `m_k` (see
/// `enforce_normals`): as a matrix, the pair `(a, b)` has the block
/// `S = −[μ]×` (`x·S y = μ·(x × y)`) between `q_a` and `q_b` and `Sᵀ`
/// between `q_b` and `q_a`; `S` is skew, so the diagonal gains nothing.
#[derive(Clone, Debug, Default)]
pub struct NormalTerms {
    pub(super) vertices: Vec<VertexShape>,
    pub(super) pairs: Vec<NormalPair>,
}

impl NormalTerms {
    /// `out += (Σ μ·∇²m) v`.
    fn apply_add(&self, v: &[f64], out: &mut [f64]) {
        for p in &self.pairs {
            let (a, b) = (&self.vertices[p.a], &self.vertices[p.b]);
            let (va, vb) = (a.gather(v), b.gather(v));
            a.scatter(cross(vb, p.mu), out);
            b.scatter(cross(p.mu, va), out);
        }
    }

    /// The assembled entries `(row, column, value)`.
    fn triplets(&self, out: &mut Vec<Triplet<usize, usize, f64>>) {
        for p in &self.pairs {
            let m = p.mu;
            let s = [[0.0, m[2], -m[1]], [-m[2], 0.0, m[0]], [m[1], -m[0], 0.0]];
            let (a, b) = (&self.vertices[p.a], &self.vertices[p.b]);
            for (&da, &wa) in a.dofs.iter().zip(&a.weights) {
                for (&db, &wb) in b.dofs.iter().zip(&b.weights) {
                    for (r, row) in s.iter().enumerate() {
                        for (c, &value) in row.iter().enumerate() {
                            let x = wa * wb * value;
                            out.push(Triplet::new(da + r, db + c, x));
                            out.push(Triplet::new(db + c, da + r, x));
                        }
                    }
                }
            }
        }
    }
}

fn dot(a: &[f64; NVAR], b: &[f64; NVAR]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl PointTangent {
    /// The factors of a point with the local `dofs`, `A`'s `columns` (one
    /// per dof), `K_y` and the normals' term.
    pub(super) fn new(
        dofs: Vec<usize>,
        columns: &[[f64; NVAR]],
        k_y: Vec<[f64; NVAR]>,
        normals: NormalTerms,
    ) -> PointTangent {
        assert_eq!(dofs.len(), columns.len(), "a column per dof");
        let (mut starts, mut rows, mut values) = (vec![0], Vec::new(), Vec::new());
        for c in columns {
            for (r, &x) in c.iter().enumerate().filter(|(_, &x)| x != 0.0) {
                rows.push(r as u8);
                values.push(x);
            }
            starts.push(rows.len() as u32);
        }
        PointTangent {
            dofs,
            starts,
            rows,
            values,
            k_y,
            normals,
        }
    }

    /// Column `j`'s nonzero entries `(row, value)`, by increasing row.
    fn entries(&self, j: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let range = self.starts[j] as usize..self.starts[j + 1] as usize;
        self.rows[range.clone()]
            .iter()
            .zip(&self.values[range])
            .map(|(&r, &x)| (r as usize, x))
    }

    /// Column `j`, all 33 entries.
    fn column(&self, j: usize) -> [f64; NVAR] {
        let mut c = [0.0; NVAR];
        self.entries(j).for_each(|(r, x)| c[r] = x);
        c
    }

    /// `K_y A`, one column of 33 per local dof.
    fn k_y_times_columns(&self) -> Vec<[f64; NVAR]> {
        (0..self.dofs.len())
            .map(|j| {
                let c = self.column(j);
                std::array::from_fn(|r| dot(&self.k_y[r], &c))
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
            for (j, &d) in p.dofs.iter().enumerate() {
                p.entries(j).for_each(|(r, x)| av[r] += x * v[d]);
            }
            let kav: [f64; NVAR] = std::array::from_fn(|r| dot(&p.k_y[r], &av));
            for (j, &d) in p.dofs.iter().enumerate() {
                out[d] += p.entries(j).map(|(r, x)| x * kav[r]).sum::<f64>();
            }
            p.normals.apply_add(v, out);
        }
    }

    /// `out += diag(K_c)`. A dof may appear in several local columns (a
    /// master node shared by the hit cell and the anchor cell): its diagonal
    /// entry sums every pair of its columns.
    pub fn add_diagonal(&self, out: &mut [f64]) {
        for p in &self.points {
            let ka = p.k_y_times_columns();
            for (a, &da) in p.dofs.iter().enumerate() {
                let ca = p.column(a);
                for (kb, &db) in ka.iter().zip(&p.dofs) {
                    if da == db {
                        out[da] += dot(&ca, kb);
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
            for (a, &da) in p.dofs.iter().enumerate() {
                let ca = p.column(a);
                for (kb, &db) in ka.iter().zip(&p.dofs) {
                    out.push(Triplet::new(da, db, dot(&ca, kb)));
                }
            }
            p.normals.triplets(&mut out);
        }
        out
    }
}
