//! Everything a linear-elastic solve of a case needs, built once: the grid and
//! its cut-cell rules, the resolved loads, the operator, the fixed part of
//! the right-hand side and, when asked for, the multigrid hierarchy.

use std::time::Instant;

use crate::backend::LinearOperator;
use crate::case::Case;
use crate::cells::pieces::{held_pieces, HeldPoint, Naming, Pieces};
use crate::cells::split::Split;
use crate::cells::Cells;
use crate::discrete::dofs::DofMap;
use crate::element::ElementOrder;
use crate::error::Result;
use crate::fem::checks::{check_finite, check_rules, Assembled};
use crate::fem::flux_consistency::FluxCorrection;
use crate::fem::level::LevelOperator;
use crate::fem::operator::ElasticOperator;
use crate::fem::problem::Problem;
use crate::fem::rhs::{dirichlet_points, fixed_rhs, DirichletPoint};
use crate::geometry::Geometry;
use crate::grid::{machine_memory_bytes, CellBox, Grid};
use crate::multigrid::{Hierarchy, MultigridOptions};
use crate::progress::{Event, Phase, Progress, Silent};
use crate::solver::Preconditioner;

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
        Setup::build(case, level, None, progress)
    }

    /// The set-up of the cells of `window` only, as one rank of a
    /// distributed run holds it ([`crate::distributed`]): every other cell
    /// is outside, so the operator's rows and the right-hand side's entries
    /// are the whole grid's wherever all of a node's cells are in the
    /// window. No multigrid hierarchy is built, whatever the case asks.
    pub fn in_window(
        case: &Case,
        level: Option<u32>,
        window: &CellBox,
        progress: &dyn Progress,
    ) -> Result<Setup> {
        Setup::build(case, level, Some(window), progress)
    }

    fn build(
        case: &Case,
        level: Option<u32>,
        window: Option<&CellBox>,
        progress: &dyn Progress,
    ) -> Result<Setup> {
        case.require_linear()?;
        let grid = case.grid(level)?;
        let _span = tracing::info_span!("setup", level = grid.level).entered();
        case.check_memory(&grid, machine_memory_bytes())?;
        let t = Instant::now();
        let cells = case.classify_in(&grid, window.unwrap_or(&grid.all_cells()), progress)?;
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
        let order = body.spec.element;
        let split = split_walls(&grid, &cells, &body.geometry, order, &dirichlet);
        let (pieces, unheld) =
            held_pieces(&grid, &cells, &split, &body.geometry, held, &[], &naming);
        let dofs = match split.is_empty() {
            true => DofMap::new(&grid, &cells, order),
            false => DofMap::with_split(&grid, &cells, split),
        };
        let LevelOperator {
            op,
            beta,
            omega_star,
            s_factor,
        } = LevelOperator::new(case, &problem, &grid, &cells, dofs);
        let t_rhs = Instant::now();
        let mut fixed_rhs = fixed_rhs(&grid, &cells, &op.dofs, &problem, beta, &dirichlet);
        let rhs_seconds = t_rhs.elapsed().as_secs_f64();
        let flux = FluxCorrection::new(
            &grid,
            &cells,
            &op.dofs.split,
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
        // The fixed right-hand side (body load, tractions, Dirichlet data),
        // part of `operator_and_rhs`.
        timings.push(("fixed_rhs".to_string(), rhs_seconds));
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
            _ if window.is_some() => None,
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

/// The copies of the nodes whose parts of the body do not meet
/// ([`crate::cells::split`]), where the walls can be taken apart: Q1
/// elements, and no Dirichlet point in a split cell (its recovered traction
/// would mix the pieces). None elsewhere: the walls stay glued (the report
/// says where).
fn split_walls(
    grid: &Grid,
    cells: &Cells,
    geometry: &Geometry,
    order: ElementOrder,
    dirichlet: &[DirichletPoint],
) -> Split {
    if order != ElementOrder::Q1 {
        return Split::default();
    }
    let split = Split::new(grid, cells, geometry);
    match dirichlet.iter().any(|p| split.cell(p.cell).is_some()) {
        true => Split::default(),
        false => split,
    }
}
