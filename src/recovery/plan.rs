//! Fit plans: what a recovery keeps of its patch fits so that later
//! recoveries on the same patches, with the same sample points and
//! constraints, only solve. A fit's acceptance, its ring and its factored
//! least-squares (KKT) system depend on the sample positions and the
//! constraint matrix, never on the values ([`super::FitFactor`]), so the
//! fixed-point loop, which recovers a new displacement on the same patches at
//! every iteration, pays for the ring search, the stability check and the
//! factorisations once. The coefficients are bit-identical to
//! [`super::recover`]'s.

use std::sync::OnceLock;

use super::spr::{recover_with, NodePlan, Planning};
use super::{recover, PatchSamples, Recovered, SprOptions};
use crate::cells::CellKind;
use crate::error::Result;
use crate::grid::Grid;

/// The accepted fit of every patch of one recovery: per distinct node (in
/// ascending order), the ring and the factored fit.
pub struct FitPlans {
    degree: usize,
    components: usize,
    plans: Vec<NodePlan>,
}

impl FitPlans {
    /// The accepted ring of each patch, in ascending node order.
    pub fn rings(&self) -> Vec<usize> {
        self.plans.iter().map(|p| p.ring).collect()
    }
}

/// [`super::recover`], reusing the plans in `plans` when it holds them (from
/// an earlier call with the same nodes, degree, sample positions and
/// constraints), and otherwise searching every patch's ring and leaving the
/// accepted fits' plans there for the next call; `None`: [`super::recover`].
/// A planned fit that fails on its values (non-finite samples) searches the
/// larger rings as [`super::recover`] does.
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
        let follow = Planning::Follow(&p.plans);
        let (rec, _) = recover_with(grid, kinds, nodes, degree, samples, opts, follow)?;
        return Ok(rec);
    }
    let keep = Planning::SearchAndKeep;
    let (rec, kept) = recover_with(grid, kinds, nodes, degree, samples, opts, keep)?;
    // Another thread may have planned the same recovery meanwhile: its plans
    // are the same, so either is kept.
    let _ = plans.set(FitPlans {
        degree,
        components: NC,
        plans: kept,
    });
    Ok(rec)
}
