//! Everything a linear-elastic solve of a case needs, built once: the grid and
//! its cut-cell rules, the resolved loads, the operator, the fixed part of
//! the right-hand side and, when asked for, the multigrid hierarchy.

use std::time::Instant;

use super::checks::{check_finite, check_rules, Assembled};
use super::flux_consistency::FluxCorrection;
use super::operator::{ElasticOperator, OperatorParams};
use super::problem::Problem;
use super::rhs::{dirichlet_points, fixed_rhs, DirichletPoint};
use super::stabilisation::pathological_cells;
use crate::backend::LinearOperator;
use crate::case::physics::StabilisationSpec;
use crate::case::Case;
use crate::cells::pieces::{held_pieces, HeldPoint, Naming, Pieces};
use crate::cells::Cells;
use crate::element::ElementOrder;
use crate::error::Result;
use crate::grid::{machine_memory_bytes, Grid};
use crate::multigrid::{Hierarchy, MultigridOptions};
use crate::progress::{Event, Phase, Progress, Silent};
use crate::solver::Preconditioner;

/// The operator `K + K_p (+ K_S)` of a case on one grid with its own cut-cell
/// rules: what [`Setup`] builds on the case's grid and what a multigrid level
/// ([`crate::multigrid`]) rebuilds on a coarser one.
pub struct LevelOperator {
    pub op: ElasticOperator,
    /// The Dirichlet penalty `β = k1 E`.
    pub beta: f64,
    /// Pathological cells (Ω*) of this grid, ascending.
    pub omega_star: Vec<usize>,
    /// `k2 E / h²`: the weight of the S-term on this grid (0 when it is off).
    pub s_factor: f64,
}

impl LevelOperator {
    /// `K + K_p` of elements `order` on `grid` classified as `cells`, plus
    /// `(k2 E / h²) M_c` on the pathological cells of `order`'s threshold.
    pub fn new(
        case: &Case,
        problem: &Problem,
        grid: &Grid,
        cells: &Cells,
        order: ElementOrder,
    ) -> LevelOperator {
        let k2 = case.spec.stabilisation.k2;
        LevelOperator::with_k2(case, problem, grid, cells, order, k2)
    }

    /// [`LevelOperator::new`] with the S-term's weight `k2`; `0` for a
    /// multigrid level, which takes the S-term of the solve's level instead
    /// ([`crate::multigrid::galerkin_s`]).
    pub fn with_k2(
        case: &Case,
        problem: &Problem,
        grid: &Grid,
        cells: &Cells,
        order: ElementOrder,
        k2: f64,
    ) -> LevelOperator {
        let params = OperatorParams {
            young: problem.young,
            poisson: problem.poisson,
            beta: case.spec.stabilisation.k1 * problem.young,
            dirichlet: &|tag, x| problem.dirichlet_mask(tag, x),
        };
        let st = StabilisationSpec {
            k2,
            ..case.spec.stabilisation.clone()
        };
        LevelOperator::with_params(grid, cells, order, &params, &st)
    }

    /// [`LevelOperator::new`] from the operator's parameters and the
    /// stabilisation settings (`k2`, `A`; `params.beta` is the penalty).
    pub fn with_params(
        grid: &Grid,
        cells: &Cells,
        order: ElementOrder,
        params: &OperatorParams,
        st: &StabilisationSpec,
    ) -> LevelOperator {
        let mut op = ElasticOperator::new(grid, cells, order, params);
        let omega_star = pathological_cells(cells, st.threshold(order));
        let s_factor = st.k2 * params.young / (grid.h * grid.h);
        if s_factor > 0.0 {
            for &c in &omega_star {
                op.add_cut_cell_mass(c, s_factor);
            }
        }
        LevelOperator {
            op,
            beta: params.beta,
            omega_star,
            s_factor,
        }
    }
}

/// A case set up on its grid.
pub struct Setup {
    pub grid: Grid,
    pub cells: Cells,
    /// The body's pieces.
    pub pieces: Pieces,
    /// Why a piece is not held (no Dirichlet condition, or one that leaves
    /// it a rigid motion), if one is not: a solve of it is refused
    /// ([`Setup::check_held`]); an operator of it can still be had.
    pub unheld: Option<crate::error::Error>,
    pub problem: Problem,
    pub op: ElasticOperator,
    pub beta: f64,
    pub dirichlet: Vec<DirichletPoint>,
    pub fixed_rhs: Vec<f64>,
    /// The cut cells' flux corrections (consistent boundary loads).
    pub flux: FluxCorrection,
    /// Pathological cells (Ω*), ascending.
    pub omega_star: Vec<usize>,
    /// `k2 E / h²`: the weight of the S-term (0 when it is off).
    pub s_factor: f64,
    /// Whether `F_S` drops its net force and moment (`[stabilisation]
    /// balanced`).
    pub s_balanced: bool,
    /// The multigrid hierarchy under `op`, built when the case's solver asks
    /// for the multigrid preconditioner.
    pub multigrid: Option<Hierarchy>,
    /// Seconds per phase.
    pub timings: Vec<(String, f64)>,
}

impl Setup {
    /// Ok when every piece of the body is held; otherwise the error naming
    /// the first piece that is not (exit code 2). Every solve asks first.
    pub fn check_held(&self) -> Result<()> {
        match &self.unheld {
            None => Ok(()),
            Some(e) => Err(e.clone()),
        }
    }

    /// Builds the grid at `level` (default: the case's), classifies it, and
    /// assembles the operator data and the fixed right-hand side.
    pub fn new(case: &Case, level: Option<u32>) -> Result<Setup> {
        Setup::new_with_progress(case, level, &Silent)
    }

    /// [`Setup::new`], reporting its phases ([`Phase::Quadrature`],
    /// [`Phase::Operator`]) to `progress`.
    pub fn new_with_progress(
        case: &Case,
        level: Option<u32>,
        progress: &dyn Progress,
    ) -> Result<Setup> {
        case.require_linear()?;
        let grid = case.grid(level)?;
        let _span = tracing::info_span!("setup", level = grid.level).entered();
        case.check_memory(&grid, machine_memory_bytes())?;
        let t = Instant::now();
        let cells = case.classify_with_progress(&grid, progress)?;
        let mut timings = vec![("quadrature".to_string(), t.elapsed().as_secs_f64())];
        tracing::info!(
            cut = cells.cut.len(),
            inside = cells.num_inside,
            seconds = timings[0].1,
            "classified the cells"
        );
        progress.event(&Event::Start {
            phase: Phase::Operator,
            total: None,
        });
        let problem = Problem::new(case);
        let t = Instant::now();
        let dirichlet = dirichlet_points(&cells, &problem);
        let held = dirichlet.iter().map(|p| HeldPoint {
            cell: p.cell,
            x: p.x,
            w: p.w,
            mask: p.mask,
        });
        let body = case.body();
        let naming = Naming {
            file: &case.file,
            key: &case.body_key(0, "dirichlet"),
            body: &body.spec.name,
        };
        let (pieces, unheld) = held_pieces(&grid, &cells, &body.geometry, held, &[], &naming);
        let LevelOperator {
            op,
            beta,
            omega_star,
            s_factor,
        } = LevelOperator::new(case, &problem, &grid, &cells, case.body().spec.element);
        let mut fixed_rhs = fixed_rhs(&grid, &cells, &op.dofs, &problem, beta, &dirichlet);
        let flux = FluxCorrection::new(
            &grid,
            &cells,
            &case.body().geometry,
            case.body().spec.element,
            case.rule_points(),
            &problem,
        );
        flux.add_given(&grid, &cells, &op.dofs, &problem, &mut fixed_rhs);
        let diagonal = op.diagonal();
        let assembled = Assembled {
            grid: &grid,
            cells: &cells,
            dofs: &op.dofs,
            problem: &problem,
            beta,
            s_factor,
            diagonal: &diagonal,
            dirichlet: &dirichlet,
            fixed_rhs: &fixed_rhs,
        };
        check_finite(case, &assembled)?;
        check_rules(case, &grid, &cells, &op.dofs, &diagonal)?;
        timings.push(("operator_and_rhs".to_string(), t.elapsed().as_secs_f64()));
        progress.event(&Event::Finish {
            phase: Phase::Operator,
        });
        tracing::info!(
            dofs = fixed_rhs.len(),
            pathological = omega_star.len(),
            seconds = timings[1].1,
            "assembled the operator and right-hand side"
        );
        let multigrid = match case.spec.solver.preconditioner {
            Preconditioner::Multigrid | Preconditioner::Auto => {
                // The coarsest level's factor needs a held body.
                if let Some(e) = &unheld {
                    return Err(e.clone());
                }
                let h = Hierarchy::new(case, &problem, &cells, &op, &MultigridOptions::default())?;
                timings.push(("multigrid".to_string(), h.seconds));
                Some(h)
            }
            Preconditioner::None | Preconditioner::Jacobi => None,
        };
        Ok(Setup {
            grid,
            cells,
            pieces,
            unheld,
            problem,
            op,
            beta,
            dirichlet,
            fixed_rhs,
            flux,
            omega_star,
            s_factor,
            s_balanced: case.spec.stabilisation.balanced(),
            multigrid,
            timings,
        })
    }
}
