//! Geometric multigrid on the nested Cartesian grids: the
//! hierarchy of level operators, its smoothers and coarse solver
//! ([`Hierarchy`]), and one V-cycle as the preconditioner of a Krylov solve
//! ([`Multigrid`], `[solver] preconditioner = "multigrid"`, CPU backend).
//!
//! # The levels
//! Level 0 is the operator of the solve, `A₀ = K + K_p (+ K_S)` on the case's
//! grid. Below it:
//! - for Q2, first the Q1 operator on the same grid and the same cut-cell
//!   rules (p-multigrid: the Q1 lattice is every other node of the Q2 one);
//! - then, for Q1, the operator on the 2×2×2 coarsening of the grid
//!   ([`crate::grid::Grid::coarsened`], same origin, so every fine cell lies
//!   in one coarse cell), until a level has at most [`COARSE_DOFS`] unknowns
//!   (or the grid is at level 0).
//!
//! Every coarse operator is **rediscretised**: the same operator
//! ([`LevelOperator`]: `K` and the Dirichlet penalty `(β/h) NᵀN`) on the
//! coarser grid classified against the geometry with its own cut-cell rules
//! — "a multigrid level is the same operator on a coarser grid" (deal.II
//! step-37). It stays matrix-free and costs an eighth of the level above.
//! The S-term is the exception: each coarse level takes the Galerkin
//! product of the solve's S-term ([`galerkin_s`]), not one on its own
//! pathological cells, which made coarse sliver modes too stiff (the
//! bracket at levels 5–7: 17, 17, 23 iterations rediscretised, 13, 12, 13
//! Galerkin).
//! Galerkin products `Pᵀ A P` of the whole operator on the cut band were not
//! needed: measured on the sphere (docs/multigrid.md), the rediscretised
//! Q1 hierarchy keeps the CG iteration count of the first solve at 9–10
//! from level 4 to 7, with and without the S-term, and over 20 grid
//! offsets. For the Q2 → Q1 step a two-grid cycle with the Galerkin product
//! took the same 45 iterations as with the rediscretised Q1 operator (level
//! 3) under a pointwise smoother: the smoother, not the coarse operator, was
//! the limit, and block Jacobi on the cut band ([`blocks`]) brought it to 11.
//!
//! # The cycle
//! A symmetric V-cycle ([`cycle`]): Chebyshev smoothing over `B⁻¹A`, `B`
//! Jacobi inside and block Jacobi on the cut band ([`smoother`],
//! [`blocks`]; the same polynomial before and after the coarse
//! correction), restriction `R = Pᵀ` and trilinear prolongation `P`
//! ([`transfer`]), and a sparse Cholesky factor (faer, AMD ordering) of the
//! assembled coarsest operator. The smoothing step is self-adjoint in the
//! energy product and the coarse solve is exact, so `M⁻¹` is symmetric
//! positive definite: it preconditions CG, and CGS and BiCGStab too.

pub mod blocks;
pub mod cycle;
pub mod galerkin_s;
pub mod smoother;
#[cfg(test)]
pub(crate) mod tests;
pub mod transfer;

use std::time::Instant;

pub use cycle::Multigrid;

use crate::backend::LinearOperator;
use crate::case::Case;
use crate::cells::Cells;
use crate::condition::sparse::Cholesky;
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::fem::checks::check_rules;
use crate::fem::level::pathological_cells;
use crate::fem::level::LevelOperator;
use crate::fem::operator::ElasticOperator;
use crate::fem::problem::Problem;
use crate::grid::Grid;
use crate::solver::floor_diagonal;
use galerkin_s::FineSTerm;
use smoother::Chebyshev;
use transfer::{Lattice, Transfer};

/// Relative diagonal shifts `δ` tried in turn for the coarsest factor
/// ([`coarse_factor`]).
const COARSE_SHIFTS: [f64; 6] = [0.0, 1e-12, 1e-10, 1e-8, 1e-6, 1e-4];

/// The sparse Cholesky factor (faer, AMD) of `A_c + δ D_c`, `D_c` the
/// diagonal of the coarsest operator floored as Jacobi floors it, for the
/// first `δ` of [`COARSE_SHIFTS`] that factors; returns it with `δ`.
///
/// Without the S-term a coarse level can hold cut cells whose part in the
/// body is a sliver, and its operator is then positive definite only in
/// exact arithmetic (κ beyond 10¹²: a non-positive pivot, measured on the
/// cut sweep at level 4). The shift changes the coarse correction only on
/// those near-null modes, by a relative `δ`; the V-cycle stays symmetric
/// positive definite and the Krylov method still solves `A x = b` exactly.
/// No shift that factors is a breakdown.
fn coarse_factor(op: &ElasticOperator) -> Result<(Cholesky, f64)> {
    shifted_factor(op.assemble(), op.diagonal(), op.grid.level)
}

/// [`coarse_factor`] of the assembled coarsest operator `a` with diagonal
/// `d`, on grid level `level` (for the message).
pub(crate) fn shifted_factor(
    mut a: faer::sparse::SparseColMat<usize, f64>,
    mut d: Vec<f64>,
    level: u32,
) -> Result<(Cholesky, f64)> {
    floor_diagonal(&mut d, false).map_err(|(i, v)| Error::Breakdown {
        method: "multigrid".into(),
        iterations: 0,
        what: format!("coarsest level: diagonal entry {i} is {v:e}"),
    })?;
    let mut last = String::new();
    let mut applied = 0.0;
    for delta in COARSE_SHIFTS {
        add_to_diagonal(&mut a, &d, delta - applied);
        applied = delta;
        match Cholesky::new(&a) {
            Ok(factor) => {
                if delta > 0.0 {
                    tracing::info!(delta, "multigrid: coarsest factor shifted");
                }
                return Ok((factor, delta));
            }
            Err(e) => last = e,
        }
    }
    Err(Error::Breakdown {
        method: "multigrid".into(),
        iterations: 0,
        what: format!(
            "Cholesky of the coarsest level ({} dofs on grid level {level}) with a diagonal \
             shift up to {:e}: {last}",
            d.len(),
            applied
        ),
    })
}

/// `A = A + δ diag(d)` on the stored diagonal entries of `A`.
fn add_to_diagonal(a: &mut faer::sparse::SparseColMat<usize, f64>, d: &[f64], delta: f64) {
    if delta == 0.0 {
        return;
    }
    for (j, dj) in d.iter().enumerate() {
        let rows = a.row_idx_of_col_raw(j).to_vec();
        for (v, i) in a.val_of_col_mut(j).iter_mut().zip(rows) {
            if i == j {
                *v += delta * dj;
            }
        }
    }
}

/// The settings of a hierarchy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultigridOptions {
    /// A level with at most this many unknowns is solved directly (sparse
    /// Cholesky).
    pub coarse_dofs: usize,
    /// Degree of the Chebyshev smoother ([`smoother`]).
    pub degree: usize,
}

impl Default for MultigridOptions {
    /// [`COARSE_DOFS`] and [`smoother::DEGREE`].
    fn default() -> Self {
        MultigridOptions {
            coarse_dofs: COARSE_DOFS,
            degree: smoother::DEGREE,
        }
    }
}

/// A level with at most this many unknowns is solved directly (sparse
/// Cholesky): small enough that its factor costs little beside one cycle.
pub const COARSE_DOFS: usize = 5_000;

/// The levels below the solve's operator, their smoothers and the factor of
/// the coarsest.
pub struct Hierarchy {
    /// The rediscretised operators below level 0, finest first.
    coarse: Vec<ElasticOperator>,
    /// The smoothers of levels `0 … coarse.len() − 1` (all but the coarsest).
    pub(crate) smoothers: Vec<Chebyshev>,
    /// The Cholesky factor of the coarsest level's assembled operator,
    /// shifted by `shift · D` ([`coarse_factor`]).
    pub(crate) direct: Cholesky,
    /// The relative diagonal shift the coarsest factor needed (0 mostly).
    pub shift: f64,
    /// Seconds to build the coarse operators, the smoothers and the factor.
    pub seconds: f64,
}

/// Where the Q1 level below an operator lies.
pub enum LevelBelow {
    /// Below a Q2 operator: the same grid and cut cells (p-multigrid).
    SameCells(Grid),
    /// Below a Q1 operator: the coarsened grid, classified anew.
    Coarser(Grid),
}

/// The level below `last`, `None` below level 0.
pub fn level_below(last: &ElasticOperator) -> Option<LevelBelow> {
    match last.dofs.order {
        ElementOrder::Q2 => Some(LevelBelow::SameCells(last.grid.clone())),
        ElementOrder::Q1 => last.grid.coarsened().map(LevelBelow::Coarser),
    }
}

/// The Q1 level operator of `case` on `grid` classified as `cells` (its own
/// cut-cell rules, checked) with the Galerkin product of the solve's S-term
/// (module doc).
pub fn rediscretised(
    case: &Case,
    problem: &Problem,
    grid: &Grid,
    cells: &Cells,
    s_term: &FineSTerm,
) -> Result<ElasticOperator> {
    let mut op = LevelOperator::with_k2(case, problem, grid, cells, ElementOrder::Q1, 0.0).op;
    check_rules(case, grid, cells, &op.dofs, &op.diagonal())?;
    let missed = s_term.add_to(&mut op);
    if missed > 0 {
        tracing::info!(
            missed,
            level = grid.level,
            "multigrid: S-term cells not cut there"
        );
    }
    Ok(op)
}

/// One line per level, for logs and reports.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelSummary {
    pub grid_level: u32,
    pub order: ElementOrder,
    pub dofs: usize,
    /// The Chebyshev interval `[a, b]` of `B⁻¹A` (`None` on the coarsest).
    pub interval: Option<(f64, f64)>,
    /// The smoother's cut-band blocks and the unknowns they hold (`None` on
    /// the coarsest).
    pub blocks: Option<(usize, usize)>,
}

impl Hierarchy {
    /// Builds the levels below `fine` (the operator of `case` on its grid,
    /// classified as `cells`; module doc), their smoothers and the factor of
    /// the coarsest. A coarsest operator that is not numerically positive
    /// definite is a breakdown.
    pub fn new(
        case: &Case,
        problem: &Problem,
        cells: &Cells,
        fine: &ElasticOperator,
        opts: &MultigridOptions,
    ) -> Result<Hierarchy> {
        let st = &case.spec.stabilisation;
        let mut omega_star = pathological_cells(cells, st.threshold(fine.dofs.order));
        omega_star.retain(|&c| fine.dofs.split.cell(c).is_none());
        let s_term = FineSTerm {
            grid: &fine.grid,
            cells: &omega_star,
            factor: st.k2 * problem.young / (fine.grid.h * fine.grid.h),
        };
        let level = |grid: &Grid, cells: &Cells| rediscretised(case, problem, grid, cells, &s_term);
        Hierarchy::build(fine, opts, |last| {
            Ok(match level_below(last) {
                Some(LevelBelow::SameCells(grid)) => Some(level(&grid, cells)?),
                Some(LevelBelow::Coarser(grid)) => Some(level(&grid, &case.classify(&grid)?)?),
                None => None,
            })
        })
    }

    /// The hierarchy under `fine` whose next level below an operator `last`
    /// is `below(last)` (`None`: `last` is the coarsest), down to the first
    /// level with at most `opts.coarse_dofs` unknowns; the smoothers of every
    /// level but the coarsest and the factor of the coarsest.
    pub fn build(
        fine: &ElasticOperator,
        opts: &MultigridOptions,
        mut below: impl FnMut(&ElasticOperator) -> Result<Option<ElasticOperator>>,
    ) -> Result<Hierarchy> {
        let t = Instant::now();
        let mut coarse: Vec<ElasticOperator> = Vec::new();
        loop {
            let last = coarse.last().unwrap_or(fine);
            if last.nrows() <= opts.coarse_dofs {
                break;
            }
            match below(last)? {
                Some(next) => coarse.push(next),
                None => break,
            }
        }
        let levels: Vec<&ElasticOperator> = std::iter::once(fine).chain(&coarse).collect();
        let (coarsest, smoothed) = levels.split_last().expect("level 0 exists");
        let smoothers = smoothed
            .iter()
            .map(|op| Chebyshev::new(op, opts.degree))
            .collect::<Result<Vec<_>>>()?;
        let (direct, shift) = coarse_factor(coarsest)?;
        let h = Hierarchy {
            coarse,
            smoothers,
            direct,
            shift,
            seconds: t.elapsed().as_secs_f64(),
        };
        for s in h.summary(fine) {
            tracing::info!(
                grid_level = s.grid_level,
                order = ?s.order,
                dofs = s.dofs,
                interval = ?s.interval,
                blocks = ?s.blocks,
                "multigrid level"
            );
        }
        Ok(h)
    }

    /// Number of levels, level 0 included.
    pub fn num_levels(&self) -> usize {
        self.coarse.len() + 1
    }

    /// The operator of level `i` (0: `fine`, the solve's).
    pub(crate) fn level<'a>(&'a self, fine: &'a ElasticOperator, i: usize) -> &'a ElasticOperator {
        if i == 0 {
            fine
        } else {
            &self.coarse[i - 1]
        }
    }

    /// The transfer between level `i` and level `i + 1`.
    pub(crate) fn transfer<'a>(&'a self, fine: &'a ElasticOperator, i: usize) -> Transfer<'a> {
        let lattice = |op: &'a ElasticOperator| Lattice {
            dims: op.grid.nodes_per_axis(op.dofs.order),
            dofs: &op.dofs,
        };
        Transfer {
            fine: lattice(self.level(fine, i)),
            coarse: lattice(self.level(fine, i + 1)),
        }
    }

    /// The levels, finest first (`fine`: the operator the hierarchy was
    /// built for).
    pub fn summary(&self, fine: &ElasticOperator) -> Vec<LevelSummary> {
        (0..self.num_levels())
            .map(|i| {
                let op = self.level(fine, i);
                LevelSummary {
                    grid_level: op.grid.level,
                    order: op.dofs.order,
                    dofs: op.nrows(),
                    interval: self.smoothers.get(i).map(|s| (s.lo, s.hi)),
                    blocks: self.smoothers.get(i).map(Chebyshev::block_sizes),
                }
            })
            .collect()
    }
}
