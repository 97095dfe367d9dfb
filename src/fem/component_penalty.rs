//! The Dirichlet penalty of the boundary points that hold only some of the
//! three components (rollers, symmetry planes, `["0", "free", "free"]`):
//!
//! ```text
//! K_p,c[3a+i, 3b+i] = Σ_q m_{q,i} w_q (β/h) N_a(x_q) N_b(x_q),
//! ```
//! with `m_q` the point's component mask. Points that hold all three
//! components carry the same term with `m = (1, 1, 1)`, which is a scalar mass
//! and lives in the cut cells' fitted weights ([`super::moment_fit`],
//! [`super::q1_forms`]); a partial mask is not a scalar mass, so its points are
//! kept here as three dense `npc × npc` masses per cell (one per component)
//! and added to the cell's product after the main apply. Only the cells a
//! partial Dirichlet part crosses have one: the boundary cells along
//! rollers and symmetry planes (hundreds on a contact case's faces, so the
//! apply runs over them in parallel and touches only the held components).

use std::collections::HashMap;

use rayon::prelude::*;

use crate::cells::Cells;
use crate::discrete::dofs::DofMap;
use crate::element::shape_values;
use crate::grid::Grid;

/// The components held at a boundary point `(tag, x)`; `None` where no
/// Dirichlet condition applies.
pub type HeldComponents<'a> = dyn Fn(u16, [f64; 3]) -> Option<[bool; 3]> + Sync + 'a;

/// The partial-mask penalty masses of the cut cells that have such points.
#[derive(Clone, Debug, Default)]
pub struct ComponentPenalty {
    /// Nodes per cell.
    npc: usize,
    /// Per cell with a mass: its nodes' active indices (`npc` each).
    nodes: Vec<u32>,
    /// Per cell: the components some point of it holds (the others' masses
    /// are zero).
    held: Vec<[bool; 3]>,
    /// Per cell: three `npc × npc` masses (component 0, 1, 2), row-major.
    masses: Vec<f64>,
    /// The position in `cells` of a cut-cell slot.
    by_slot: HashMap<usize, usize>,
}

impl ComponentPenalty {
    /// The masses of the cut cells of `cells` whose boundary points have a
    /// partial mask (`held(tag, x)`; `None` off the Dirichlet parts),
    /// weighted by `β/h`.
    pub fn new(
        grid: &Grid,
        cells: &Cells,
        dofs: &DofMap,
        beta: f64,
        held: &HeldComponents<'_>,
    ) -> ComponentPenalty {
        let order = dofs.order;
        let npc = order.nodes_per_cell();
        let per_cell: Vec<(usize, [bool; 3], Vec<f64>)> = (0..cells.cut.len())
            .into_par_iter()
            .filter_map(|s| {
                let cell = cells.cut[s];
                let lo = grid.cell_box(cell).lo;
                let mut masses: Option<Vec<f64>> = None;
                let mut any = [false; 3];
                let mut n = vec![0.0; npc];
                for q in cells.surface_points(s) {
                    let Some(mask) = held(q.tag, q.x).filter(|m| *m != [true; 3]) else {
                        continue;
                    };
                    let xi = [0, 1, 2].map(|a| (q.x[a] - lo[a]) / grid.h);
                    shape_values(order, xi, &mut n);
                    let m = masses.get_or_insert_with(|| vec![0.0; 3 * npc * npc]);
                    let scale = q.w * beta / grid.h;
                    for (i, held) in mask.iter().enumerate() {
                        if !held {
                            continue;
                        }
                        any[i] = true;
                        let mi = &mut m[i * npc * npc..(i + 1) * npc * npc];
                        for a in 0..npc {
                            for b in 0..npc {
                                mi[a * npc + b] += scale * n[a] * n[b];
                            }
                        }
                    }
                }
                masses.map(|m| (s, any, m))
            })
            .collect();
        let mut out = ComponentPenalty {
            npc,
            ..ComponentPenalty::default()
        };
        let mut nodes = vec![0usize; npc];
        for (s, any, m) in per_cell {
            out.by_slot.insert(s, out.held.len());
            dofs.cell_active_nodes(grid, cells.cut[s], &mut nodes);
            out.nodes.extend(nodes.iter().map(|&a| a as u32));
            out.held.push(any);
            out.masses.extend(m);
        }
        out
    }

    /// The mass of component `i` of the `k`-th cell with a mass.
    fn mass(&self, k: usize, i: usize) -> &[f64] {
        let n2 = self.npc * self.npc;
        &self.masses[(3 * k + i) * n2..(3 * k + i + 1) * n2]
    }

    /// `y += K_p,c x`: each cell's product in parallel, then added in.
    pub fn apply_add(&self, x: &[f64], y: &mut [f64]) {
        if self.held.is_empty() {
            return;
        }
        let npc = self.npc;
        let mut products = vec![[0.0; 3]; npc * self.held.len()];
        products
            .par_chunks_mut(npc)
            .enumerate()
            .for_each(|(k, out)| {
                let nodes = &self.nodes[k * npc..(k + 1) * npc];
                for i in (0..3).filter(|&i| self.held[k][i]) {
                    let m = self.mass(k, i);
                    for (o, row) in out.iter_mut().zip(m.chunks_exact(npc)) {
                        o[i] = row
                            .iter()
                            .zip(nodes)
                            .map(|(v, &nb)| v * x[3 * nb as usize + i])
                            .sum();
                    }
                }
            });
        for (nodes, product) in self.nodes.chunks_exact(npc).zip(products.chunks_exact(npc)) {
            for (&na, p) in nodes.iter().zip(product) {
                let a = 3 * na as usize;
                for i in 0..3 {
                    y[a + i] += p[i];
                }
            }
        }
    }

    /// Adds slot `s`'s masses to its dense cell matrix (row-major, side
    /// `3 npc`, dof `3a + i`).
    pub fn add_to_matrix(&self, s: usize, matrix: &mut [f64]) {
        let Some(&k) = self.by_slot.get(&s) else {
            return;
        };
        let (npc, ne) = (self.npc, 3 * self.npc);
        for i in 0..3 {
            let m = self.mass(k, i);
            for a in 0..npc {
                for b in 0..npc {
                    matrix[(3 * a + i) * ne + 3 * b + i] += m[a * npc + b];
                }
            }
        }
    }

    /// Adds slot `s`'s masses to its cell matrix's diagonal (dof `3a + i`).
    pub fn add_to_diagonal(&self, s: usize, diagonal: &mut [f64]) {
        let Some(&k) = self.by_slot.get(&s) else {
            return;
        };
        let npc = self.npc;
        for i in 0..3 {
            let m = self.mass(k, i);
            for a in 0..npc {
                diagonal[3 * a + i] += m[a * npc + a];
            }
        }
    }

    /// Slot `s`'s masses, one `npc × npc` row-major per component, or
    /// `None` where it has none.
    pub fn masses_of(&self, s: usize) -> Option<[&[f64]; 3]> {
        let &k = self.by_slot.get(&s)?;
        Some([0, 1, 2].map(|i| self.mass(k, i)))
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        8 * (self.masses.len() + self.held.len()) + 4 * self.nodes.len() + 3 * self.held.len()
    }
}
