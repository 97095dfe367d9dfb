//! The linear path on several ranks (docs/distributed.md): the grid's
//! cells shared out as bricks balanced by work ([`partition`]); each rank
//! classifies and integrates the cells of its window, its brick grown by
//! [`GHOST_LAYERS`] layers ([`RankSetup`]); the unknowns of the nodes a
//! rank does not own are ghosts, brought from their owners before each
//! apply ([`halo`]); and the Krylov methods of [`crate::solver`] run
//! unchanged over the rank's [`backend::DistBackend`], whose dot products
//! are summed over the ranks ([`crate::comm`]).
//!
//! Built so far: the set-up, the pieces of the body across the ranks
//! ([`pieces`]) and the solve with the recovered load and the S-term
//! ([`solve`]), Krylov with Jacobi. The multigrid levels, the reactions and
//! error norms, the output and the check that every piece of the body is
//! held are not distributed yet, so no run of the program takes this path.

pub mod backend;
pub mod halo;
pub mod partition;
pub mod pieces;
pub mod run;
pub mod solve;

#[cfg(test)]
mod tests;

use crate::case::Case;
use crate::cells::Cells;
use crate::comm::Comm;
use crate::driver::setup::Setup;
use crate::error::{Error, Result};
use crate::grid::CellBox;
use crate::progress::Progress;

pub use backend::{DistBackend, DistOperator};
pub use halo::Halo;

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
        if setup.op.dofs.has_copies() {
            return Err(Error::UnsupportedOnBackend {
                backend: format!("distributed ({} ranks)", comm.size()),
                what: "bodies whose walls are split inside a cell".into(),
                hint: "run on one rank".into(),
            });
        }
        let halo = Halo::new(comm, &setup.grid, &setup.op.dofs, &bricks, GHOST_LAYERS);
        Ok(RankSetup {
            bricks,
            window,
            setup,
            halo,
        })
    }

    /// The fixed right-hand side's owned entries (the ghosts' zero).
    pub fn fixed_rhs(&self) -> Vec<f64> {
        let mut b = self.setup.fixed_rhs.clone();
        self.halo.zero_ghosts(&mut b);
        b
    }
}

/// `local` where every rank succeeded; otherwise this rank's error, or one
/// saying that another rank failed. Collective: every rank calls it where a
/// rank's own step may fail, so that none waits for a rank that gave up.
pub(crate) fn agree<T>(comm: &dyn Comm, local: Result<T>) -> Result<T> {
    let mut failed = [f64::from(u8::from(local.is_err()))];
    comm.sum(&mut failed);
    match (local, failed[0] > 0.0) {
        (Ok(v), false) => Ok(v),
        (Err(e), _) => Err(e),
        (Ok(_), true) => Err(Error::Distributed {
            what: "another rank failed; its error is in its own output".into(),
        }),
    }
}
