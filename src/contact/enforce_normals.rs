//! The master patch's corner normals as kinematic variables: their first
//! derivatives (columns of `A = ∂y/∂u`) and the second-derivative term they
//! add to the contact tangent.
//!
//! The normal at corner `k` of the hit patch is the current vertex normal
//! `m_k = Σ_f n_f` over the triangles `f` around the vertex, with
//! `n_f = (q1 − q0) × (q2 − q0) = q0 × q1 + q1 × q2 + q2 × q0` from the
//! triangle's current corners `q_a = X_a + u_m(X_a)` (each evaluated in its
//! vertex's cell, `Σ_b N_b(X_a) u_b`). So
//! `∂n_f/∂q_a · δ = δ × (q_{a+1} − q_{a+2})` (corners cyclic), which gives
//! the columns, and `m_k` is quadratic in the positions: with the
//! residual's weights `μ_k = R_y[m_k]`, the tangent gains
//! `Σ_k μ_k · ∇²_u m_k`, the quadratic form `2 Σ μ_k · (δq_a × δq_{a+1})`
//! over the triangles' consecutive corners — kept as vertex pairs with their
//! summed `μ` ([`NormalTerms`]).

use std::collections::HashMap;

use super::enforce::ContactBody;
use super::enforce_gap::{M, NVAR};
use super::enforce_local::{cell_shape, Jacobian};
use super::enforce_tangent::{NormalPair, NormalTerms, VertexShape};
use super::surface::Surface;
use crate::spatial::vec3::{cross, sub};

/// The corners' vertices and their neighbourhoods: which vertex positions
/// enter `m_k`, and how each depends on the dofs.
pub struct CornerNormals {
    /// Per vertex met, its slot in `shapes`.
    slots: HashMap<usize, usize>,
    shapes: Vec<VertexShape>,
    /// Per corner, the triangles around it.
    rings: [Vec<usize>; 3],
}

impl CornerNormals {
    /// The shapes of the vertices around the corners `corners` (vertex
    /// indices of the master surface) and the columns of `∂m_k/∂u`, added to
    /// `jac` (one column per dof: a dof already there gets its entries).
    pub fn add_columns(
        jac: &mut Jacobian,
        body: &ContactBody,
        surface: &Surface,
        current: &[[f64; 3]],
        corners: [usize; 3],
    ) -> CornerNormals {
        let mut normals = CornerNormals {
            slots: HashMap::new(),
            shapes: Vec::new(),
            rings: corners.map(|v| surface.triangles_at_vertex(v).map(|t| t as usize).collect()),
        };
        for (k, &corner) in corners.iter().enumerate() {
            for f in surface.triangles_at_vertex(corner).map(|t| t as usize) {
                let v = surface.triangles[f].vertices.map(|v| v as usize);
                for a in 0..3 {
                    let d = sub(current[v[(a + 1) % 3]], current[v[(a + 2) % 3]]);
                    let slot = normals.slot(body, surface, v[a]);
                    let shape = &normals.shapes[slot];
                    for (&node, &w) in shape.dofs.iter().zip(&shape.weights) {
                        for i in 0..3 {
                            let mut e = [0.0; 3];
                            e[i] = w;
                            let dm = cross(e, d);
                            let col = jac.column(node + i);
                            (0..3).for_each(|c| col[M + 3 * k + c] += dm[c]);
                        }
                    }
                }
            }
        }
        normals
    }

    /// The slot of vertex `v`, its shape computed on first use.
    fn slot(&mut self, body: &ContactBody, surface: &Surface, v: usize) -> usize {
        if let Some(&s) = self.slots.get(&v) {
            return s;
        }
        let (dofs, weights, _) = cell_shape(body, surface.vertex_cell[v], surface.vertices[v]);
        self.shapes.push(VertexShape {
            dofs: dofs.iter().step_by(3).copied().collect(),
            weights,
        });
        self.slots.insert(v, self.shapes.len() - 1);
        self.shapes.len() - 1
    }

    /// The tangent's second-derivative term for the residual in `y`,
    /// `r_y` (whose entries at `m_k` are the weights `μ_k`).
    pub fn second_derivatives(self, surface: &Surface, r_y: &[f64; NVAR]) -> NormalTerms {
        let mut pairs: HashMap<(usize, usize), [f64; 3]> = HashMap::new();
        for (k, ring) in self.rings.iter().enumerate() {
            let mu = [0, 1, 2].map(|c| r_y[M + 3 * k + c]);
            for &f in ring {
                let v = surface.triangles[f].vertices.map(|v| v as usize);
                for a in 0..3 {
                    let (sa, sb) = (self.slots[&v[a]], self.slots[&v[(a + 1) % 3]]);
                    // μ·(δa × δb) = −μ·(δb × δa): one key per unordered pair.
                    let (key, sign) = if sa < sb {
                        ((sa, sb), 1.0)
                    } else {
                        ((sb, sa), -1.0)
                    };
                    let sum = pairs.entry(key).or_insert([0.0; 3]);
                    (0..3).for_each(|c| sum[c] += sign * mu[c]);
                }
            }
        }
        let mut pairs: Vec<NormalPair> = pairs
            .into_iter()
            .map(|((a, b), mu)| NormalPair { a, b, mu })
            .collect();
        pairs.sort_by_key(|p| (p.a, p.b));
        NormalTerms {
            vertices: self.shapes,
            pairs,
        }
    }
}
