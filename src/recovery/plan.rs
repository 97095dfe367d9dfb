//! Fit plans: what a recovery keeps of its patch fits so that later
//! recoveries on the same patches, with the same sample points and
//! constraints, only solve. A fit's acceptance, its ring and its factored
//! least-squares (KKT) system depend on the sample positions and the
//! constraint matrix, never on the values ([`super::FitFactor`]), so the
//! fixed-point loop, which recovers a new displacement on the same patches at
//! every iteration, pays for the ring search, the stability check and the
//! factorisations once, and solves each fit from the moments of its cells'
//! samples ([`super::moments`]). The plans are made either by a first
//! recovery ([`recover_planned`], which also fits its values, refined on the
//! samples) or from the sample positions alone ([`plan_fits`], before the
//! loop, no fit solved). The coefficients from plans equal
//! [`super::recover`]'s to round-off.

use std::sync::OnceLock;

use super::moments::recover_from_moments;
use super::spr::{recover_with, NodePlan, Planning};
use super::{recover, PatchSamples, Recovered, SprOptions};
use crate::cells::CellKind;
use crate::error::Result;
use crate::grid::Grid;

/// The accepted fit of every patch of one recovery: per distinct node (in
/// ascending order), its cells and the factored fit, with each patch cell
/// given as its slot in the list of the distinct cells of all patches.
pub struct FitPlans {
    pub(super) degree: usize,
    components: usize,
    /// The cells of all patches, ascending and distinct.
    pub(super) cells: Vec<usize>,
    pub(super) plans: Vec<NodePlan>,
}

impl FitPlans {
    /// The plans of one recovery, their patch cells renamed to slots.
    fn new(degree: usize, components: usize, mut plans: Vec<NodePlan>) -> FitPlans {
        let mut cells: Vec<usize> = plans
            .iter()
            .flat_map(|p| p.cells.iter().map(|&(c, _)| c))
            .collect();
        cells.sort_unstable();
        cells.dedup();

        for plan in &mut plans {
            for (c, _) in &mut plan.cells {
                *c = cells.binary_search(c).expect("a patch cell is listed");
            }
        }
        FitPlans {
            degree,
            components,
            cells,
            plans,
        }
    }

    /// The accepted ring of each patch, in ascending node order.
    pub fn rings(&self) -> Vec<usize> {
        self.plans.iter().map(|p| p.info.ring).collect()
    }
}

/// Makes the plans of a recovery on `nodes` in `plans` (a later
/// [`recover_planned`] with the same nodes, degree, sample positions and
/// constraints reuses them) without fitting: only the samples' positions
/// and the constraints are read. Nothing is done when `plans` holds plans.
pub fn plan_fits<const NC: usize, S: PatchSamples<NC>>(
    grid: &Grid,
    kinds: &[CellKind],
    nodes: &[usize],
    degree: usize,
    samples: &S,
    opts: &SprOptions,
    plans: &OnceLock<FitPlans>,
) -> Result<()> {
    if plans.get().is_some() {
        return Ok(());
    }
    let plan = Planning::PlanOnly;
    let (_, kept) = recover_with(grid, kinds, nodes, degree, samples, opts, plan, None)?;
    let _ = plans.set(FitPlans::new(degree, NC, kept));
    Ok(())
}

/// [`super::recover`], reusing the plans in `plans` when it holds them (from
/// an earlier call with the same nodes, degree, sample positions and
/// constraints), and otherwise searching every patch's ring and leaving the
/// accepted fits' plans there for the next call; `None`: [`super::recover`].
/// When a planned fit fails on its values (non-finite samples), the whole
/// recovery searches the rings as [`super::recover`] does.
///
/// # Panics
/// As [`super::recover`]; and when the plans were made for another number of
/// distinct nodes, another degree or another number of components.
pub fn recover_planned<const NC: usize, S: PatchSamples<NC>>(
    grid: &Grid,
    kinds: &[CellKind],
    nodes: &[usize],
    degree: usize,
    samples: &S,
    opts: &SprOptions,
    plans: Option<&OnceLock<FitPlans>>,
) -> Result<Recovered<NC>> {
    let Some(plans) = plans else {
        return recover(grid, kinds, nodes, degree, samples, opts);
    };
    if let Some(p) = plans.get() {
        assert_eq!(
            (p.degree, p.components),
            (degree, NC),
            "fit plans of another degree or field"
        );
        let mut distinct = nodes.to_vec();
        distinct.sort_unstable();
        distinct.dedup();
        assert_eq!(distinct.len(), p.plans.len(), "one plan per distinct node");
        return match recover_from_moments(grid, distinct, samples, p) {
            Some(rec) => Ok(rec),
            None => recover(grid, kinds, nodes, degree, samples, opts),
        };
    }
    let keep = Planning::SearchAndKeep;
    let (rec, kept) = recover_with(grid, kinds, nodes, degree, samples, opts, keep, None)?;
    // Another thread may have planned the same recovery meanwhile: its plans
    // are the same, so either is kept.
    let _ = plans.set(FitPlans::new(degree, NC, kept));
    Ok(rec)
}
