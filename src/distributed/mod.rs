//! The linear path on several ranks (docs/distributed.md): the grid's
//! cells shared out as bricks balanced by work ([`partition`]); each rank
//! classifies and integrates the cells of its window, its brick grown by
//! [`GHOST_LAYERS`] layers ([`RankSetup`]); the unknowns of the nodes a
//! rank does not own are ghosts, brought from their owners before each
//! apply ([`halo`]); and the Krylov methods of [`crate::solver`] run
//! unchanged over the rank's [`backend::DistBackend`], whose dot products
//! are summed over the ranks ([`crate::comm`]).
//!
//! The pieces of the body are joined across the ranks and checked held
//! ([`pieces`]); the solve takes the recovered load and the S-term, Krylov
//! with Jacobi or the multigrid V-cycle, every level shared out as the
//! solve's ([`solve`], [`multigrid`]); the reactions, error norms and the
//! body's counts are summed over the bricks into one report, and the
//! ParaView output is written in pieces ([`run`]). A rank may solve on its
//! GPU ([`backend`], Jacobi). Not distributed yet: the device V-cycle and
//! the Newton path.

pub mod backend;
pub mod halo;
pub mod multigrid;
pub mod partition;
pub mod pieces;
pub mod run;
pub mod solve;
pub mod surface;

#[cfg(test)]
mod tests;

use crate::case::Case;
use crate::cells::pieces::Naming;
use crate::cells::Cells;
use crate::comm::{agree, Comm};
use crate::driver::setup::Setup;
use crate::error::{Error, Result};
use crate::grid::CellBox;
use crate::multigrid::MultigridOptions;
use crate::progress::Progress;
use crate::solver::Preconditioner;

pub use backend::{DistBackend, DistOperator};
pub use halo::Halo;
pub use multigrid::{RankHierarchy, RankMultigrid};

/// Cells of ghost layers around a brick. An owned node's rows take its
/// cells (one layer); its recovered load takes the patches of those cells'
/// vertices, up to [`crate::recovery::SprOptions`]' three rings (three
/// more); and the cells at the window's edge may lack a negligible
/// neighbour merged into them (one more).
pub const GHOST_LAYERS: usize = 5;

/// Bricks' cut planes fall on multiples of this many cells.
pub const ALIGN: usize = 1;

/// One rank's share of a case: its brick and window, the set-up of the
/// window, and the halo of its unknowns.
pub struct RankSetup {
    pub bricks: Vec<CellBox>,
    pub window: CellBox,
    pub setup: Setup,
    pub halo: Halo,
    /// The multigrid levels under the rank's solve, when the case's solver
    /// asks for multigrid (or `auto`).
    pub multigrid: Option<RankHierarchy>,
}

impl RankSetup {
    /// This rank's share of `case` at `level` (default: the case's) among
    /// `comm`'s ranks. Collective.
    pub fn new(
        case: &Case,
        level: Option<u32>,
        comm: &dyn Comm,
        progress: &dyn Progress,
    ) -> Result<RankSetup> {
        let grid = case.grid(level)?;
        let kinds = Cells::rough_kinds(&grid, &case.body().geometry);
        let work = partition::cell_work(&kinds);
        let bricks = partition::bricks(&grid, &work, comm.size(), ALIGN)?;
        let window = bricks[comm.rank()].grown(GHOST_LAYERS, grid.n);
        let mut setup = agree(comm, Setup::in_window(case, level, &window, progress))?;
        let windows: Vec<CellBox> = bricks
            .iter()
            .map(|b| b.grown(GHOST_LAYERS, grid.n))
            .collect();
        pieces::join(comm, &grid, &windows, &mut setup.pieces);
        let brick = bricks[comm.rank()];
        let body = case.body();
        let naming = Naming {
            file: &case.file,
            key: &case.body_key(0, "dirichlet"),
            body: &body.spec.name,
        };
        let counts = |c: usize| brick.contains(grid.cell_ijk(c));
        pieces::check_held(comm, &setup, &counts, &body.geometry, &naming)?;
        keep_near(&mut setup, &brick);
        if setup.op.dofs.has_copies() {
            return Err(Error::UnsupportedOnBackend {
                backend: format!("distributed ({} ranks)", comm.size()),
                what: "bodies whose walls are split inside a cell".into(),
                hint: "run on one rank".into(),
            });
        }
        let halo = Halo::new(comm, &setup.grid, &setup.op.dofs, &bricks, GHOST_LAYERS);
        let mut rs = RankSetup {
            bricks,
            window,
            setup,
            halo,
            multigrid: None,
        };
        if let Preconditioner::Multigrid | Preconditioner::Auto = case.spec.solver.preconditioner {
            let h = RankHierarchy::new(case, &rs, comm, &MultigridOptions::default())?;
            rs.setup.timings.push(("multigrid".to_string(), h.seconds));
            rs.multigrid = Some(h);
        }
        Ok(rs)
    }

    /// The fixed right-hand side's owned entries (the ghosts' zero).
    pub fn fixed_rhs(&self) -> Vec<f64> {
        let mut b = self.setup.fixed_rhs.clone();
        self.halo.zero_ghosts(&mut b);
        b
    }
}

/// Keeps the recovered load's terms of the cells around the rank's own
/// nodes (one layer below its brick, the brick): the Dirichlet points, the
/// pathological cells and the recovered flux corrections of the others only
/// feed ghost rows, and their patches, cut by the window's edge, might not
/// fit.
fn keep_near(setup: &mut Setup, brick: &CellBox) {
    let near = CellBox {
        lo: brick.lo.map(|v| v.saturating_sub(1)),
        hi: brick.hi,
    };
    let grid = &setup.grid;
    let keep = |c: usize| near.contains(grid.cell_ijk(c));
    setup.dirichlet.retain(|p| keep(p.cell));
    setup.omega_star.retain(|&c| keep(c));
    let cut = &setup.cells.cut;
    setup.flux.keep_recovered(|i| keep(cut[i]));
}
