//! The elasticity operator `A = K + K_p (+ K_S)` on the active dofs, applied
//! matrix-free, and the same operator assembled as a sparse matrix (faer).
//!
//! Every inside cell has the same element matrix `h K_ref`, so
//! inside cells store nothing; each cut cell stores the moment-fitted weights
//! of its matrix `Σ_vol w BᵀDB + Σ_{Dirichlet points} w (β/h) NᵀN`
//! (docs/method.md, *Stabilised Dirichlet conditions*) at the `(2p+1)³`
//! Gauss points of the cell ([`super::moment_fit`]:
//! exact, 250 numbers for Q2 instead of 6561), for Q1 rearranged into the
//! factored form of [`super::q1_forms`] (114 numbers instead of 576), and
//! the S-stabilisation adds its whole-cell mass to the mass part of the cells
//! it touches.
//!
//! The apply is node-centred, as the GPU kernel is: each active node gathers,
//! from the cells around it, its rows of the cell matrix times the cell's
//! displacements, `y_n = Σ_{c ∋ n} K_c[n, :] x_c`, where a cut cell's rows
//! come from `z_c = K_c x_c`, computed first for all cut cells from their
//! forms or weights ([`super::q1_forms`], [`super::cut_apply`]). No two threads write the same entry, so no
//! atomics and no colouring are needed. The apply runs the plan of
//! [`super::fast_apply`] (the constant interior stencils along runs, the
//! gather elsewhere); the generic gather ([`ElasticOperator::apply_gather`])
//! is the reference it is tested against.
//!
//! Where the dof map has copies of glued nodes ([`crate::cells::split`]),
//! the lattice's apply runs on the lattice's unknowns, the split cells keep
//! zero weights there, and their pieces follow as a list of dense matrices
//! ([`super::split_elements`]) over all unknowns, copies included.

use std::borrow::Cow;

use rayon::prelude::*;

use std::sync::Mutex;

pub use super::assembled::AssembledOperator;
use super::component_penalty::{ComponentPenalty, HeldComponents};
use super::cut_apply::CutKernel;
use super::fast_apply::{CellData, FastApply};
use super::moment_fit::{CutWeights, FitBasis};
use super::q1_forms::Q1Forms;
use super::split_elements::SplitElements;

mod assembly;
use crate::backend::LinearOperator;
use crate::cells::{CellKind, Cells};
use crate::discrete::dofs::{node_cells, DofMap};
use crate::element::reference::{lame, reference_stiffness};
use crate::element::ElementOrder;
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
    /// Per cell: `OUTSIDE`, `INSIDE` or the index (slot) of its cut data.
    slot: Vec<u32>,
    /// `h K_ref`, row-major `ne × ne`.
    k_inside: Vec<f64>,
    /// The cut cells' data, and the cell of each slot.
    cut: CutData,
    own_cells: Vec<usize>,
    /// Lamé parameters `(λ, μ)`.
    lame: (f64, f64),
    basis: FitBasis,
    /// The penalty of the Dirichlet points that hold only some components.
    partial: ComponentPenalty,
    /// The pieces of split cells, applied after the lattice.
    split: SplitElements,
    /// The fast apply's plan and its reused scratch.
    fast: FastApply,
    scratch: Scratch,
}

/// The cut cells' matrices: factored forms for Q1, the moment-fitted weights
/// and their sum-factorised kernel otherwise.
#[derive(Clone, Debug)]
pub(super) enum CutData {
    Forms(Q1Forms),
    Weights {
        weights: CutWeights,
        kernel: CutKernel,
    },
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
#[derive(Clone, Copy)]
pub struct OperatorParams<'a> {
    pub young: f64,
    pub poisson: f64,
    /// Penalty `β = k1 E`; the Dirichlet term is `w (β/h) NᵀM N`, `M` the
    /// diagonal mask of the components held.
    pub beta: f64,
    /// The components held at a boundary point (tag, position); `None` where
    /// no Dirichlet condition applies.
    pub dirichlet: &'a HeldComponents<'a>,
}

impl ElasticOperator {
    /// Builds the operator: reference matrix and cut-cell weights (in parallel).
    pub fn new(grid: &Grid, cells: &Cells, order: ElementOrder, p: &OperatorParams) -> Self {
        ElasticOperator::with_dofs(grid, cells, DofMap::new(grid, cells, order), p)
    }

    /// [`ElasticOperator::new`] on the unknowns of `dofs`: the pieces of its
    /// split cells are elements of their own ([`SplitElements`]).
    pub fn with_dofs(grid: &Grid, cells: &Cells, dofs: DofMap, p: &OperatorParams) -> Self {
        let order = dofs.order;
        let ne = 3 * order.nodes_per_cell();
        let k_ref = reference_stiffness(order, p.young, p.poisson) * grid.h;
        let mut k_inside = Vec::with_capacity(ne * ne);
        for i in 0..ne {
            k_inside.extend((0..ne).map(|j| k_ref[(i, j)]));
        }
        let mut slot = vec![OUTSIDE; grid.num_cells()];
        for (c, k) in cells.kinds.iter().enumerate() {
            if *k == CellKind::Inside {
                slot[c] = INSIDE;
            }
        }
        for (i, &c) in cells.cut.iter().enumerate() {
            slot[c] = i as u32;
        }
        let basis = FitBasis::new(order);
        let weights_of = |i: usize, keep: &dyn Fn([f64; 3]) -> bool| {
            cut_cell_weights(grid, cells, i, &basis, p, keep)
        };
        let data: Vec<f64> = (0..cells.cut.len())
            .into_par_iter()
            .flat_map_iter(|i| match dofs.split.cell(cells.cut[i]) {
                Some(_) => vec![0.0; 2 * basis.num_points()],
                None => weights_of(i, &|_| true),
            })
            .collect();
        let weights = CutWeights {
            nq: basis.num_points(),
            data,
        };
        let lame = lame(p.young, p.poisson);
        let split = SplitElements::new(grid, cells, &dofs, &basis, lame, &weights_of);
        let partial = ComponentPenalty::new(grid, cells, &dofs, p.beta, p.dirichlet);
        let cut = match order {
            ElementOrder::Q1 => CutData::Forms(Q1Forms::new(&basis, &weights, lame, grid.h)),
            ElementOrder::Q2 => CutData::Weights {
                weights,
                kernel: CutKernel::new(&basis, lame, grid.h),
            },
        };
        let data = CellData {
            slot: &slot,
            inside: &k_inside,
            cut: &cut,
            own_cells: &cells.cut,
            node_to_active: &dofs.node_to_active,
        };
        let lattice = &dofs.active_to_node[..dofs.lattice];
        let fast = FastApply::new(grid, order, &data, lattice, &basis, lame);
        ElasticOperator {
            grid: grid.clone(),
            dofs,
            ne,
            slot,
            k_inside,
            cut,
            own_cells: cells.cut.clone(),
            lame,
            basis,
            partial,
            split,
            fast,
            scratch: Scratch::default(),
        }
    }

    /// The lattice's part of a vector (the copies follow it).
    fn lattice_len(&self) -> usize {
        3 * self.dofs.lattice
    }

    /// The pieces of the split cells.
    pub fn split_elements(&self) -> &SplitElements {
        &self.split
    }

    /// The data the fast apply reads.
    fn cell_data(&self) -> CellData<'_> {
        CellData {
            slot: &self.slot,
            inside: &self.k_inside,
            cut: &self.cut,
            own_cells: &self.own_cells,
            node_to_active: &self.dofs.node_to_active,
        }
    }

    /// The fast apply's plan, for reports.
    pub fn fast_apply(&self) -> &FastApply {
        &self.fast
    }

    /// The matrix of a cell, row-major (a cut cell's rebuilt from its
    /// weights), or `None` for an outside cell.
    pub fn cell_matrix(&self, cell: usize) -> Option<Cow<'_, [f64]>> {
        match self.slot[cell] {
            OUTSIDE => None,
            INSIDE => Some(Cow::Borrowed(&self.k_inside)),
            s => Some(Cow::Owned(self.own_matrix(s as usize))),
        }
    }

    /// The dense matrix of slot `s`, from its form or weights and its
    /// partial-mask penalty.
    fn own_matrix(&self, s: usize) -> Vec<f64> {
        let mut m = match &self.cut {
            CutData::Forms(forms) => forms.expand(s),
            CutData::Weights { weights, .. } => {
                let (w, m) = weights.cell(s);
                self.basis.expand(w, m, self.lame, 1.0 / self.grid.h)
            }
        };
        self.partial.add_to_matrix(s, &mut m);
        m
    }

    /// The diagonal of slot `s`'s matrix.
    fn own_diagonal(&self, s: usize) -> Vec<f64> {
        let mut d = match &self.cut {
            CutData::Forms(forms) => forms.diagonal(s),
            CutData::Weights { weights, .. } => {
                let (w, m) = weights.cell(s);
                self.basis.diagonal(w, m, self.lame, 1.0 / self.grid.h)
            }
        };
        self.partial.add_to_diagonal(s, &mut d);
        d
    }

    /// Adds `factor · M_c` (the whole-cell vector mass `h³ M_ref`) to a cut
    /// cell's matrix: the S-term `(k2 E/h²) M_c` of a pathological cell.
    pub fn add_cut_cell_mass(&mut self, cell: usize, factor: f64) {
        let s = self.slot[cell];
        assert!(s != OUTSIDE && s != INSIDE, "cell {cell} is not cut");
        let h3 = self.grid.h.powi(3);
        match &mut self.cut {
            CutData::Forms(forms) => forms.add_cell_mass(s as usize, factor * h3),
            CutData::Weights { weights, .. } => {
                weights.add_cell_mass(&self.basis, s as usize, factor * h3)
            }
        }
    }

    /// Adds `factor · h³ M_box` to a cut Q1 cell's matrix, `M_box` the vector
    /// mass of its shape functions over the reference box `[lo, hi] ⊂ [0,1]³`:
    /// a multigrid level's share of a finer level's S-term
    /// ([`crate::multigrid::galerkin_s`]). Returns `false`, adding nothing,
    /// where the cell is not cut or the operator is not Q1.
    pub fn add_cut_cell_box_mass(
        &mut self,
        cell: usize,
        factor: f64,
        lo: [f64; 3],
        hi: [f64; 3],
    ) -> bool {
        let s = self.slot[cell];
        let h3 = self.grid.h.powi(3);
        match &mut self.cut {
            CutData::Forms(forms) if s != OUTSIDE && s != INSIDE => {
                forms.add_box_mass(s as usize, factor * h3, lo, hi);
                true
            }
            _ => false,
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

    /// The cut cells' dense matrices, row-major `ne × ne` each, back to back
    /// in slot order (stabilisation terms included once added), rebuilt from
    /// the weights (what a device backend uploads).
    pub fn own_matrices(&self) -> Vec<f64> {
        (0..self.own_cells.len())
            .into_par_iter()
            .flat_map_iter(|s| self.own_matrix(s))
            .collect()
    }

    /// Bytes of the cut cells' data (forms or weights).
    pub fn cut_bytes(&self) -> usize {
        self.partial.bytes()
            + match &self.cut {
                CutData::Forms(forms) => forms.bytes(),
                CutData::Weights { weights, .. } => 8 * weights.data.len(),
            }
    }

    /// The cut cells' factored forms and the partial-mask penalty beside
    /// them (what a device backend uploads), or `None` where the cut cells
    /// are not in factored form (not Q1).
    pub fn q1_cut_data(&self) -> Option<(&Q1Forms, &ComponentPenalty)> {
        match &self.cut {
            CutData::Forms(forms) => Some((forms, &self.partial)),
            CutData::Weights { .. } => None,
        }
    }

    /// Cells with their own matrix.
    pub fn own_cells(&self) -> &[usize] {
        &self.own_cells
    }

    /// Bytes of operator data (the inside matrix, the cut cells' forms or
    /// weights, the maps, the fitting tables and the fast apply's plan), for
    /// the memory reports; the apply's scratch (three vectors and `z`) is not
    /// counted.
    pub fn bytes(&self) -> usize {
        self.cut_bytes()
            + 8 * (self.k_inside.len() + self.own_cells.len())
            + 4 * (self.slot.len()
                + self.dofs.node_to_active.len()
                + self.dofs.active_to_node.len())
            + self.basis.bytes()
            + self.fast.bytes()
            + self.split.bytes()
    }

    /// `z[ne s .. ne (s+1)] = K_s x_s` for every cut cell `s`.
    fn cut_products(&self, x: &[f64], z: &mut [f64]) {
        let npc = self.dofs.order.nodes_per_cell();
        let cell_nodes = |s: usize| {
            let mut nodes = [0usize; 27];
            self.dofs
                .cell_active_nodes(&self.grid, self.own_cells[s], &mut nodes[..npc]);
            nodes
        };
        match &self.cut {
            CutData::Forms(forms) => {
                let nodes: Vec<[u32; 8]> = (0..self.own_cells.len())
                    .map(|s| {
                        let nodes = cell_nodes(s);
                        std::array::from_fn(|q| nodes[q] as u32)
                    })
                    .collect();
                forms.apply(&nodes, x, z);
            }
            CutData::Weights { weights, kernel } => {
                let gather = |s: usize, xe: &mut [f64]| {
                    for (m, &an) in cell_nodes(s)[..npc].iter().enumerate() {
                        xe[3 * m..3 * m + 3].copy_from_slice(&x[3 * an..3 * an + 3]);
                    }
                };
                kernel.apply(weights, gather, z);
            }
        }
    }

    /// `y = A x` by the generic node-centred gather (see the module doc): the
    /// reference the fast apply is tested against.
    pub fn apply_gather(&self, x: &[f64], y: &mut [f64]) {
        let mut z = vec![0.0; self.ne * self.own_cells.len()];
        self.cut_products(x, &mut z);
        let z = &z;
        let npc = self.dofs.order.nodes_per_cell();
        let ne = self.ne;
        let lattice = self.lattice_len();
        y[lattice..].fill(0.0);
        y[..lattice]
            .par_chunks_mut(3)
            .enumerate()
            .with_min_len(64)
            .for_each_init(
                || (vec![0usize; npc], vec![0.0; ne], Vec::with_capacity(8)),
                |(nodes, xe, around), (a, yn)| {
                    yn.fill(0.0);
                    let node = self.dofs.active_to_node[a] as usize;
                    node_cells(&self.grid, self.dofs.order, node, around);
                    for &(cell, l) in around.iter() {
                        match self.slot[cell] {
                            OUTSIDE => {}
                            INSIDE => {
                                self.dofs.cell_active_nodes(&self.grid, cell, nodes);
                                for (m, &an) in nodes.iter().enumerate() {
                                    xe[3 * m..3 * m + 3].copy_from_slice(&x[3 * an..3 * an + 3]);
                                }
                                for (i, o) in yn.iter_mut().enumerate() {
                                    let row =
                                        &self.k_inside[(3 * l + i) * ne..(3 * l + i + 1) * ne];
                                    *o +=
                                        row.iter().zip(xe.iter()).map(|(k, v)| k * v).sum::<f64>();
                                }
                            }
                            s => {
                                let zl = &z[ne * s as usize + 3 * l..];
                                for (o, v) in yn.iter_mut().zip(zl) {
                                    *o += v;
                                }
                            }
                        }
                    }
                },
            );
        self.partial.apply_add(x, y);
        self.split.apply_add(x, y);
    }
}

impl LinearOperator for ElasticOperator {
    fn nrows(&self) -> usize {
        self.dofs.ndofs()
    }

    /// `y = A x` by the fast plan.
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let mut local = Vec::new();
        let mut guard = self.scratch.0.try_lock();
        // A concurrent apply holds the shared scratch: use a fresh one.
        let scratch = guard.as_deref_mut().unwrap_or(&mut local);
        scratch.resize(self.fast.scratch_len(), 0.0);
        let lattice = self.lattice_len();
        self.fast
            .apply(&self.cell_data(), &x[..lattice], &mut y[..lattice], scratch);
        self.partial.apply_add(x, y);
        y[lattice..].fill(0.0);
        self.split.apply_add(x, y);
    }

    fn diagonal(&self) -> Vec<f64> {
        let own: Vec<f64> = (0..self.own_cells.len())
            .into_par_iter()
            .flat_map_iter(|s| self.own_diagonal(s))
            .collect();
        let ne = self.ne;
        let mut d = vec![0.0; self.dofs.ndofs()];
        let lattice = self.lattice_len();
        d[..lattice]
            .par_chunks_mut(3)
            .enumerate()
            .for_each(|(a, dn)| {
                let node = self.dofs.active_to_node[a] as usize;
                let mut around = Vec::with_capacity(8);
                node_cells(&self.grid, self.dofs.order, node, &mut around);
                for &(cell, l) in &around {
                    for (i, v) in dn.iter_mut().enumerate() {
                        *v += match self.slot[cell] {
                            OUTSIDE => 0.0,
                            INSIDE => self.k_inside[(3 * l + i) * ne + 3 * l + i],
                            s => own[ne * s as usize + 3 * l + i],
                        };
                    }
                }
            });
        self.split.add_diagonal(&mut d);
        d
    }
}

/// The moment-fitted weights of the `i`-th cut cell's points `x` with
/// `keep(x)` (see
/// [`super::moment_fit`]): `W_q = Σ_vol w L_q(ξ)`, then
/// `M_q = (β/h) Σ_{Dirichlet points holding every component} w L_q(ξ)`.
fn cut_cell_weights(
    grid: &Grid,
    cells: &Cells,
    i: usize,
    basis: &FitBasis,
    p: &OperatorParams,
    keep: &dyn Fn([f64; 3]) -> bool,
) -> Vec<f64> {
    let nq = basis.num_points();
    let x0 = grid.cell_box(cells.cut[i]).lo;
    let inv_h = 1.0 / grid.h;
    let xi = |x: [f64; 3]| [0, 1, 2].map(|a| (x[a] - x0[a]) * inv_h);
    let mut w = vec![0.0; 2 * nq];
    let (stiffness, mass) = w.split_at_mut(nq);
    for q in cells.volume_points(i).iter().filter(|q| keep(q.x)) {
        basis.add_point(xi(q.x), q.w, stiffness);
    }
    // Points holding some components only: [`ComponentPenalty`].
    for q in cells.surface_points(i).iter().filter(|q| keep(q.x)) {
        if (p.dirichlet)(q.tag, q.x) == Some([true; 3]) {
            basis.add_point(xi(q.x), q.w * p.beta * inv_h, mass);
        }
    }
    w
}
