//! A V-cycle whose finest level is any operator over several blocks of
//! unknowns (the Newton tangent of a multi-body problem: each body's
//! tangent on its own grid, coupled by contact, with held rows), and whose
//! coarse correction is one [`Hierarchy`] per block (issue 17, item 2).
//!
//! # The cycle
//! With `A` the finest operator (`K_T` of the whole problem), `S` a
//! Chebyshev step over `D⁻¹A` ([`Chebyshev`], built for each `A`), per
//! block `k` the unknowns `[o_k, o_{k+1})` on the nodal lattice of its grid,
//! `P_k` the trilinear prolongation from the block's first coarse level and
//! `V_k` one V-cycle of that block's hierarchy:
//!
//! ```text
//! x = S(b, 0)
//! r = b − A x;  r_h = 0 on held rows
//! x_k = x_k + P_k V_k(P_kᵀ r_k)          every block k
//! x = S(b, x)
//! x_h = b_h on held rows
//! ```
//! Held rows and columns of `A` are the identity (the coupling sees held
//! entries as zero), so the exact inverse there is the identity, which is
//! what the last line applies; zeroing the held residual keeps the coarse
//! levels to the free unknowns. The cycle is symmetric when `A` is (the same
//! `S` before and after, `V_k` symmetric): it preconditions CG as well as
//! CGS and BiCGStab.
//!
//! The coarse levels see neither the contact coupling nor the current
//! state: they are the blocks' linear-elastic operators at the reference
//! configuration. The finest smoother sees both; what is left between the
//! two is for the Krylov method.

use std::ops::Range;
use std::sync::Mutex;

use super::smoother::{Chebyshev, Work};
use super::transfer::{Lattice, Transfer};
use super::{Hierarchy, Multigrid};
use crate::backend::{CpuBackend, LinearOperator};
use crate::error::Result;
use crate::fem::operator::ElasticOperator;
use crate::solver::ApplyInverse;

/// One block of the finest level and the hierarchy under it.
#[derive(Clone, Copy)]
pub struct Block<'a> {
    /// The block's unknowns in the finest operator.
    pub offset: usize,
    /// The block's nodal lattice on the finest level.
    pub fine: Lattice<'a>,
    /// The block's first coarse level (its grid coarsened once).
    pub top: &'a ElasticOperator,
    /// The levels below `top`.
    pub below: &'a Hierarchy,
}

impl Block<'_> {
    fn range(&self) -> Range<usize> {
        self.offset..self.offset + self.fine.dofs.ndofs()
    }

    fn transfer(&self) -> Transfer<'_> {
        Transfer {
            fine: self.fine,
            coarse: Lattice {
                dims: self.top.grid.nodes_per_axis(self.top.dofs.order),
                dofs: &self.top.dofs,
            },
        }
    }
}

/// The V-cycle over `op` and its blocks (module doc).
pub struct BlockMultigrid<'a> {
    op: &'a dyn LinearOperator,
    smoother: Chebyshev,
    held: &'a [bool],
    blocks: Vec<(Block<'a>, Multigrid<'a>)>,
    scratch: Mutex<Scratch>,
}

/// The finest smoother's vectors; per block the restricted residual and
/// its coarse correction.
struct Scratch {
    work: Work,
    coarse: Vec<(Vec<f64>, Vec<f64>)>,
}

impl<'a> BlockMultigrid<'a> {
    /// The cycle of `op` (held rows where `held` is true) over `blocks`,
    /// with a Chebyshev smoother of `degree` on `op`.
    ///
    /// # Panics
    /// If the blocks do not tile the unknowns of `op` in order.
    pub fn new(
        op: &'a dyn LinearOperator,
        held: &'a [bool],
        blocks: &[Block<'a>],
        degree: usize,
    ) -> Result<BlockMultigrid<'a>> {
        let n = op.nrows();
        assert_eq!(held.len(), n, "block multigrid: held mask of {n}");
        let mut next = 0;
        for b in blocks {
            assert_eq!(b.offset, next, "block multigrid: blocks tile the unknowns");
            next = b.range().end;
        }
        assert_eq!(next, n, "block multigrid: blocks tile the unknowns");
        let smoother = Chebyshev::new(op, degree)?;
        let coarse = blocks
            .iter()
            .map(|b| (vec![0.0; b.top.nrows()], vec![0.0; b.top.nrows()]))
            .collect();
        Ok(BlockMultigrid {
            op,
            smoother,
            held,
            blocks: blocks
                .iter()
                .map(|b| (*b, Multigrid::new(b.top, b.below)))
                .collect(),
            scratch: Mutex::new(Scratch {
                work: Work::new(n),
                coarse,
            }),
        })
    }

    /// `z = M⁻¹ r`: one cycle from `z = 0` (module doc).
    ///
    /// # Panics
    /// If `r` or `z` do not have the size of the operator.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        let n = self.op.nrows();
        assert!(
            r.len() == n && z.len() == n,
            "block multigrid: vectors of {n}"
        );
        let mut guard = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        let Scratch { work, coarse } = &mut *guard;
        self.smoother.smooth(self.op, r, z, true, work);
        self.smoother.residual(self.op, r, z, work);
        let res = work.residual_mut();
        for (v, &h) in res.iter_mut().zip(self.held) {
            if h {
                *v = 0.0;
            }
        }
        for ((block, mg), (bc, xc)) in self.blocks.iter().zip(coarse.iter_mut()) {
            let range = block.range();
            let transfer = block.transfer();
            transfer.restrict(&work.residual()[range.clone()], bc);
            mg.apply(bc, xc);
            transfer.prolong_add(xc, &mut z[range]);
        }
        self.smoother.smooth(self.op, r, z, false, work);
        for ((zi, ri), &h) in z.iter_mut().zip(r).zip(self.held) {
            if h {
                *zi = *ri;
            }
        }
    }
}

impl ApplyInverse<CpuBackend> for BlockMultigrid<'_> {
    fn apply_inverse(&self, r: &Vec<f64>, z: &mut Vec<f64>) {
        self.apply(r, z);
    }
}
