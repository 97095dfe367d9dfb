//! The S-term of a coarse multigrid level: the Galerkin product of the
//! solve's, not the S-term of the level's own pathological cells.
//!
//! # Why
//! The S-term of the solve's level is `K_S = f₀ Σ_{c ∈ Ω*₀} M_c`, `f₀ =
//! k2 E / h₀²`: a whole-cell mass on its pathological cells. Rediscretised on
//! a grid of size `h = 2^m h₀` it would be `(k2 E / h²) Σ_{C ∈ Ω*_h} M_C`
//! on that grid's own pathological cells. A coarse basis function that lives
//! on a coarse sliver sees the fine S-term only on the fine sliver cells
//! inside it, an eighth of the coarse cell or less, so the rediscretised
//! S-term makes it twice as stiff or more as the fine operator does, and the
//! coarse correction undershoots on exactly the modes the S-term is there
//! for. Measured on the bracket of `cases/` (CG + multigrid, first solve):
//! 17, 17, 23 iterations at levels 5–7 with the rediscretised S-term, 13,
//! 12, 13 with this one. (Found at level 7 on a grid whose cut-cell rules
//! had lost boundary points, since fixed: 38 rediscretised, 27 with the
//! S-term off on every level, 30 and 28 with the coarse S-term weakened by
//! 2 and 4 per level, 49 and 61 with it strengthened the same way.)
//!
//! # What
//! The coarse functions are trilinear and are reproduced by the prolongation
//! on the fine cells, so the Galerkin product `Pᵀ K_S P` is the fine S-term
//! integrated with the coarse functions:
//!
//! ```text
//! K_S,h = f₀ Σ_{c ∈ Ω*₀} ∫_c N_hᵀ N_h dV
//! ```
//!
//! Each fine cell `c` lies in one cell `C` of the coarse grid (same origin,
//! [`crate::grid::Grid::coarsened`]), where it is the reference box
//! `[i/2^m, (i+1)/2^m]` per axis (`i` the fine index modulo `2^m`); its
//! share is `f₀ h³ M_box` ([`crate::fem::operator::ElasticOperator::add_cut_cell_box_mass`]).
//! For the Q2 → Q1 step (`m = 0`) it is the whole-cell Q1 mass on the Q2
//! operator's own Ω*.

use crate::fem::operator::ElasticOperator;
use crate::grid::Grid;

/// The S-term of the solve's level: its grid, its pathological cells and
/// their weight `f₀ = k2 E / h₀²`.
pub struct FineSTerm<'a> {
    pub grid: &'a Grid,
    pub cells: &'a [usize],
    pub factor: f64,
}

impl FineSTerm<'_> {
    /// Adds the Galerkin product of this S-term to the Q1 operator `op` of a
    /// grid that is the same or a coarsening of [`FineSTerm::grid`]. Returns
    /// the number of fine cells whose coarse cell is not cut (they add
    /// nothing: a coarse cell holding a fine cut cell is cut, but its
    /// classification is its own).
    pub fn add_to(&self, op: &mut ElasticOperator) -> usize {
        if self.factor == 0.0 {
            return 0;
        }
        let steps = self.grid.level - op.grid.level;
        let ratio = 1usize << steps;
        let size = 1.0 / ratio as f64;
        let mut missed = 0;
        for &c in self.cells {
            let ijk = self.grid.cell_ijk(c);
            let coarse = op.grid.cell_index(ijk.map(|i| i / ratio));
            let lo = ijk.map(|i| (i % ratio) as f64 * size);
            let hi = lo.map(|l| l + size);
            // `factor · h³` with the coarse h: the box mass is per unit
            // reference volume of the coarse cell.
            if !op.add_cut_cell_box_mass(coarse, self.factor, lo, hi) {
                missed += 1;
            }
        }
        missed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::LinearOperator;
    use crate::driver::setup::Setup;
    use crate::element::ElementOrder;
    use crate::fem::level::pathological_cells;
    use crate::fem::level::LevelOperator;
    use crate::multigrid::tests::{dot, scrambled, sphere};
    use crate::multigrid::transfer::{Lattice, Transfer};

    fn lattice(op: &ElasticOperator) -> Lattice<'_> {
        Lattice {
            dims: op.grid.nodes_per_axis(ElementOrder::Q1),
            dofs: &op.dofs,
        }
    }

    /// On the cut Q1 sphere, one and two levels down: the S-term this
    /// module adds to a coarse operator equals `Pᵀ K_S P` of the solve's
    /// S-term `K_S` (the fine operator with it minus without it), tested as
    /// `y·(C_S − C) x = (P y)·(A_S − A)(P x)` on vectors without structure.
    #[test]
    fn coarse_s_term_is_the_galerkin_product_of_the_fine_one() {
        let case = sphere("q1", 0.01);
        let setup = Setup::new(&case, Some(4)).unwrap();
        let (grid, cells, problem) = (&setup.grid, &setup.cells, &setup.problem);
        let omega_star =
            pathological_cells(cells, case.spec.stabilisation.threshold(ElementOrder::Q1));
        assert!(!omega_star.is_empty());
        let s_term = FineSTerm {
            grid,
            cells: &omega_star,
            factor: setup.s_factor,
        };
        let plain_fine =
            LevelOperator::with_k2(&case, problem, grid, cells, ElementOrder::Q1, 0.0).op;

        let mut coarse_grid = grid.clone();
        let mut chain: Vec<ElasticOperator> = vec![setup.op.clone()];
        for _ in 0..2 {
            coarse_grid = coarse_grid.coarsened().unwrap();
            let coarse_cells = case.classify(&coarse_grid).unwrap();
            let plain = LevelOperator::with_k2(
                &case,
                problem,
                &coarse_grid,
                &coarse_cells,
                ElementOrder::Q1,
                0.0,
            )
            .op;
            let mut with_s = plain.clone();
            assert_eq!(s_term.add_to(&mut with_s), 0);
            // P from this coarse level to the fine one, through the levels between.
            chain.push(with_s.clone());
            let (x, y) = (scrambled(plain.nrows(), 7), scrambled(plain.nrows(), 8));
            let prolong = |v: &[f64]| {
                let mut v = v.to_vec();
                for i in (0..chain.len() - 1).rev() {
                    let t = Transfer {
                        fine: lattice(&chain[i]),
                        coarse: lattice(&chain[i + 1]),
                    };
                    let mut f = vec![0.0; chain[i].nrows()];
                    t.prolong_add(&v, &mut f);
                    v = f;
                }
                v
            };
            let difference = |a: &ElasticOperator, b: &ElasticOperator, u: &[f64], v: &[f64]| {
                let (mut au, mut bu) = (vec![0.0; u.len()], vec![0.0; u.len()]);
                a.apply(u, &mut au);
                b.apply(u, &mut bu);
                let d: Vec<f64> = au.iter().zip(&bu).map(|(p, q)| p - q).collect();
                (dot(v, &d), dot(v, &au).abs())
            };
            let (coarse, scale) = difference(&with_s, &plain, &x, &y);
            let (px, py) = (prolong(&x), prolong(&y));
            let (fine, _) = difference(&setup.op, &plain_fine, &px, &py);
            assert!(
                coarse.abs() > 1e-6 * scale,
                "no S-term on level {}",
                coarse_grid.level
            );
            assert!(
                (coarse - fine).abs() <= 1e-12 * scale,
                "level {}: y·C_S x = {coarse:e}, Py·K_S Px = {fine:e}",
                coarse_grid.level
            );
        }
    }
}
