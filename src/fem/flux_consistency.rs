//! Consistency of the cut-cell rules: the boundary flux of every cut cell made
//! to satisfy the divergence theorem with its volume rule exactly, so that the
//! patch test holds to round-off on every geometry (edges and corners of CSG
//! parts included).
//!
//! # Why the volume rule alone cannot be fixed
//! For a field with constant (Q1) or linear (Q2) stress `τ`, the discrete
//! equations hold for the interpolant iff, for every test function `v`,
//!
//! ```text
//! Σ_c V_c(τ_ij ∂_j v_i + ∂_j τ_ij v_i) = Σ_c G_c(τ_ij n_j v_i) + Σ_c F_c(τ_ij n^f_j v_i)
//! ```
//! with `V_c` the cell's volume rule, `G_c` its boundary rule on `Γ ∩ c` and
//! `F_c` its faces, whose terms cancel between active neighbours. Saye's
//! volume and surface rules are each accurate but not *mutually* exact: where
//! two surfaces meet in a cell they converge slowly, and the difference is what
//! the patch test measures (1.3e-2 energy error on a plate with a tilted hole at
//! level 3). Deriving the volume moments from the surface rule by the
//! divergence theorem, `V(∂_k P) := G(P n_k) + F(P n^f_k)`, fixes one direction
//! `k` only: unless the boundary rule integrates the flux of every
//! divergence-free polynomial field to zero (a closed rule, which only exact
//! integration on the discrete surface gives), the moments depend on the choice
//! of `P` and `k`, and the other directions keep the defect.
//!
//! # The cure: the boundary flux derived from the volume rule
//! Direction by direction the opposite derivation is well posed. For each axis
//! `j` and each `f ∈ Q_{2p}` (the space the moment-fitted rules integrate
//! exactly, [`super::moment_fit`]) define the consistent flux
//!
//! ```text
//! G^c_j(f) := V_c(∂_j f) − F_{c,j}(f),     F_{c,j}(f) = ∫_{f⁺_j ∩ Ω} f − ∫_{f⁻_j ∩ Ω} f,
//! ```
//! with the face integrals taken by one rule per face shared by both cells
//! ([`crate::cells::face_rule`]; exact Gauss on a face of an inside cell, zero on
//! a face toward an inactive cell). `G^c_j` is linear in `f` and differs from
//! Saye's `G_j(f) = Σ_s w_s n_{s,j} f(x_s)` by the defect
//! `D_j(f) = Σ_r D_{r,j} f(ξ_r)`, stored on the `n³` fitting points of the cell
//! (`D_{r,j} = G^c_j(L_r) − G_j(L_r)` for the Lagrange basis `L_r` of `Q_{2p}`).
//! Every flux-type boundary load `∫ (τ n)·v` (exact tractions, the recovered
//! traction `σ̂ n` of the Dirichlet parts) is integrated by Saye's points plus
//! the correction `Σ_r Σ_j D_{r,j} τ_ij(x_r) v_i(x_r)`, which is exact for
//! `τ_ij v_i ∈ Q_{2p}` (constant `τ` for Q1, linear for Q2, as in the patch
//! tests). Summed over the cells the face terms cancel and the identity above
//! holds to round-off, whatever the accuracy of the individual rules.
//!
//! The accuracy of the rules is untouched: on a smooth surface `D` is of the
//! size of Saye's own error (high order in h), so the correction is as small;
//! where surfaces meet it moves the flux where the volume rule says it is.
//!
//! # Which field a cell's correction uses
//! `τ` must be a flux density defined in the cell: the exact stress on
//! exact-traction parts, `−p I` on a pressure part (its traction `−p n` is a
//! flux), the recovered stress `σ̂` on Dirichlet parts. A cell
//! whose boundary points belong to several parts splits `D` by their share of
//! the boundary weight (any split is exact in the patch test, where the fields
//! agree). A Dirichlet part that holds only some components (a roller)
//! carries the recovered flux in all three: `σ̂` is the cell's stress
//! whatever the mask, and its tangential traction is what the free
//! components' zero traction approximates (with a share for the held
//! components only, a roller cell keeps a defect of 1e-3 in the patch test).
//! Traction-free parts and given vector tractions carry no flux density and
//! get no correction. A cut cell without boundary points (its surface lies
//! on a face claimed by a neighbour, or it received a merged sliver's face)
//! uses `σ̂` when the problem has Dirichlet parts, else the exact stress.
//!
//! # Split cells
//! Each piece of a split cell ([`crate::cells::split`]) is a domain of its
//! own: its defect is taken over the cell's volume, boundary and face points
//! that lie in it, and its correction loads its own nodes. The face terms
//! still cancel, where the pieces on both sides of a face are one
//! component. A split cell carries no Dirichlet point (the set-up keeps such
//! walls glued), so only the given stresses correct it.

use std::collections::HashMap;

use rayon::prelude::*;

use super::moment_fit::{lagrange, lagrange_derivative, FitBasis};
use super::problem::{Boundary, Problem};
use super::rhs::{
    add_cell_loads, add_element_point_load, add_piece_load, add_point_load, per_item,
    DirichletPoint,
};
use crate::cells::split::Split;
use crate::cells::{face_neighbour, CellKind, Cells, CutFaceRules};
use crate::discrete::dofs::DofMap;
use crate::element::{shape_values, ElementOrder};
use crate::error::Result;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::recovery::{BlendTable, Recovered};

/// The flux defects of the cut cells and the share of each load source.
#[derive(Clone, Debug)]
pub struct FluxCorrection {
    /// Fitting points per cell, `n³`, `n = 2p + 1`.
    nq: usize,
    /// The 1D fitting points on `[0, 1]`.
    points: Vec<f64>,
    /// `D_{r,j}` per cut cell (cut-cell order), `nq` rows each.
    defect: Vec<[f64; 3]>,
    /// Per cut cell: the share of `D` carried by the exact stress.
    exact_share: Vec<f64>,
    /// Per cut cell: the share carried by the recovered stress.
    recovered_share: Vec<f64>,
    /// (cut cell, pressure tag, share) for the cells with pressure points:
    /// the share carried by that part's stress `−p I`.
    pressure_share: Vec<(usize, u16, f64)>,
    /// Per piece of a split cell (cut cell, piece, `D_{r,j}` over the
    /// piece's points); a split cell's own `D` is their sum.
    pieces: Vec<(usize, usize, Vec<[f64; 3]>)>,
}

impl FluxCorrection {
    /// The defects of every cut cell of `cells` (face rules with `q` points
    /// per segment, the cut rules' own order), split between the sources of
    /// `problem`.
    pub fn new(
        grid: &Grid,
        cells: &Cells,
        split: &Split,
        geometry: &Geometry,
        order: ElementOrder,
        q: usize,
        problem: &Problem,
    ) -> FluxCorrection {
        let basis = FitBasis::new(order);
        let nq = basis.num_points();
        // Face rules exact on whole faces for `Q_{2p}` (2q − 1 ≥ 2p).
        let q = q.max(order.degree() + 1);
        let faces = CutFaceRules::new(geometry, grid, &cells.kinds, &cells.cut, q);
        let mut defect: Vec<[f64; 3]> = (0..cells.cut.len())
            .into_par_iter()
            .flat_map_iter(|i| match split.cell(cells.cut[i]) {
                Some(_) => vec![[0.0; 3]; nq],
                None => cell_defect(grid, cells, &faces, &basis, i, &|_| true),
            })
            .collect();
        let pieces: Vec<(usize, usize, Vec<[f64; 3]>)> = split
            .cells
            .par_iter()
            .flat_map_iter(|s| {
                let i = cells.cut_position(s.cell).expect("a split cell is cut");
                (0..s.pieces.len()).map(move |p| (i, p, s))
            })
            .map(|(i, p, s)| {
                let keep = |x: [f64; 3]| s.piece_of(x) == p;
                (i, p, cell_defect(grid, cells, &faces, &basis, i, &keep))
            })
            .collect();
        // A split cell's own defect is the sum of its pieces'.
        for (i, _, d) in &pieces {
            for (a, b) in defect[i * nq..(i + 1) * nq].iter_mut().zip(d) {
                *a = [0, 1, 2].map(|j| a[j] + b[j]);
            }
        }
        let has_dirichlet = problem.has_dirichlet();
        let mut exact_share = vec![0.0; cells.cut.len()];
        let mut recovered_share = vec![0.0; cells.cut.len()];
        let mut pressure_share = Vec::new();
        for i in 0..cells.cut.len() {
            let (mut total, mut exact, mut recovered) = (0.0, 0.0, 0.0);
            let mut pressure: Vec<(u16, f64)> = Vec::new();
            for p in cells.surface_points(i) {
                total += p.w;
                if problem.dirichlet_mask(p.tag, p.x).is_some() {
                    recovered += p.w;
                } else if let Boundary::Neumann(n) = &problem.boundary[p.tag as usize] {
                    if n.is_exact() {
                        exact += p.w;
                    } else if n.pressure.is_some() {
                        match pressure.iter_mut().find(|(t, _)| *t == p.tag) {
                            Some((_, w)) => *w += p.w,
                            None => pressure.push((p.tag, p.w)),
                        }
                    }
                }
            }
            if total > 0.0 {
                exact_share[i] = exact / total;
                recovered_share[i] = recovered / total;
                pressure_share.extend(pressure.into_iter().map(|(t, w)| (i, t, w / total)));
            } else if has_dirichlet {
                recovered_share[i] = 1.0;
            } else if problem.exact.is_some() {
                exact_share[i] = 1.0;
            }
        }
        FluxCorrection {
            nq,
            points: basis.points,
            defect,
            exact_share,
            recovered_share,
            pressure_share,
            pieces,
        }
    }

    /// `D_{r,j}` of the `i`-th cut cell.
    pub fn defect(&self, i: usize) -> &[[f64; 3]] {
        &self.defect[i * self.nq..(i + 1) * self.nq]
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        24 * self.defect.len()
            + 8 * (self.exact_share.len() + self.recovered_share.len())
            + 24 * self.pressure_share.len()
    }

    /// Drops the recovered stress's share of the cut cells (by position in
    /// `cells.cut`) that `keep` refuses: a rank keeps the cells around its
    /// own nodes, the others' recovered corrections being its ghosts'.
    pub fn keep_recovered(&mut self, keep: impl Fn(usize) -> bool) {
        for (i, share) in self.recovered_share.iter_mut().enumerate() {
            if !keep(i) {
                *share = 0.0;
            }
        }
    }

    /// The cut cells whose correction uses the recovered stress (positions in
    /// the cut list).
    pub fn recovered_cells(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.recovered_share.len()).filter(|&i| self.recovered_share[i] > 0.0)
    }

    /// Calls `sink(x_r, f_r)` with the point loads `f_r,i = factor Σ_j D_{r,j}
    /// τ_ij(x_r)` of the `i`-th cut cell: the correction of `∫ (τ n)·v` is
    /// `Σ_r f_r · v(x_r)`.
    pub fn for_each_load(
        &self,
        grid: &Grid,
        cells: &Cells,
        i: usize,
        factor: f64,
        tau: &mut dyn FnMut([f64; 3]) -> Result<[[f64; 3]; 3]>,
        sink: &mut dyn FnMut([f64; 3], [f64; 3]),
    ) -> Result<()> {
        self.for_each_defect_load(grid, cells, i, self.defect(i), factor, tau, sink)
    }

    /// [`FluxCorrection::for_each_load`] of the defect `defect` of the
    /// `i`-th cut cell (or of a piece of it).
    #[allow(clippy::too_many_arguments)]
    fn for_each_defect_load(
        &self,
        grid: &Grid,
        cells: &Cells,
        i: usize,
        defect: &[[f64; 3]],
        factor: f64,
        tau: &mut dyn FnMut([f64; 3]) -> Result<[[f64; 3]; 3]>,
        sink: &mut dyn FnMut([f64; 3], [f64; 3]),
    ) -> Result<()> {
        let lo = grid.cell_box(cells.cut[i]).lo;
        let n = self.points.len();
        for (r, d) in defect.iter().enumerate() {
            let xi = [r % n, (r / n) % n, r / (n * n)].map(|a| self.points[a]);
            let x = [0, 1, 2].map(|a| lo[a] + grid.h * xi[a]);
            sink(x, defect_load(factor, d, &tau(x)?));
        }
        Ok(())
    }

    /// Adds the corrections carried by the given stresses to `rhs`: the exact
    /// stress, and `−p I` of the pressure parts.
    pub fn add_given(
        &self,
        grid: &Grid,
        cells: &Cells,
        dofs: &DofMap,
        problem: &Problem,
        rhs: &mut [f64],
    ) {
        // A split cell's pieces load their own nodes (below).
        let whole = |i: usize| dofs.split.cell(cells.cut[i]).is_none();
        let exact: Vec<usize> = (0..cells.cut.len())
            .filter(|&i| self.exact_share[i] > 0.0 && whole(i))
            .collect();
        let cell_of = |i: usize| cells.cut[i];
        let element = per_item(|i, fe| {
            let c = cells.cut[i];
            let mut tau = |x: [f64; 3]| Ok(problem.exact_stress(x).unwrap_or([[0.0; 3]; 3]));
            let mut sink = |x, f| add_element_point_load(grid, dofs.order, c, x, f, fe);
            self.for_each_load(grid, cells, i, self.exact_share[i], &mut tau, &mut sink)
        });
        add_cell_loads(grid, dofs, &exact, &cell_of, rhs, element)
            .expect("the exact stress is infallible");
        for &(i, tag, share) in self.pressure_share.iter().filter(|p| whole(p.0)) {
            let c = cells.cut[i];
            let mut tau = |x: [f64; 3]| {
                let p = problem.pressure(tag, x);
                Ok([[-p, 0.0, 0.0], [0.0, -p, 0.0], [0.0, 0.0, -p]])
            };
            let mut sink = |x, f| add_point_load(grid, dofs, c, x, f, rhs);
            self.for_each_load(grid, cells, i, share, &mut tau, &mut sink)
                .expect("a pressure is infallible");
        }
        for (i, piece, defect) in &self.pieces {
            let s = dofs
                .split
                .cell(cells.cut[*i])
                .expect("the split of the set-up");
            let mut sink = |x, f| add_piece_load(grid, dofs, (s, *piece), x, f, rhs);
            let mut exact = |x: [f64; 3]| Ok(problem.exact_stress(x).unwrap_or([[0.0; 3]; 3]));
            let share = self.exact_share[*i];
            self.for_each_defect_load(grid, cells, *i, defect, share, &mut exact, &mut sink)
                .expect("the exact stress is infallible");
            for &(_, tag, share) in self.pressure_share.iter().filter(|p| p.0 == *i) {
                let mut tau = |x: [f64; 3]| {
                    let p = problem.pressure(tag, x);
                    Ok([[-p, 0.0, 0.0], [0.0, -p, 0.0], [0.0, 0.0, -p]])
                };
                self.for_each_defect_load(grid, cells, *i, defect, share, &mut tau, &mut sink)
                    .expect("a pressure is infallible");
            }
        }
    }

    /// Adds the corrections carried by the recovered stress `sigma` to `rhs`.
    pub fn add_recovered(
        &self,
        grid: &Grid,
        cells: &Cells,
        dofs: &DofMap,
        sigma: &Recovered<6>,
        rhs: &mut [f64],
    ) -> Result<()> {
        let recovered: Vec<usize> = self
            .recovered_cells()
            .filter(|&i| dofs.split.cell(cells.cut[i]).is_none())
            .collect();
        let cell_of = |i: usize| cells.cut[i];
        let table = self.blend_table(sigma);
        let shapes = self.fitting_shapes(dofs.order);
        let npc = dofs.order.nodes_per_cell();
        let element = per_item(|i, fe| {
            let mut tau = [0.0; 6 * MAX_FITTING_POINTS];
            let tau = &mut tau[..6 * self.nq];
            sigma.blend_at_table(cells.cut[i], &table, tau)?;
            let factor = self.recovered_share[i];
            for (r, (d, n)) in self
                .defect(i)
                .iter()
                .zip(shapes.chunks_exact(npc))
                .enumerate()
            {
                let f = defect_load(factor, d, &self.stress_at(tau, r));
                for (a, na) in n.iter().enumerate() {
                    for k in 0..3 {
                        fe[3 * a + k] += na * f[k];
                    }
                }
            }
            Ok(())
        });
        add_cell_loads(grid, dofs, &recovered, &cell_of, rhs, element)
    }

    /// The fitting points in the cell's reference coordinates, `r` in
    /// [`FluxCorrection::for_each_load`]'s order.
    fn reference_points(&self) -> Vec<[f64; 3]> {
        let n = self.points.len();
        (0..self.nq)
            .map(|r| [r % n, (r / n) % n, r / (n * n)].map(|a| self.points[a]))
            .collect()
    }

    /// The stress tensor at fitting point `r` of blended Voigt values
    /// `tau[c · nq + r]` ([`Recovered::blend_at_table`]).
    fn stress_at(&self, tau: &[f64], r: usize) -> [[f64; 3]; 3] {
        voigt_matrix(&std::array::from_fn(|c| tau[c * self.nq + r]))
    }

    /// The recovered stress's blend at the fitting points.
    fn blend_table(&self, sigma: &Recovered<6>) -> BlendTable {
        BlendTable::new(sigma.basis(), &self.reference_points())
    }

    /// The shape functions of `order` at the fitting points, `nodes_per_cell`
    /// per point.
    fn fitting_shapes(&self, order: ElementOrder) -> Vec<f64> {
        let npc = order.nodes_per_cell();
        let mut out = vec![0.0; self.nq * npc];
        for (xi, n) in self
            .reference_points()
            .iter()
            .zip(out.chunks_exact_mut(npc))
        {
            shape_values(order, *xi, n);
        }
        out
    }
}

/// The most fitting points of a cell, `(2p + 1)³` for Q2.
const MAX_FITTING_POINTS: usize = 125;

/// The point load `f_i = factor Σ_j D_j τ_ij` of one fitting point.
fn defect_load(factor: f64, d: &[f64; 3], t: &[[f64; 3]; 3]) -> [f64; 3] {
    [0, 1, 2].map(|c| factor * (0..3).map(|j| d[j] * t[c][j]).sum::<f64>())
}

impl FluxCorrection {
    /// Per Dirichlet point, the traction density that carries its cell's
    /// recovered correction: each component of the cell's correction force
    /// `Σ_r f_r` spread evenly (per unit area) over the cell's Dirichlet
    /// points that hold that component, so that the reactions `Σ_q w_q λ_q`
    /// balance the loads of the corrected system. A component that no point
    /// of the cell holds (a roller's free one) has no reaction: its
    /// correction stays a load on the free boundary.
    pub fn dirichlet_densities(
        &self,
        cells: &Cells,
        sigma: &Recovered<6>,
        dirichlet: &[DirichletPoint],
    ) -> Result<Vec<[f64; 3]>> {
        let mut area: HashMap<usize, [f64; 3]> = HashMap::new();
        for p in dirichlet {
            let a = area.entry(p.cell).or_default();
            (0..3).for_each(|k| a[k] += p.w * p.mask[k]);
        }
        let mut density: HashMap<usize, [f64; 3]> = HashMap::new();
        let table = self.blend_table(sigma);
        let mut tau = vec![0.0; 6 * self.nq];
        for i in self.recovered_cells() {
            let c = cells.cut[i];
            let Some(&a) = area.get(&c) else {
                continue;
            };
            let mut force = [0.0; 3];
            sigma.blend_at_table(c, &table, &mut tau)?;
            for (r, d) in self.defect(i).iter().enumerate() {
                let f = defect_load(self.recovered_share[i], d, &self.stress_at(&tau, r));
                (0..3).for_each(|k| force[k] += f[k]);
            }
            let d = [0, 1, 2].map(|k| if a[k] > 0.0 { force[k] / a[k] } else { 0.0 });
            density.insert(c, d);
        }
        Ok(dirichlet
            .iter()
            .map(|p| {
                let d = density.get(&p.cell).copied().unwrap_or([0.0; 3]);
                [0, 1, 2].map(|k| d[k] * p.mask[k])
            })
            .collect())
    }
}

/// The symmetric matrix of a Voigt stress (xx, yy, zz, yz, xz, xy).
fn voigt_matrix(s: &[f64; 6]) -> [[f64; 3]; 3] {
    [[s[0], s[5], s[4]], [s[5], s[1], s[3]], [s[4], s[3], s[2]]]
}

/// `D_{r,j} = V(∂_j L_r) − F_j(L_r) − G_j(L_r)` of the `i`-th cut cell's
/// points `x` with `keep(x)` (all of them, or those of one piece).
fn cell_defect(
    grid: &Grid,
    cells: &Cells,
    faces: &CutFaceRules,
    basis: &FitBasis,
    i: usize,
    keep: &dyn Fn([f64; 3]) -> bool,
) -> Vec<[f64; 3]> {
    let (t, gw) = (&basis.points, &basis.weights);
    let n = t.len();
    let cell = cells.cut[i];
    let lo = grid.cell_box(cell).lo;
    let h = grid.h;
    let xi = |x: [f64; 3]| [0, 1, 2].map(|a| (x[a] - lo[a]) / h);
    let mut d = vec![[0.0; 3]; n * n * n];
    if cells.repaired.binary_search(&cell).is_ok() {
        // A repaired rule is first order: nothing to make consistent.
        return d;
    }
    // `d[r][j] += w ∂_j L_r(ξ)` (grad = true) or `w c_j L_r(ξ)`; the
    // products are formed left to right, as `w_j ℓ'_a ℓ_b ℓ_c / h`, with the
    // leading ones shared between the points' `r`.
    let mut add = |x: [f64; 3], w: [f64; 3], grad: bool| {
        let e = xi(x);
        let l = e.map(|s| lagrange(t, s));
        if grad {
            let dl = e.map(|s| lagrange_derivative(t, s));
            for ii in 0..n {
                let a = [w[0] * dl[0][ii], w[1] * l[0][ii], w[2] * l[0][ii]];
                for jj in 0..n {
                    let b = [a[0] * l[1][jj], a[1] * dl[1][jj], a[2] * l[1][jj]];
                    for k in 0..n {
                        let r = ii + n * (jj + n * k);
                        d[r][0] += b[0] * l[2][k] / h;
                        d[r][1] += b[1] * l[2][k] / h;
                        d[r][2] += b[2] * dl[2][k] / h;
                    }
                }
            }
        } else {
            for ii in 0..n {
                for jj in 0..n {
                    let a = l[0][ii] * l[1][jj];
                    for k in 0..n {
                        let v = a * l[2][k];
                        let dr = &mut d[ii + n * (jj + n * k)];
                        for c in 0..3 {
                            dr[c] += w[c] * v;
                        }
                    }
                }
            }
        }
    };
    for p in cells.volume_points(i).iter().filter(|p| keep(p.x)) {
        add(p.x, [p.w; 3], true);
    }
    for p in cells.surface_points(i).iter().filter(|p| keep(p.x)) {
        add(p.x, p.n.map(|c| -p.w * c), false);
    }
    for axis in 0..3 {
        for side in 0..2 {
            let Some(nb) = face_neighbour(grid, cell, axis, side) else {
                continue;
            };
            let sign = if side == 1 { -1.0 } else { 1.0 };
            let mut w = [0.0; 3];
            match cells.kinds[nb] {
                CellKind::Outside => {}
                CellKind::Inside => {
                    // The whole face, by the fitting points' own Gauss rule.
                    let [b, c] = [(axis + 1) % 3, (axis + 2) % 3];
                    let mut x = lo;
                    x[axis] += side as f64 * h;
                    for (sb, wb) in t.iter().zip(gw) {
                        for (sc, wc) in t.iter().zip(gw) {
                            x[b] = lo[b] + h * sb;
                            x[c] = lo[c] + h * sc;
                            w[axis] = sign * wb * wc * h * h;
                            if keep(x) {
                                add(x, w, false);
                            }
                        }
                    }
                }
                CellKind::Cut => {
                    let low = if side == 0 { nb } else { cell };
                    for p in faces.rule(low, axis) {
                        w[axis] = sign * p.w;
                        if keep(p.x) {
                            add(p.x, w, false);
                        }
                    }
                }
            }
        }
    }
    d
}
