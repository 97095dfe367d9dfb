//! The S-stabilisation of the pathological cells in the total Lagrangian
//! residual of one body (paper eq. 5 carried over to Problem 2).
//!
//! Ω* are the cut cells with volume fraction `0 < A_c < A`
//! ([`pathological_cells`]), as whole cells (their part outside the body
//! included). With `S = S(û)` the recovered displacement of the body's
//! current `u_h`, held fixed:
//! ```text
//! R_S(u) = (k2 E / h²) Σ_{c ∈ Ω*} ∫_c Nᵀ (u_h − S) dV = Σ_c (M_c u_c − f_c)
//! K_S    = (k2 E / h²) Σ_{c ∈ Ω*} M_c          M_c = h³ M_ref (whole-cell mass)
//! f_c    = (k2 E / h²) ∫_c Nᵀ S dV             (3×3×3 Gauss over the whole cell)
//! Π_S(u) = Σ_c ½ u_cᵀ M_c u_c − f_c · u_c
//! ```
//! `K_S` is constant, so the tangent stays exact for the residual with `S`
//! held; `S` is re-evaluated between Newton passes by the fixed point of
//! [`super::newton`] (*Recovered terms*) through [`STerm::refresh`]. The `f_c`
//! are the only state that changes, behind a lock, so the problem stays
//! shared (`&self`) throughout the solve.
//!
//! # The recovery
//! SPR of degree p + 1 (Q1: 2, Q2: 3) on the patches of the vertex nodes of Ω*,
//! blended by CPE ([`crate::recovery::recover`]); the patch polynomials
//! extend `S` over the whole cell. The fit is a plain least-squares fit to
//! `u_h`, *without* the equilibrium rows of the linear S-term
//! ([`crate::driver::stabilisation`]): there `∇·σ(û) + b = 0` is linear in `û`
//! (`σ = D ε`), here the stress is `P(F(û))` of a hyperelastic material, and
//! collocating the linear operator at a finitely strained state would pull
//! `S` towards a field that is not the body's equilibrium; a plain fit of the
//! complete quadratic still reproduces every field of that space exactly.
//!
//! Sample points: the (p + 2)³ Gauss points of inside cells (Q1: 3×3×3, Q2:
//! 4×4×4); in cut cells, their fit points
//! ([`crate::cells::Cells::fit_points`]) and those of the cell's (p + 2)³
//! Gauss points that lie in the body. p + 2 levels per axis, one more than
//! the element's Gauss rule, because a plane-strain slab is one cell thick:
//! with p + 1 sample levels in z (which is all a Q1 cut cell's rule has,
//! q = 2) the `ζ^(p+1)` term of the fit is undetermined, and a patch of cut
//! cells only (a corner of a slab) would be rejected at every ring. The
//! `f_c` integral takes the same rule: `N_a S` has degree 2p + 1 per axis.

use std::sync::{OnceLock, PoisonError, RwLock, RwLockReadGuard};

use rayon::prelude::*;

use super::problem::{CellBuffer, HyperProblem, MAX_NODES};
use crate::cells::pieces::Pieces;
use crate::cells::{CellKind, Cells};
use crate::driver::stabilisation::cell_s_matrix;
use crate::element::{shape_values, tensor_gauss_rule, ElementOrder};
use crate::error::Result;
use crate::fem::level::pathological_cells;
use crate::geometry::Geometry;
use crate::recovery::{
    recover_planned, FitPlans, Mirror, PatchSamples, Recovered, Sample, SprOptions,
};

/// The S-term of one body: Ω*, the scaled cell mass and the current `f_c`.
pub struct STerm {
    /// `k2 E / h²`.
    pub factor: f64,
    /// Ω*: the pathological grid cells, ascending.
    pub omega_star: Vec<usize>,
    /// Per Ω* cell: its entry in [`HyperProblem::cells`].
    entries: Vec<usize>,
    /// Per entry of [`HyperProblem::cells`]: its position in Ω*.
    slot: Vec<Option<usize>>,
    /// The element.
    order: ElementOrder,
    /// `(k2 E / h²) h³ M_ref`, row-major `3n × 3n` for `n` nodes (dof
    /// `3 a + i`).
    mass: Vec<f64>,
    /// Cell kinds of the grid (the patches skip outside cells).
    kinds: Vec<CellKind>,
    /// The body's piece of each cell (a patch keeps to its node's piece).
    pieces: Vec<u32>,
    /// Sample positions of the cut cells, per cut index, back to back.
    cut_samples: Vec<[f64; 3]>,
    cut_sample_start: Vec<usize>,
    /// Per Ω* cell: `f_c` of the last refresh (zero before the first),
    /// `n` rows each.
    targets: RwLock<Vec<[f64; 3]>>,
    /// The faces of the grid box that are symmetry planes: the patches
    /// continue across them (`crate::bodies::symmetry`).
    pub mirror: Mirror,
    /// The patch fits of the first recovery, which the later ones reuse
    /// (the sample positions never change; [`recover_planned`]).
    plans: OnceLock<FitPlans>,
}

impl STerm {
    /// The S-term of `problem` (set up on `cells` of `solid`) with weight
    /// `k2 E` (`k2_young`) and threshold `a`.
    pub fn new(
        problem: &HyperProblem,
        cells: &Cells,
        solid: &Geometry,
        k2_young: f64,
        a: f64,
    ) -> STerm {
        let h = problem.grid.h;
        let factor = k2_young / (h * h);
        let omega_star = pathological_cells(cells, a);
        let entries: Vec<usize> = omega_star
            .iter()
            .map(|c| {
                problem
                    .cells
                    .binary_search(c)
                    .expect("a pathological cell is a cut cell of the problem")
            })
            .collect();
        let mut slot = vec![None; problem.cells.len()];
        for (s, &k) in entries.iter().enumerate() {
            slot[k] = Some(s);
        }
        let order = problem.order();
        let rule = tensor_gauss_rule(rule_points(order));
        let mut cut_samples = Vec::new();
        let mut cut_sample_start = vec![0];
        for (i, &c) in cells.cut.iter().enumerate() {
            cut_samples.extend(cells.fit_points(i, crate::cells::MAX_FIT_POINTS));
            let lo = problem.grid.cell_box(c).lo;
            cut_samples.extend(
                rule.iter()
                    .map(|(xi, _)| [0, 1, 2].map(|a| lo[a] + h * xi[a]))
                    .filter(|&x| solid.inside(x)),
            );
            cut_sample_start.push(cut_samples.len());
        }
        STerm {
            factor,
            targets: RwLock::new(vec![[0.0; 3]; order.nodes_per_cell() * omega_star.len()]),
            omega_star,
            entries,
            slot,
            order,
            mass: cell_s_matrix(order, factor, h),
            kinds: cells.kinds.clone(),
            pieces: Pieces::new(&problem.grid, cells).of_cell,
            cut_samples,
            cut_sample_start,
            mirror: Mirror::none(),
            plans: OnceLock::new(),
        }
    }

    /// The current `f_c`, per Ω* cell, `n` rows each.
    pub fn targets(&self) -> RwLockReadGuard<'_, Vec<[f64; 3]>> {
        self.targets.read().unwrap_or_else(PoisonError::into_inner)
    }

    /// The Ω* position of the `k`-th entry of [`HyperProblem::cells`].
    pub fn slot(&self, k: usize) -> Option<usize> {
        self.slot[k]
    }

    /// `out += M_c v`.
    fn add_mass(&self, ve: &[[f64; 3]], out: &mut [[f64; 3]]) {
        let dofs = 3 * ve.len();
        for row in 0..dofs {
            let m = &self.mass[row * dofs..(row + 1) * dofs];
            let s: f64 = (0..dofs).map(|col| m[col] * ve[col / 3][col % 3]).sum();
            out[row / 3][row % 3] += s;
        }
    }

    /// Ω* cell `s`'s rows of the flat `targets`.
    fn cell_targets<'t>(&self, targets: &'t [[f64; 3]], s: usize) -> &'t [[f64; 3]] {
        let n = self.order.nodes_per_cell();
        &targets[s * n..(s + 1) * n]
    }

    /// `out += M_c u_c − f_c` for the `k`-th entry (nothing off Ω*).
    pub fn add_cell_residual(
        &self,
        k: usize,
        ue: &[[f64; 3]],
        targets: &[[f64; 3]],
        out: &mut [[f64; 3]],
    ) {
        if let Some(s) = self.slot[k] {
            self.add_mass(ue, out);
            for (o, f) in out.iter_mut().zip(self.cell_targets(targets, s)) {
                for i in 0..3 {
                    o[i] -= f[i];
                }
            }
        }
    }

    /// `out += M_c v_c` for the `k`-th entry (nothing off Ω*).
    pub fn add_cell_tangent(&self, k: usize, ve: &[[f64; 3]], out: &mut [[f64; 3]]) {
        if self.slot[k].is_some() {
            self.add_mass(ve, out);
        }
    }

    /// `d += diag(M_c)` for the `k`-th entry (nothing off Ω*).
    pub fn add_cell_diagonal(&self, k: usize, d: &mut [[f64; 3]]) {
        if self.slot[k].is_some() {
            let dofs = 3 * d.len();
            for row in 0..dofs {
                d[row / 3][row % 3] += self.mass[row * dofs + row];
            }
        }
    }

    /// `½ u_cᵀ M_c u_c − f_c · u_c` for the `k`-th entry (0 off Ω*).
    pub fn cell_energy(&self, k: usize, ue: &[[f64; 3]], targets: &[[f64; 3]]) -> f64 {
        let Some(s) = self.slot[k] else {
            return 0.0;
        };
        let mut mu: CellBuffer = [[0.0; 3]; MAX_NODES];
        let mu = &mut mu[..ue.len()];
        self.add_mass(ue, mu);
        let mut e = 0.0;
        for ((u, m), f) in ue.iter().zip(mu.iter()).zip(self.cell_targets(targets, s)) {
            for i in 0..3 {
                e += u[i] * (0.5 * m[i] - f[i]);
            }
        }
        e
    }

    /// The sample positions of grid cell `cell` (non-outside).
    fn sample_positions(&self, p: &HyperProblem, cell: usize, out: &mut Vec<[f64; 3]>) {
        let k = p
            .cells
            .binary_search(&cell)
            .expect("a patch cell is active");
        match p.cut_index[k] {
            Some(i) => out.extend_from_slice(
                &self.cut_samples[self.cut_sample_start[i]..self.cut_sample_start[i + 1]],
            ),
            None => {
                let lo = p.grid.cell_box(cell).lo;
                out.extend(
                    tensor_gauss_rule(rule_points(self.order))
                        .iter()
                        .map(|(xi, _)| [0, 1, 2].map(|a| lo[a] + p.grid.h * xi[a])),
                );
            }
        }
    }

    /// `S` of any field sampled as `value(cell, x)` (the solve passes `u_h`;
    /// tests pass a field of the fit space to check reproduction).
    pub fn recover_of<F>(&self, p: &HyperProblem, value: F) -> Result<Recovered<3>>
    where
        F: Fn(usize, [f64; 3]) -> [f64; 3] + Sync,
    {
        let mut nodes = Vec::with_capacity(8 * self.omega_star.len());
        let mut v = [0usize; 8];
        for &c in &self.omega_star {
            p.grid.cell_nodes(ElementOrder::Q1, c, &mut v);
            nodes.extend_from_slice(&v);
        }
        let samples = DisplacementSamples {
            term: self,
            problem: p,
            value,
        };
        let opts = SprOptions {
            mirror: self.mirror,
            pieces: Some(&self.pieces),
            ..SprOptions::default()
        };
        let degree = self.order.degree() + 1;
        let plans = Some(&self.plans);
        recover_planned(&p.grid, &self.kinds, &nodes, degree, &samples, &opts, plans)
    }

    /// `S` of the displacement `u` of `p`.
    pub fn recover(&self, p: &HyperProblem, u: &[f64]) -> Result<Recovered<3>> {
        self.recover_of(p, |cell, x| displacement_at(p, u, cell, x))
    }

    /// `f_c = (k2 E / h²) ∫_c Nᵀ S dV` per Ω* cell, `n` rows each.
    pub fn targets_of(&self, p: &HyperProblem, s: &Recovered<3>) -> Result<Vec<[f64; 3]>> {
        let rule = tensor_gauss_rule(rule_points(self.order));
        let (h, vol) = (p.grid.h, p.grid.h.powi(3));
        let npc = self.order.nodes_per_cell();
        let mut f = vec![[0.0; 3]; npc * self.omega_star.len()];
        f.par_chunks_mut(npc)
            .zip(&self.omega_star)
            .try_for_each(|(f, &c)| {
                let lo = p.grid.cell_box(c).lo;
                let mut n = [0.0; MAX_NODES];
                let n = &mut n[..npc];
                let blend = s.cell_blend(c)?;
                for (xi, w) in &rule {
                    let x = [0, 1, 2].map(|a| lo[a] + h * xi[a]);
                    let sx = blend.eval(x);
                    shape_values(self.order, *xi, n);
                    for (fa, na) in f.iter_mut().zip(n.iter()) {
                        for i in 0..3 {
                            fa[i] += self.factor * w * vol * na * sx[i];
                        }
                    }
                }
                Ok(())
            })?;
        Ok(f)
    }

    /// Re-evaluates `S` at `u` and stores the new `f_c`.
    pub fn refresh(&self, p: &HyperProblem, u: &[f64]) -> Result<()> {
        let s = self.recover(p, u)?;
        let targets = self.targets_of(p, &s)?;
        *self.targets.write().unwrap_or_else(PoisonError::into_inner) = targets;
        Ok(())
    }

    /// The Ω* cells' entries in [`HyperProblem::cells`].
    pub fn entries(&self) -> &[usize] {
        &self.entries
    }
}

/// The samples of a displacement field `value(cell, x)` at the S-term's
/// sample positions; a displacement reflects as a vector.
struct DisplacementSamples<'a, F> {
    term: &'a STerm,
    problem: &'a HyperProblem,
    value: F,
}

impl<F> PatchSamples<3> for DisplacementSamples<'_, F>
where
    F: Fn(usize, [f64; 3]) -> [f64; 3] + Sync,
{
    fn samples(&self, cell: usize, out: &mut Vec<Sample<3>>) {
        let mut xs = Vec::new();
        self.term.sample_positions(self.problem, cell, &mut xs);
        out.extend(xs.into_iter().map(|x| (x, (self.value)(cell, x))));
    }

    fn reflected(&self, axis: usize, mut value: [f64; 3]) -> Option<[f64; 3]> {
        value[axis] = -value[axis];
        Some(value)
    }
}

/// `u_h(x)` of the problem's displacement `u` in grid cell `cell` (active).
pub fn displacement_at(p: &HyperProblem, u: &[f64], cell: usize, x: [f64; 3]) -> [f64; 3] {
    let k = p.cells.binary_search(&cell).expect("the cell is active");
    let mut buffer: CellBuffer = [[0.0; 3]; MAX_NODES];
    let ue = p.gather(k, u, &mut buffer);
    let lo = p.grid.cell_box(cell).lo;
    let xi = [0, 1, 2].map(|a| (x[a] - lo[a]) / p.grid.h);
    let mut n = [0.0; MAX_NODES];
    let n = &mut n[..ue.len()];
    shape_values(p.order(), xi, n);
    let mut v = [0.0; 3];
    for (na, ua) in n.iter().zip(ue) {
        for i in 0..3 {
            v[i] += na * ua[i];
        }
    }
    v
}

/// Gauss points per axis of the sample rule and of the `f_c` integral: p + 2
/// (module doc).
fn rule_points(order: ElementOrder) -> usize {
    order.degree() + 2
}
