//! The multigrid V-cycle on several ranks: the one-rank hierarchy
//! ([`crate::multigrid`]) with each level shared out as the solve's level is.
//!
//! - **Levels.** Below a Q2 operator the Q1 operator of the same cells and
//!   bricks; below a Q1 operator the coarsened grid, whose bricks are the
//!   level above's halved ([`coarse_bricks`]), each rank classifying the
//!   cells of its coarse brick grown by [`COARSE_GHOST_LAYERS`]. Every level
//!   carries the Galerkin product of the solve's S-term: the pathological
//!   cells of every brick are gathered once, so a rank adds the fine cells
//!   under its coarse window whoever owns them.
//! - **Smoothers.** Each rank's Chebyshev smoother is the one-rank one over
//!   its window ([`Chebyshev::on`]): the diagonal floored against the whole
//!   level's largest entry, the blocks of its cut cells, and the Lanczos
//!   estimate with the ghosts brought before each apply and block solve and
//!   exact dot products over the ranks, so every rank gets the one-rank
//!   interval.
//! - **Transfers.** Restriction and prolongation are the one-rank gathers
//!   over the rank's window, after its input's ghosts are brought
//!   ([`Reach::Window`]); the ghost rows of the output are zeroed again.
//! - **Coarsest level.** Every rank gathers the owned columns of the
//!   coarsest operator into the whole level's matrix, numbered as one rank
//!   numbers it, and factors it; each coarse solve gathers the right-hand
//!   side's owned entries, solves on every rank and keeps its own.
//!
//! Every owned row of every step is computed from the same numbers in the
//! same order as on one rank, so a V-cycle on P ranks is the one-rank cycle
//! to the bit.

use std::cell::RefCell;
use std::time::Instant;

use faer::dyn_stack::MemBuffer;
use faer::sparse::{SparseColMat, Triplet};

use super::backend::DistBackend;
use super::halo::{Halo, Reach};
use super::{RankSetup, GHOST_LAYERS};
use crate::backend::LinearOperator;
use crate::case::Case;
use crate::comm::{agree, Comm};
use crate::condition::sparse::Cholesky;
use crate::error::{Error, Result};
use crate::fem::level::pathological_cells;
use crate::fem::operator::ElasticOperator;
use crate::grid::{CellBox, Grid};
use crate::multigrid::blocks::BlockJacobi;
use crate::multigrid::cycle::{vcycle, HostLevels, LevelWork, OnHost};
use crate::multigrid::galerkin_s::FineSTerm;
use crate::multigrid::smoother::{Chebyshev, LevelShare};
use crate::multigrid::transfer::{Lattice, Transfer};
use crate::multigrid::{level_below, rediscretised, shifted_factor, LevelBelow, MultigridOptions};
use crate::progress::Silent;
use crate::solver::ApplyInverse;

/// Cells of ghost layers around a coarse level's brick: the cells around
/// its owned nodes (one), their neighbours merged into them (one), and one
/// to spare.
pub const COARSE_GHOST_LAYERS: usize = 3;

/// The bricks of the grid coarsened from the one `bricks` share out, `n`
/// coarse cells per axis: every cut plane halved, rounded up (they still
/// tile the grid; a brick may be empty).
pub fn coarse_bricks(bricks: &[CellBox], n: [usize; 3]) -> Vec<CellBox> {
    bricks
        .iter()
        .map(|b| CellBox {
            lo: [0, 1, 2].map(|a| b.lo[a].div_ceil(2).min(n[a])),
            hi: [0, 1, 2].map(|a| b.hi[a].div_ceil(2).min(n[a])),
        })
        .collect()
}

/// A level below the solve's on this rank: its operator over the rank's
/// window and its halo.
struct Level {
    op: ElasticOperator,
    halo: Halo,
}

/// The levels below a rank's solve, their smoothers and the coarsest
/// level's factor.
pub struct RankHierarchy {
    coarse: Vec<Level>,
    smoothers: Vec<Chebyshev>,
    coarsest: Coarsest,
    /// Seconds to build it all.
    pub seconds: f64,
}

/// The unknowns of one level on one rank, as its smoother and cycle see them.
struct Share<'a> {
    comm: &'a dyn Comm,
    op: &'a ElasticOperator,
    halo: &'a Halo,
    /// An input with its ghosts brought.
    filled: RefCell<Vec<f64>>,
}

impl<'a> Share<'a> {
    fn new(comm: &'a dyn Comm, op: &'a ElasticOperator, halo: &'a Halo) -> Self {
        Share {
            comm,
            op,
            halo,
            filled: RefCell::new(vec![0.0; op.nrows()]),
        }
    }

    /// `f(x with its ghosts of reach brought)`.
    fn with_ghosts<T>(&self, x: &[f64], reach: Reach, f: impl FnOnce(&[f64]) -> T) -> T {
        let mut filled = self.filled.borrow_mut();
        filled.copy_from_slice(x);
        self.halo.fill_ghosts(self.comm, &mut filled, reach);
        f(&filled)
    }
}

impl LevelShare for Share<'_> {
    fn comm(&self) -> &dyn Comm {
        self.comm
    }

    fn owns(&self, a: usize) -> bool {
        self.halo.owns(a)
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.with_ghosts(x, Reach::Near, |x| self.op.apply(x, y));
        self.halo.zero_ghosts(y);
    }

    fn precondition(&self, pre: &BlockJacobi, r: &[f64], z: &mut [f64]) {
        self.with_ghosts(r, Reach::Near, |r| pre.apply(r, z));
        self.halo.zero_ghosts(z);
    }
}

/// Unknowns of a level over the ranks.
fn total_rows(comm: &dyn Comm, halo: &Halo) -> usize {
    let mut n = [3.0 * halo.num_owned() as f64];
    comm.sum(&mut n);
    n[0] as usize
}

impl RankHierarchy {
    /// The hierarchy under the rank's solve (`rs`), as the one-rank
    /// [`crate::multigrid::Hierarchy::new`] builds it under the whole
    /// grid's. Collective.
    pub fn new(
        case: &Case,
        rs: &RankSetup,
        comm: &dyn Comm,
        opts: &MultigridOptions,
    ) -> Result<RankHierarchy> {
        let t = Instant::now();
        let setup = &rs.setup;
        let fine = &setup.op;
        let st = &case.spec.stabilisation;
        let omega_star = gathered_cells(
            comm,
            &setup.grid,
            &rs.bricks[comm.rank()],
            &pathological_cells(&setup.cells, st.threshold(fine.dofs.order)),
        );
        let factor = st.k2 * setup.problem.young / (fine.grid.h * fine.grid.h);
        let mut coarse: Vec<Level> = Vec::new();
        let mut bricks = rs.bricks.clone();
        loop {
            let (last, halo) = coarse.last().map_or((fine, &rs.halo), |l| (&l.op, &l.halo));
            if total_rows(comm, halo) <= opts.coarse_dofs {
                break;
            }
            let Some(below) = level_below(last) else {
                break;
            };
            let (grid, ghost) = match below {
                LevelBelow::SameCells(grid) => (grid, GHOST_LAYERS),
                LevelBelow::Coarser(grid) => {
                    bricks = coarse_bricks(&bricks, grid.n);
                    (grid, COARSE_GHOST_LAYERS)
                }
            };
            let window = bricks[comm.rank()].grown(ghost, grid.n);
            let level = agree(
                comm,
                level_on(case, rs, &grid, &window, &omega_star, factor),
            )?;
            let halo = Halo::new(comm, &grid, &level.dofs, &bricks, ghost);
            coarse.push(Level { op: level, halo });
        }
        let mut smoothers = Vec::new();
        let levels: Vec<(&ElasticOperator, &Halo)> = std::iter::once((fine, &rs.halo))
            .chain(coarse.iter().map(|l| (&l.op, &l.halo)))
            .collect();
        let (&(last, last_halo), smoothed) = levels.split_last().expect("level 0 exists");
        for &(op, halo) in smoothed {
            smoothers.push(Chebyshev::on(op, &Share::new(comm, op, halo), opts.degree)?);
        }
        let coarsest = agree(comm, Coarsest::new(comm, last, last_halo))?;
        Ok(RankHierarchy {
            coarse,
            smoothers,
            coarsest,
            seconds: t.elapsed().as_secs_f64(),
        })
    }

    /// Number of levels, the solve's included.
    pub fn num_levels(&self) -> usize {
        self.coarse.len() + 1
    }
}

/// The sorted union over the ranks of `cells`, the ones of each rank's
/// `brick` taken. Collective.
fn gathered_cells(comm: &dyn Comm, grid: &Grid, brick: &CellBox, cells: &[usize]) -> Vec<usize> {
    let mine: Vec<f64> = cells
        .iter()
        .filter(|&&c| brick.contains(grid.cell_ijk(c)))
        .map(|&c| c as f64)
        .collect();
    let mut all: Vec<usize> = comm
        .all_gather(&mine)
        .into_iter()
        .flatten()
        .map(|c| c as usize)
        .collect();
    all.sort_unstable();
    all
}

/// The Q1 level on `grid` over this rank's `window`: the solve's cells
/// when the grid is the solve's, else the window's classified; with the
/// Galerkin product of the fine S-term's cells (`omega_star`, the whole
/// grid's, weight `factor`) that lie under the window.
fn level_on(
    case: &Case,
    rs: &RankSetup,
    grid: &Grid,
    window: &CellBox,
    omega_star: &[usize],
    factor: f64,
) -> Result<ElasticOperator> {
    let fine = &rs.setup.grid;
    let ratio = 1usize << (fine.level - grid.level);
    let under: Vec<usize> = omega_star
        .iter()
        .copied()
        .filter(|&c| window.contains(fine.cell_ijk(c).map(|i| i / ratio)))
        .collect();
    let s_term = FineSTerm {
        grid: fine,
        cells: &under,
        factor,
    };
    let problem = &rs.setup.problem;
    match grid == fine {
        true => rediscretised(case, problem, grid, &rs.setup.cells, &s_term),
        false => {
            let cells = case.classify_in(grid, window, &Silent)?;
            rediscretised(case, problem, grid, &cells, &s_term)
        }
    }
}

/// The coarsest level on every rank: the whole level's factor, and where
/// each rank's owned unknowns sit in it.
struct Coarsest {
    /// This rank's owned nodes (local).
    owned: Vec<usize>,
    /// Per rank, the whole level's node index of each of its owned nodes.
    places: Vec<Vec<usize>>,
    factor: Cholesky,
}

impl Coarsest {
    /// The factor of the whole coarsest level from every rank's owned
    /// columns of `op` (numbered as one rank numbers it: lattice order),
    /// shifted as one rank shifts it. Collective.
    fn new(comm: &dyn Comm, op: &ElasticOperator, halo: &Halo) -> Result<Coarsest> {
        let dofs = &op.dofs;
        let owned: Vec<usize> = (0..dofs.num_active()).filter(|&a| halo.owns(a)).collect();
        let ids: Vec<f64> = owned
            .iter()
            .map(|&a| f64::from(dofs.active_to_node[a]))
            .collect();
        let all_ids = comm.all_gather(&ids);
        let mut nodes: Vec<u32> = all_ids.iter().flatten().map(|&v| v as u32).collect();
        nodes.sort_unstable();
        let place = |node: u32| {
            nodes
                .binary_search(&node)
                .expect("every active node is owned by a rank")
        };
        let places: Vec<Vec<usize>> = all_ids
            .iter()
            .map(|ids| ids.iter().map(|&v| place(v as u32)).collect())
            .collect();
        // The owned columns (rows, by symmetry) and diagonal entries.
        let a = op.assemble();
        let d = op.diagonal();
        let mut entries = Vec::new();
        let mut diagonal = Vec::new();
        for (&local, &global) in owned.iter().zip(&places[comm.rank()]) {
            for c in 0..3 {
                let j = 3 * local + c;
                diagonal.push(d[j]);
                let rows = a.row_idx_of_col(j);
                for (i, &v) in rows.zip(a.val_of_col(j)) {
                    let node = dofs.active_to_node[i / 3];
                    let row = 3 * place(node) + i % 3;
                    entries.extend([row as f64, (3 * global + c) as f64, v]);
                }
            }
        }
        let n = 3 * nodes.len();
        let mut whole_diagonal = vec![0.0; n];
        for (rank, values) in comm.all_gather(&diagonal).iter().enumerate() {
            for (k, &node) in places[rank].iter().enumerate() {
                whole_diagonal[3 * node..3 * node + 3].copy_from_slice(&values[3 * k..3 * k + 3]);
            }
        }
        let triplets: Vec<Triplet<usize, usize, f64>> = comm
            .all_gather(&entries)
            .iter()
            .flat_map(|e| e.chunks_exact(3))
            .map(|t| Triplet::new(t[0] as usize, t[1] as usize, t[2]))
            .collect();
        let whole = SparseColMat::try_new_from_triplets(n, n, &triplets).map_err(|e| {
            Error::Distributed {
                what: format!("the coarsest level's matrix: {e:?}"),
            }
        })?;
        let (factor, _shift) = shifted_factor(whole, whole_diagonal, op.grid.level)?;
        Ok(Coarsest {
            owned,
            places,
            factor,
        })
    }
}

/// One V-cycle on the rank's share of every level, as the Krylov solve's
/// preconditioner.
pub struct RankMultigrid<'a> {
    levels: OnHost<RankLevels<'a>>,
    work: RefCell<Vec<LevelWork<Vec<f64>>>>,
}

/// The rank's [`HostLevels`].
struct RankLevels<'a> {
    shares: Vec<Share<'a>>,
    hierarchy: &'a RankHierarchy,
    /// The whole coarsest vector and the factor's solve scratch.
    coarse: RefCell<(Vec<f64>, MemBuffer)>,
}

impl<'a> RankMultigrid<'a> {
    /// The V-cycle of `hierarchy` under the rank's solve `rs`.
    pub fn new(rs: &'a RankSetup, hierarchy: &'a RankHierarchy, comm: &'a dyn Comm) -> Self {
        let shares = std::iter::once(Share::new(comm, &rs.setup.op, &rs.halo))
            .chain(
                hierarchy
                    .coarse
                    .iter()
                    .map(|l| Share::new(comm, &l.op, &l.halo)),
            )
            .collect();
        let c = &hierarchy.coarsest;
        let n = 3 * c.places.iter().map(Vec::len).sum::<usize>();
        let levels = OnHost(RankLevels {
            shares,
            hierarchy,
            coarse: RefCell::new((vec![0.0; n], c.factor.solve_scratch())),
        });
        let work = RefCell::new(LevelWork::all(&levels));
        RankMultigrid { levels, work }
    }
}

impl ApplyInverse<DistBackend<'_>> for RankMultigrid<'_> {
    /// One V-cycle from zero on `A z = r`. Collective.
    fn apply_inverse(&self, r: &Vec<f64>, z: &mut Vec<f64>) {
        vcycle(&self.levels, 0, r, z, &mut self.work.borrow_mut());
    }
}

impl<'a> RankLevels<'a> {
    /// The transfer between level `i` and level `i + 1`.
    fn transfer(&self, i: usize) -> Transfer<'a> {
        let lattice = |op: &'a ElasticOperator| Lattice {
            dims: op.grid.nodes_per_axis(op.dofs.order),
            dofs: &op.dofs,
        };
        Transfer {
            fine: lattice(self.shares[i].op),
            coarse: lattice(self.shares[i + 1].op),
        }
    }
}

impl HostLevels for RankLevels<'_> {
    fn num_levels(&self) -> usize {
        self.shares.len()
    }

    fn nrows(&self, level: usize) -> usize {
        self.shares[level].op.nrows()
    }

    fn smoother(&self, level: usize) -> &Chebyshev {
        &self.hierarchy.smoothers[level]
    }

    fn apply(&self, level: usize, x: &[f64], y: &mut [f64]) {
        self.shares[level].apply(x, y);
    }

    fn precondition(&self, level: usize, r: &[f64], z: &mut [f64]) {
        self.shares[level].precondition(&self.hierarchy.smoothers[level].pre, r, z);
    }

    /// The fine residual's ghosts brought, the coarse ghost rows zeroed.
    fn restrict(&self, level: usize, fine: &[f64], coarse: &mut [f64]) {
        let transfer = self.transfer(level);
        self.shares[level].with_ghosts(fine, Reach::Window, |f| transfer.restrict(f, coarse));
        self.shares[level + 1].halo.zero_ghosts(coarse);
    }

    /// The coarse correction's ghosts brought, the fine ghost rows zeroed.
    fn prolong_add(&self, level: usize, coarse: &[f64], fine: &mut [f64]) {
        let transfer = self.transfer(level);
        self.shares[level + 1]
            .with_ghosts(coarse, Reach::Window, |c| transfer.prolong_add(c, fine));
        self.shares[level].halo.zero_ghosts(fine);
    }

    /// Every rank's owned entries gathered into the whole level, solved on
    /// every rank, this rank's kept.
    fn coarse_solve(&self, b: &[f64], x: &mut [f64]) {
        let c = &self.hierarchy.coarsest;
        let comm = self.shares[0].comm;
        let mine: Vec<f64> = c
            .owned
            .iter()
            .flat_map(|&a| b[3 * a..3 * a + 3].iter().copied())
            .collect();
        let mut guard = self.coarse.borrow_mut();
        let (whole, scratch) = &mut *guard;
        for (rank, values) in comm.all_gather(&mine).iter().enumerate() {
            for (k, &node) in c.places[rank].iter().enumerate() {
                whole[3 * node..3 * node + 3].copy_from_slice(&values[3 * k..3 * k + 3]);
            }
        }
        c.factor.solve_in_place_with(whole, scratch);
        x.fill(0.0);
        for (&a, &node) in c.owned.iter().zip(&c.places[comm.rank()]) {
            x[3 * a..3 * a + 3].copy_from_slice(&whole[3 * node..3 * node + 3]);
        }
    }
}
