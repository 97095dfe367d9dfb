//! The multigrid preconditioner of the bodies' Newton tangents (`[solver]
//! preconditioner = "multigrid"` in a `[[body]]` case).
//!
//! # The levels
//! Per body, the **linear-elastic** operator `K + K_p (+ K_S)` of the body
//! at the reference configuration (its material's `E`, `ν`; the case's
//! `k1`, `k2`, `A`) on its own grid, cut cells and element, then (Q2 only)
//! the Q1 operator on the same grid and cut-cell rules, and the Q1 operator
//! rediscretised on the 2×2×2 coarsenings of the grid with their own cut-cell
//! rules, the S-term the Galerkin product of the finest level's
//! ([`crate::multigrid::galerkin_s`]): a linear case's [`Hierarchy`], built
//! once per run. The body's
//! Dirichlet parts hold the components they hold, inside their regions. A
//! plane-strain body's caps hold `u_z` by the same penalty: on the finest
//! level the caps are the slab's two node planes, where `u_z` is held
//! anyway; on a coarse one the upper cap cuts the coarse cells. A symmetry
//! plane holds its normal component by the same penalty (without it a body
//! held only on its symmetry planes has a singular hierarchy, and its
//! V-cycle diverges).
//!
//! # The preconditioner
//! Block diagonal: body `b`'s residual, with its held entries set to zero,
//! goes through one V-cycle of its hierarchy ([`Multigrid`]); held rows get
//! the identity (the tangent's own rows there). Each block is symmetric
//! positive definite, so the preconditioner is too.
//!
//! # Why the reference linear operator
//! It sees neither the deformation nor the contact coupling, but at the
//! strains of the cases it is spectrally close to the tangent, and its apply
//! costs a fraction of the tangent's (no stress update per quadrature
//! point). Measured on `cases/mindlin.toml` at level 3, contact penalty 3
//! then (docs/multigrid.md,
//! "Newton tangents"): a V-cycle whose finest level smoothed the true
//! tangent (contact included) took 1 256 BiCGStab iterations and 73 s, this
//! one 1 311 and 24 s, Jacobi 8 697 and 58 s; the contact forces of all
//! three agree to 1e-14.

use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;

use super::setup::{BodiesSetup, BodySetup};
use crate::backend::CpuBackend;
use crate::case::physics::StabilisationSpec;
use crate::case::{Case, PLANE_STRAIN_CAP};
use crate::cells::{cut_rule_points, Cells};
use crate::discrete::dofs::DofMap;
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::fem::level::pathological_cells;
use crate::fem::level::LevelOperator;
use crate::fem::operator::{ElasticOperator, OperatorParams};
use crate::grid::Grid;
use crate::multigrid::galerkin_s::FineSTerm;
use crate::multigrid::{level_below, Hierarchy, LevelBelow, Multigrid, MultigridOptions};
use crate::solver::ApplyInverse;

/// Every body's levels: its linear operator on its grid and the hierarchy
/// under it.
pub struct BodiesMultigrid {
    levels: Vec<(ElasticOperator, Hierarchy)>,
    /// Seconds to build them.
    pub seconds: f64,
}

impl BodiesMultigrid {
    /// The levels of every body of `setup` (module doc), down to a level of
    /// at most `opts.coarse_dofs` unknowns per body.
    pub fn new(
        case: &Case,
        setup: &BodiesSetup,
        opts: &MultigridOptions,
    ) -> Result<BodiesMultigrid> {
        let t = Instant::now();
        let mut levels = Vec::with_capacity(setup.bodies.len());
        for (i, body) in setup.bodies.iter().enumerate() {
            let st = &case.spec.stabilisation;
            let order = setup.problem.bodies[i].order();
            let fine = body_operator(case, i, body, (&body.grid, &body.cells), order, st.k2);
            let omega_star = pathological_cells(&body.cells, st.threshold(order));
            let young = case.bodies[i].spec.material.young;
            let s_term = FineSTerm {
                grid: &body.grid,
                cells: &omega_star,
                factor: st.k2 * young / (body.grid.h * body.grid.h),
            };
            let q1 = ElementOrder::Q1;
            let hierarchy = Hierarchy::build(&fine, opts, |last| {
                let mut op = match level_below(last) {
                    None => return Ok(None),
                    Some(LevelBelow::SameCells(grid)) => {
                        body_operator(case, i, body, (&grid, &body.cells), q1, 0.0)
                    }
                    Some(LevelBelow::Coarser(grid)) => {
                        let cells = Cells::classify(&grid, &body.solid, cut_rule_points(q1))
                            .map_err(|e| Error::CaseFile {
                                file: case.file.clone(),
                                key: format!("body[{i}].geometry"),
                                reason: format!("multigrid level {}: {e}", grid.level),
                            })?;
                        body_operator(case, i, body, (&grid, &cells), q1, 0.0)
                    }
                };
                s_term.add_to(&mut op);
                Ok(Some(op))
            })?;
            levels.push((fine, hierarchy));
        }
        Ok(BodiesMultigrid {
            levels,
            seconds: t.elapsed().as_secs_f64(),
        })
    }

    /// The preconditioner of `setup`'s problem from these levels.
    pub fn preconditioner<'a>(&'a self, setup: &'a BodiesSetup) -> BodiesVCycles<'a> {
        let problem = &setup.problem;
        BodiesVCycles {
            cycles: self
                .levels
                .iter()
                .map(|(fine, h)| Multigrid::new(fine, h))
                .collect(),
            offsets: &problem.offsets,
            held: problem.held(),
            free: Mutex::new(vec![0.0; problem.held().len()]),
        }
    }
}

/// Body `i`'s linear-elastic operator of elements `order` on a grid
/// classified as its cells (module doc), with the S-term's weight `k2` (0 on
/// a coarse level, which takes the finest level's S-term instead).
fn body_operator(
    case: &Case,
    i: usize,
    body: &BodySetup,
    (grid, cells): (&Grid, &Cells),
    order: ElementOrder,
    k2: f64,
) -> ElasticOperator {
    let spec = &case.bodies[i].spec;
    let parts: Vec<_> = spec
        .dirichlet
        .iter()
        .filter_map(|(name, d)| body.solid.tag_id(name).map(|tag| (tag, d)))
        .collect();
    let cap = spec
        .plane_strain
        .then(|| body.solid.tag_id(PLANE_STRAIN_CAP))
        .flatten();
    // A tag has at most one Dirichlet condition; the caps and the symmetry
    // planes have none.
    let held = |tag: u16, x: [f64; 3]| -> Option<[bool; 3]> {
        if cap == Some(tag) {
            return Some([false, false, true]);
        }
        if let Some(plane) = body.symmetry.iter().find(|p| p.tag == tag) {
            let mut mask = [false; 3];
            mask[plane.axis] = true;
            return Some(mask);
        }
        let (_, d) = parts.iter().find(|(t, _)| *t == tag)?;
        d.applies_at(x).then(|| d.mask())
    };
    let params = OperatorParams {
        young: spec.material.young,
        poisson: spec.material.poisson,
        beta: case.spec.stabilisation.k1 * spec.material.young,
        dirichlet: &held,
    };
    let st = StabilisationSpec {
        k2,
        ..case.spec.stabilisation.clone()
    };
    LevelOperator::with_params(grid, cells, DofMap::new(grid, cells, order), &params, &st).op
}

/// The block-diagonal preconditioner of the module doc.
pub struct BodiesVCycles<'a> {
    cycles: Vec<Multigrid<'a>>,
    offsets: &'a [usize],
    held: &'a [bool],
    /// The residual with its held entries zeroed.
    free: Mutex<Vec<f64>>,
}

impl BodiesVCycles<'_> {
    /// `z = M⁻¹ r`.
    ///
    /// # Panics
    /// If `r` or `z` do not have the problem's size.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        let mut free = self.free.lock().unwrap_or_else(|e| e.into_inner());
        for ((f, &v), &h) in free.iter_mut().zip(r).zip(self.held) {
            *f = if h { 0.0 } else { v };
        }
        // The bodies' V-cycles side by side: each one's serial parts (its
        // coarsest solve) overlap the others' work.
        let mut blocks = Vec::with_capacity(self.cycles.len());
        let mut rest = &mut z[..];
        for b in 0..self.cycles.len() {
            let (block, tail) = rest.split_at_mut(self.offsets[b + 1] - self.offsets[b]);
            blocks.push((b, block));
            rest = tail;
        }
        blocks.into_par_iter().for_each(|(b, block)| {
            self.cycles[b].apply(&free[self.offsets[b]..self.offsets[b + 1]], block);
        });
        for ((zi, &ri), &h) in z.iter_mut().zip(r).zip(self.held) {
            if h {
                *zi = ri;
            }
        }
    }
}

impl ApplyInverse<CpuBackend> for BodiesVCycles<'_> {
    fn apply_inverse(&self, r: &Vec<f64>, z: &mut Vec<f64>) {
        self.apply(r, z);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multigrid::tests::{dot, scrambled};
    use crate::progress::Silent;

    const CASE: &str = include_str!("../../cases/annuli_contact.toml");

    /// On the two plane-strain annuli at level 4, with small coarsest levels
    /// so that each body has a V-cycle: `M⁻¹` is symmetric and positive, the identity on the
    /// held `u_z`, and its free part does not depend on the held entries.
    #[test]
    fn the_preconditioner_is_symmetric_positive_and_keeps_held_rows() {
        let case = Case::from_str_with("annuli_contact.toml", CASE, &[]).unwrap();
        let setup = BodiesSetup::new(&case, Some(4), &Silent).unwrap();
        let opts = MultigridOptions {
            coarse_dofs: 300,
            ..MultigridOptions::default()
        };
        let mg = BodiesMultigrid::new(&case, &setup, &opts).unwrap();
        assert!(mg.levels.iter().all(|(_, h)| h.num_levels() >= 2));
        let pre = mg.preconditioner(&setup);
        let held = setup.problem.held();
        let n = held.len();
        assert!(held.iter().any(|&h| h));
        let (x, y) = (scrambled(n, 1), scrambled(n, 2));
        let (mut mx, mut my) = (vec![0.0; n], vec![0.0; n]);
        pre.apply(&x, &mut mx);
        pre.apply(&y, &mut my);
        let (a, b) = (dot(&x, &my), dot(&y, &mx));
        let scale = (dot(&x, &x) * dot(&my, &my)).sqrt();
        assert!((a - b).abs() <= 1e-12 * scale, "x·M⁻¹y = {a}, y·M⁻¹x = {b}");
        assert!(dot(&x, &mx) > 0.0 && dot(&y, &my) > 0.0);
        let mut x_other = x.clone();
        for i in (0..n).filter(|&i| held[i]) {
            assert_eq!(mx[i], x[i], "held row {i}");
            x_other[i] = -3.0 * x[i] + 1.0;
        }
        let mut m_other = vec![0.0; n];
        pre.apply(&x_other, &mut m_other);
        for i in (0..n).filter(|&i| !held[i]) {
            assert_eq!(m_other[i], mx[i], "free row {i}");
        }
    }
}
