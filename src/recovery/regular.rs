//! The fit shared by the regular patches of one recovery.
//!
//! A node whose first ring is eight inside cells, none seen across a
//! mirror face, whose fit has no constraints, has the same sample points in
//! its scaled coordinates `ξ = (x − x_node)/h` as every other such node: the
//! caller's rule of an inside cell, moved by the node's position. Its fit's
//! acceptance, its centred design matrix `A` and its factored normal
//! equations are therefore those of any one of them. [`RegularFit`] makes
//! them once, from the lowest regular node of the recovery, and each regular
//! node then costs the product `Aᵀ B` of its values and one solve
//! ([`super::FitFactor::fit_moments`]). A node's points are checked against
//! the template's (to [`POSITION_TOLERANCE`] in scaled units) before the
//! template serves it; a node whose points differ is fitted as any other.
//!
//! The template is used only when its normal matrix is well conditioned
//! ([`super::FitFactor::solves_from_moments`]): one solve then loses
//! `cond(M̃)·ε` of the coefficients, where the refined solve of a general
//! patch loses about `√cond(M̃)·ε`; both are round-off for these patches.

use nalgebra::DMatrix;

use super::fit::{fit_and_factor, FitFactor, FitOptions};
use super::kkt::design_matrix;
use super::mirror::PatchCell;
use super::{Monomials, Sample};
use crate::cells::CellKind;

/// Largest difference, in scaled units, between a node's sample point and
/// the template's for the template to fit the node.
pub(super) const POSITION_TOLERANCE: f64 = 1e-12;

/// The cells of a patch's first ring when they make a regular patch: eight
/// cells, all inside, none mirrored.
pub(super) fn is_regular(kinds: &[CellKind], ring_one: &[PatchCell]) -> bool {
    ring_one.len() == 8
        && ring_one
            .iter()
            .all(|&(c, mask)| mask == 0 && kinds[c] == CellKind::Inside)
}

/// The factored fit of a regular patch, for every regular patch of one
/// recovery.
pub(super) struct RegularFit {
    /// The template's sample points, scaled about its node.
    positions: Vec<[f64; 3]>,
    /// `A`: the basis at the points, about their centroid.
    design: DMatrix<f64>,
    pub(super) factor: FitFactor,
}

impl RegularFit {
    /// The template of the regular patch whose scaled samples are
    /// `samples`; `None` when that fit is not accepted or not well enough
    /// conditioned to be solved once.
    pub(super) fn new<const NC: usize>(
        basis: &Monomials,
        samples: &[Sample<NC>],
        opts: &FitOptions,
    ) -> Option<RegularFit> {
        let (_, factor) = fit_and_factor(basis, samples, None, opts).ok()?;
        if !factor.solves_from_moments() {
            return None;
        }
        let positions: Vec<[f64; 3]> = samples.iter().map(|(x, _)| *x).collect();
        let design = design_matrix(basis, factor.centroid(), positions.iter().copied());
        Some(RegularFit {
            positions,
            design,
            factor,
        })
    }

    /// The coefficients of the regular patch whose scaled samples are
    /// `samples` (in the node basis, as [`super::fit_polynomial`]); `None`
    /// when its points are not the template's, or the fit is not finite.
    pub(super) fn fit<const NC: usize>(
        &self,
        basis: &Monomials,
        samples: &[Sample<NC>],
    ) -> Option<Vec<f64>> {
        let same = samples.len() == self.positions.len()
            && samples
                .iter()
                .zip(&self.positions)
                .all(|((x, _), p)| (0..3).all(|k| (x[k] - p[k]).abs() <= POSITION_TOLERANCE));
        if !same {
            return None;
        }
        let nb = basis.len();
        let mut atb = vec![0.0; nb * NC];
        for (s, (_, v)) in samples.iter().enumerate() {
            for j in 0..nb {
                let a = self.design[(s, j)];
                for (r, vc) in atb[j * NC..(j + 1) * NC].iter_mut().zip(v) {
                    *r += a * vc;
                }
            }
        }
        self.factor.fit_moments(&atb, NC).ok()
    }
}
