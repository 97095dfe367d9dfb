//! The multigrid preconditioner of the bodies' Newton tangents (`[solver]
//! preconditioner = "multigrid"` in a `[[body]]` case; issue 17, item 2).
//!
//! Per body, the levels below its grid are the **linear-elastic** operator
//! `K + K_p (+ K_S)` of the body at the reference configuration (its
//! material's `E`, `ν`; the case's `k1`, `k2`, `A`), rediscretised on the
//! 2×2×2 coarsenings of its grid with their own cut-cell rules, exactly as
//! a linear case's hierarchy ([`crate::multigrid`]). The body's Dirichlet
//! parts hold the components they hold, inside their regions; a
//! plane-strain body's caps hold `u_z`, which stands in on the coarse
//! levels for the held `u_z` of the finest one (the caps are the slab's two
//! node planes there, and a coarse cell is cut by the upper one).
//!
//! These levels are built once per run; each Newton tangent gets only its
//! own finest smoother ([`BlockMultigrid`]). The coarse levels do not follow
//! the deformation or the contact: at moderate strains the linear operator
//! is spectrally close to the tangent, and the finest smoother and the
//! Krylov method cover the rest.

use std::time::Instant;

use super::problem::BodiesProblem;
use super::setup::BodiesSetup;
use crate::backend::CpuBackend;
use crate::case::bodies::{BodiesCase, PLANE_STRAIN_CAP};
use crate::cells::{cut_rule_points, Cells};
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::fem::operator::{ElasticOperator, OperatorParams};
use crate::fem::setup::LevelOperator;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::hyper::newton::TangentSolver;
use crate::multigrid::blocks::{Block, BlockMultigrid};
use crate::multigrid::smoother::DEGREE;
use crate::multigrid::transfer::Lattice;
use crate::multigrid::{Hierarchy, MultigridOptions};
use crate::solver::{solve_preconditioned, KrylovOptions, KrylovStats};

/// One body's levels below its grid.
struct BodyLevels {
    /// The body on its grid coarsened once.
    top: ElasticOperator,
    /// The levels below `top`, their smoothers and the coarsest factor.
    below: Hierarchy,
}

/// Every body's coarse levels.
pub struct BodiesMultigrid {
    levels: Vec<BodyLevels>,
    /// Seconds to build them.
    pub seconds: f64,
}

impl BodiesMultigrid {
    /// The coarse levels of every body of `setup` (module doc). A body on a
    /// grid of level 0 has none: an error naming its `grid.level`.
    pub fn new(case: &BodiesCase, setup: &BodiesSetup) -> Result<BodiesMultigrid> {
        let t = Instant::now();
        let opts = MultigridOptions::default();
        let mut levels = Vec::with_capacity(setup.bodies.len());
        for (i, body) in setup.bodies.iter().enumerate() {
            let level = |grid: &Grid| body_operator(case, i, &body.solid, grid);
            let Some(grid) = body.grid.coarsened() else {
                return Err(Error::CaseFile {
                    file: case.file.clone(),
                    key: format!("body[{i}].grid.level"),
                    reason: "the multigrid preconditioner needs a grid level of at least 1".into(),
                });
            };
            let top = level(&grid)?;
            let below = Hierarchy::build(&top, &opts, |last| {
                last.grid.coarsened().map(|g| level(&g)).transpose()
            })?;
            levels.push(BodyLevels { top, below });
        }
        Ok(BodiesMultigrid {
            levels,
            seconds: t.elapsed().as_secs_f64(),
        })
    }

    /// The tangent solver of `setup`'s problem preconditioned by these levels.
    pub fn solver<'a>(&'a self, setup: &'a BodiesSetup) -> MultigridTangentSolver<'a> {
        let problem = &setup.problem;
        let blocks = self
            .levels
            .iter()
            .zip(&setup.bodies)
            .zip(&problem.bodies)
            .enumerate()
            .map(|(b, ((levels, body), p))| Block {
                offset: problem.offsets[b],
                fine: Lattice {
                    dims: body.grid.nodes_per_axis(ElementOrder::Q1),
                    dofs: &p.dofs,
                },
                top: &levels.top,
                below: &levels.below,
            })
            .collect();
        MultigridTangentSolver {
            be: CpuBackend::new(),
            problem,
            blocks,
        }
    }
}

/// Body `i`'s linear-elastic operator on `grid` (module doc).
fn body_operator(
    case: &BodiesCase,
    i: usize,
    solid: &Geometry,
    grid: &Grid,
) -> Result<ElasticOperator> {
    let spec = &case.bodies[i].spec;
    let cells = Cells::classify(grid, solid, cut_rule_points(ElementOrder::Q1)).map_err(|e| {
        Error::CaseFile {
            file: case.file.clone(),
            key: format!("body[{i}].geometry"),
            reason: format!("multigrid level {}: {e}", grid.level),
        }
    })?;
    let parts: Vec<_> = spec
        .dirichlet
        .iter()
        .filter_map(|(name, d)| solid.tag_id(name).map(|tag| (tag, d)))
        .collect();
    let cap = spec
        .plane_strain
        .then(|| solid.tag_id(PLANE_STRAIN_CAP))
        .flatten();
    let held = |tag: u16, x: [f64; 3]| -> Option<[bool; 3]> {
        let mut mask: Option<[bool; 3]> = None;
        let mut hold = |m: [bool; 3]| {
            let old = mask.unwrap_or([false; 3]);
            mask = Some([0, 1, 2].map(|c| old[c] || m[c]));
        };
        for (t, d) in &parts {
            if *t == tag && d.applies_at(x) {
                hold(d.mask());
            }
        }
        if cap == Some(tag) {
            hold([false, false, true]);
        }
        mask
    };
    let params = OperatorParams {
        young: spec.material.young,
        poisson: spec.material.poisson,
        beta: case.spec.stabilisation.k1 * spec.material.young,
        dirichlet: &held,
    };
    let st = &case.spec.stabilisation;
    Ok(LevelOperator::with_params(grid, &cells, ElementOrder::Q1, &params, st).op)
}

/// The CPU tangent solver with the bodies' V-cycle ([`BlockMultigrid`]) as
/// preconditioner: the finest smoother is rebuilt for each tangent.
pub struct MultigridTangentSolver<'a> {
    be: CpuBackend,
    problem: &'a BodiesProblem,
    blocks: Vec<Block<'a>>,
}

impl TangentSolver for MultigridTangentSolver<'_> {
    fn solve(
        &mut self,
        tangent: &dyn crate::backend::LinearOperator,
        rhs: &[f64],
        du: &mut Vec<f64>,
        opts: &KrylovOptions,
    ) -> Result<KrylovStats> {
        let mg = BlockMultigrid::new(tangent, self.problem.held(), &self.blocks, DEGREE)?;
        solve_preconditioned(&self.be, tangent, &mg, &rhs.to_vec(), du, opts)
    }
}
