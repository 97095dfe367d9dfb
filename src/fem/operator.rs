//! The elasticity operator `A = K + K_p (+ K_S)` on the active dofs, applied
//! matrix-free, and the same operator assembled as a sparse matrix (faer).
//!
//! Every inside cell has the same element matrix `h K_ref` (DESIGN §2.2), so
//! inside cells store nothing; each cut cell stores its dense matrix
//! `Σ_vol w BᵀDB + Σ_{Dirichlet points} w (β/h) NᵀN` (DESIGN §3.1), and later
//! terms (the S-stabilisation) are added to the cells they touch.
//!
//! The apply is node-centred, as the GPU kernel will be: each active node
//! gathers, from the (up to 8) cells around it, its rows of the cell matrix
//! times the cell's displacements, `y_n = Σ_{c ∋ n} K_c[n, :] x_c`. No two
//! threads write the same entry, so no atomics and no colouring are needed.
//! For Q1 the apply runs the plan of [`super::fast_apply`] (the constant
//! interior stencil along runs, the gather elsewhere); the generic gather
//! ([`ElasticOperator::apply_gather`]) is the reference and serves Q2.

use nalgebra::DMatrix;
use rayon::prelude::*;

use std::sync::Mutex;

use super::dofs::{node_cells, DofMap};
use super::fast_apply::{FastApply, Matrices};
use crate::backend::LinearOperator;
use crate::cells::{CellKind, Cells};
use crate::element::reference::{elasticity_matrix, reference_stiffness, strain_displacement};
use crate::element::{shape_values, ElementOrder};
use crate::grid::Grid;

/// Slot of an outside cell.
pub const OUTSIDE: u32 = u32::MAX;
/// Slot of an inside cell (the shared reference matrix).
pub const INSIDE: u32 = u32::MAX - 1;

/// The assembled-on-demand, applied-matrix-free elasticity operator.
#[derive(Clone, Debug)]
pub struct ElasticOperator {
    pub grid: Grid,
    pub dofs: DofMap,
    /// Dofs per cell, `3 · nodes_per_cell`.
    ne: usize,
    /// Per cell: `OUTSIDE`, `INSIDE` or the index of its own matrix.
    slot: Vec<u32>,
    /// `h K_ref`, row-major `ne × ne`.
    k_inside: Vec<f64>,
    /// Own matrices, row-major `ne × ne` each, and the cell of each.
    k_own: Vec<f64>,
    own_cells: Vec<usize>,
    /// The fast apply's plan (Q1 only) and its reused scratch.
    fast: Option<FastApply>,
    scratch: Scratch,
}

/// A reusable scratch vector; a clone starts empty.
#[derive(Debug, Default)]
struct Scratch(Mutex<Vec<f64>>);

impl Clone for Scratch {
    fn clone(&self) -> Self {
        Scratch::default()
    }
}

/// What the operator needs to know about the material and the Dirichlet parts.
#[derive(Clone, Copy, Debug)]
pub struct OperatorParams<'a> {
    pub young: f64,
    pub poisson: f64,
    /// Penalty `β = k1 E`; the Dirichlet term is `w (β/h) NᵀN`.
    pub beta: f64,
    /// Per boundary tag id: does it carry a Dirichlet condition?
    pub dirichlet_tags: &'a [bool],
}

impl ElasticOperator {
    /// Builds the operator: reference matrix and cut-cell matrices (in parallel).
    pub fn new(grid: &Grid, cells: &Cells, order: ElementOrder, p: &OperatorParams) -> Self {
        let dofs = DofMap::new(grid, cells, order);
        let ne = 3 * order.nodes_per_cell();
        let k_ref = reference_stiffness(order, p.young, p.poisson) * grid.h;
        let k_inside: Vec<f64> = row_major(&k_ref);
        let mut slot = vec![OUTSIDE; grid.num_cells()];
        for (c, k) in cells.kinds.iter().enumerate() {
            if *k == CellKind::Inside {
                slot[c] = INSIDE;
            }
        }
        for (i, &c) in cells.cut.iter().enumerate() {
            slot[c] = i as u32;
        }
        let k_own: Vec<f64> = (0..cells.cut.len())
            .into_par_iter()
            .flat_map_iter(|i| row_major(&cut_cell_matrix(grid, cells, i, order, p)))
            .collect();
        let mut op = ElasticOperator {
            grid: grid.clone(),
            dofs,
            ne,
            slot,
            k_inside,
            k_own,
            own_cells: cells.cut.clone(),
            fast: None,
            scratch: Scratch::default(),
        };
        if order == ElementOrder::Q1 {
            op.fast = Some(FastApply::new(
                grid,
                &op.matrices(),
                &op.dofs.active_to_node,
            ));
        }
        op
    }

    /// The data the fast apply reads.
    fn matrices(&self) -> Matrices<'_> {
        Matrices {
            slot: &self.slot,
            inside: &self.k_inside,
            own: &self.k_own,
            own_cells: &self.own_cells,
            node_to_active: &self.dofs.node_to_active,
        }
    }

    /// The fast apply's plan (Q1), for reports.
    pub fn fast_apply(&self) -> Option<&FastApply> {
        self.fast.as_ref()
    }

    /// The matrix of a cell, row-major, or `None` for an outside cell.
    pub fn cell_matrix(&self, cell: usize) -> Option<&[f64]> {
        let ne2 = self.ne * self.ne;
        match self.slot[cell] {
            OUTSIDE => None,
            INSIDE => Some(&self.k_inside),
            s => Some(&self.k_own[s as usize * ne2..(s as usize + 1) * ne2]),
        }
    }

    /// Adds `m` (row-major `ne × ne`) to a cut cell's own matrix.
    pub fn add_to_cut_cell(&mut self, cell: usize, m: &[f64]) {
        let s = self.slot[cell];
        assert!(s != OUTSIDE && s != INSIDE, "cell {cell} has no own matrix");
        let ne2 = self.ne * self.ne;
        for (k, v) in self.k_own[s as usize * ne2..(s as usize + 1) * ne2]
            .iter_mut()
            .zip(m)
        {
            *k += v;
        }
    }

    /// Dofs per cell, `3 · nodes_per_cell` (the side of every cell matrix).
    pub fn dofs_per_cell(&self) -> usize {
        self.ne
    }

    /// Per grid cell: [`OUTSIDE`], [`INSIDE`] or the index of its own matrix in
    /// [`Self::own_matrices`] (what a device backend uploads).
    pub fn cell_slots(&self) -> &[u32] {
        &self.slot
    }

    /// The shared inside-cell matrix `h K_ref`, row-major `ne × ne`.
    pub fn inside_matrix(&self) -> &[f64] {
        &self.k_inside
    }

    /// The own matrices of the cut cells, row-major `ne × ne` each, back to back
    /// in slot order (stabilisation terms included once added).
    pub fn own_matrices(&self) -> &[f64] {
        &self.k_own
    }

    /// Cells with their own matrix.
    pub fn own_cells(&self) -> &[usize] {
        &self.own_cells
    }

    /// Bytes of operator data (matrices, maps and the fast apply's plan), for
    /// the memory reports; the apply's scratch (three vectors) is not counted.
    pub fn bytes(&self) -> usize {
        8 * (self.k_inside.len() + self.k_own.len())
            + 4 * (self.slot.len()
                + self.dofs.node_to_active.len()
                + self.dofs.active_to_node.len())
            + self.fast.as_ref().map_or(0, FastApply::bytes)
    }

    /// `y = A x` by the generic node-centred gather (see the module doc): the
    /// reference the fast apply is tested against, and the Q2 apply.
    pub fn apply_gather(&self, x: &[f64], y: &mut [f64]) {
        let npc = self.dofs.order.nodes_per_cell();
        y.par_chunks_mut(3)
            .enumerate()
            .with_min_len(64)
            .for_each_init(
                || (vec![0usize; npc], vec![0.0; 3 * npc]),
                |(nodes, xe), (a, yn)| {
                    yn.fill(0.0);
                    self.for_node_cells(a, |cell, l, k| {
                        self.dofs.cell_active_nodes(&self.grid, cell, nodes);
                        for (m, &an) in nodes.iter().enumerate() {
                            xe[3 * m..3 * m + 3].copy_from_slice(&x[3 * an..3 * an + 3]);
                        }
                        for i in 0..3 {
                            let row = &k[(3 * l + i) * self.ne..(3 * l + i + 1) * self.ne];
                            let mut s = 0.0;
                            for j in 0..self.ne {
                                s += row[j] * xe[j];
                            }
                            yn[i] += s;
                        }
                    });
                },
            );
    }

    /// Calls `f(cell, local, matrix)` for the cells around an active node.
    fn for_node_cells(&self, active: usize, mut f: impl FnMut(usize, usize, &[f64])) {
        let node = self.dofs.active_to_node[active] as usize;
        let mut around = Vec::with_capacity(8);
        node_cells(&self.grid, self.dofs.order, node, &mut around);
        for &(cell, local) in &around {
            if let Some(k) = self.cell_matrix(cell) {
                f(cell, local, k);
            }
        }
    }

    /// Rows of the matrix for an active node, as (column dof, value) triples
    /// per component, summed over cells: for the assembly and its tests.
    fn node_rows(&self, active: usize) -> [Vec<(usize, f64)>; 3] {
        let npc = self.dofs.order.nodes_per_cell();
        let mut nodes = vec![0; npc];
        let mut rows: [Vec<(usize, f64)>; 3] = Default::default();
        self.for_node_cells(active, |cell, l, k| {
            self.dofs.cell_active_nodes(&self.grid, cell, &mut nodes);
            for i in 0..3 {
                let row = &k[(3 * l + i) * self.ne..(3 * l + i + 1) * self.ne];
                for (m, &a) in nodes.iter().enumerate() {
                    for j in 0..3 {
                        rows[i].push((3 * a + j, row[3 * m + j]));
                    }
                }
            }
        });
        for r in &mut rows {
            r.sort_by_key(|e| e.0);
            r.dedup_by(|b, a| {
                if a.0 == b.0 {
                    a.1 += b.1;
                    true
                } else {
                    false
                }
            });
        }
        rows
    }

    /// The operator as a faer sparse matrix (symmetric, so CSR = CSC).
    pub fn assemble(&self) -> faer::sparse::SparseColMat<usize, f64> {
        let n = self.dofs.ndofs();
        let blocks: Vec<[Vec<(usize, f64)>; 3]> = (0..self.dofs.num_active())
            .into_par_iter()
            .map(|a| self.node_rows(a))
            .collect();
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        let mut values = Vec::new();
        col_ptr.push(0);
        for rows in &blocks {
            for r in rows {
                for &(c, v) in r {
                    row_idx.push(c);
                    values.push(v);
                }
                col_ptr.push(row_idx.len());
            }
        }
        let symbolic =
            faer::sparse::SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        faer::sparse::SparseColMat::new(symbolic, values)
    }
}

impl LinearOperator for ElasticOperator {
    fn nrows(&self) -> usize {
        self.dofs.ndofs()
    }

    /// `y = A x`: the fast plan for Q1, the generic gather otherwise.
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let Some(fast) = &self.fast else {
            return self.apply_gather(x, y);
        };
        let mut local = Vec::new();
        let mut guard = self.scratch.0.try_lock();
        // A concurrent apply holds the shared scratch: use a fresh one.
        let xs = guard.as_deref_mut().unwrap_or(&mut local);
        xs.resize(fast.scratch_len(), 0.0);
        fast.apply(&self.matrices(), &self.dofs.active_to_node, x, y, xs);
    }

    fn diagonal(&self) -> Vec<f64> {
        let mut d = vec![0.0; self.dofs.ndofs()];
        d.par_chunks_mut(3).enumerate().for_each(|(a, dn)| {
            self.for_node_cells(a, |_, l, k| {
                for i in 0..3 {
                    dn[i] += k[(3 * l + i) * self.ne + 3 * l + i];
                }
            });
        });
        d
    }
}

/// The assembled operator, applied with faer's sparse × dense product.
pub struct AssembledOperator(pub faer::sparse::SparseColMat<usize, f64>);

impl LinearOperator for AssembledOperator {
    fn nrows(&self) -> usize {
        self.0.nrows()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let n = self.0.nrows();
        let xs = faer::MatRef::from_column_major_slice(x, n, 1);
        let ys = faer::MatMut::from_column_major_slice_mut(y, n, 1);
        // A is symmetric: Aᵀ x, computed column by column, is A x.
        faer::sparse::linalg::matmul::sparse_dense_matmul(
            ys,
            faer::Accum::Replace,
            self.0.as_ref(),
            xs,
            1.0,
            faer::Par::Seq,
        );
    }

    fn diagonal(&self) -> Vec<f64> {
        let a = self.0.as_ref();
        (0..a.ncols())
            .map(|j| {
                let rows = a.row_idx_of_col_raw(j);
                let vals = a.val_of_col(j);
                rows.iter()
                    .zip(vals)
                    .filter(|(r, _)| **r == j)
                    .map(|(_, v)| *v)
                    .sum()
            })
            .collect()
    }
}

fn row_major(m: &DMatrix<f64>) -> Vec<f64> {
    let mut out = Vec::with_capacity(m.nrows() * m.ncols());
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            out.push(m[(i, j)]);
        }
    }
    out
}

/// `Σ_vol w BᵀDB + Σ_{Dirichlet points} w (β/h) NᵀN` on the `i`-th cut cell.
fn cut_cell_matrix(
    grid: &Grid,
    cells: &Cells,
    i: usize,
    order: ElementOrder,
    p: &OperatorParams,
) -> DMatrix<f64> {
    let npc = order.nodes_per_cell();
    let ne = 3 * npc;
    let cell = cells.cut[i];
    let x0 = grid.cell_box(cell).lo;
    let inv_h = 1.0 / grid.h;
    let d = elasticity_matrix(p.young, p.poisson);
    let mut k = DMatrix::zeros(ne, ne);
    let mut b = DMatrix::zeros(6, ne);
    let xi = |x: [f64; 3]| [0, 1, 2].map(|a| (x[a] - x0[a]) * inv_h);
    for q in cells.volume_points(i) {
        strain_displacement(order, xi(q.x), inv_h, &mut b);
        crate::element::reference::add_btdb(&mut k, &b, &d, q.w);
    }
    let mut n = vec![0.0; npc];
    for q in cells.surface_points(i) {
        if !p.dirichlet_tags[q.tag as usize] {
            continue;
        }
        shape_values(order, xi(q.x), &mut n);
        let s = q.w * p.beta * inv_h;
        for a in 0..npc {
            for bb in 0..npc {
                let v = s * n[a] * n[bb];
                for c in 0..3 {
                    k[(3 * a + c, 3 * bb + c)] += v;
                }
            }
        }
    }
    k
}
