//! The multigrid V-cycle on the device: the hierarchy the set-up built on
//! the CPU ([`Hierarchy`]: level operators, Chebyshev intervals, cut-band
//! blocks, coarsest factor) uploaded once, and the one V-cycle of
//! [`crate::multigrid::cycle`] run over it ([`DeviceCycle`]), so that the
//! cycle is the CPU's step for step:
//!
//! - the level operators as [`GpuOperator`]s (the Q1 plan; the gather for Q2);
//! - the smoother's `B⁻¹`: `pointwise_mul` with `D⁻¹` (0 on the blocks), then
//!   `block_rows`, each block entry's row of its block's inverse;
//! - the Chebyshev step `chebyshev_update` and the vector kernels;
//! - restriction and prolongation as gathers over the lattices' index maps
//!   (`restrict`, `prolong_add`; no atomics);
//! - the coarsest level by its dense inverse (`dense_matvec`), computed from
//!   the Cholesky factor at upload; where the inverse would not fit one
//!   storage binding, the coarsest right-hand side goes to the host, is
//!   solved with the factor and comes back (a few thousand entries).
//!
//! Every array of the cycle is bound whole: a level vector or index map
//! beyond one storage binding is [`Error::DeviceTooSmall`].
//!
//! A [`DeviceCycle`] keeps what its first application recorded (each
//! dispatch's bind group and params, the clears) and replays it when it is
//! applied again to the same vectors `r` and `z`, as a Krylov solve does
//! every iteration: the cycle's order of steps depends on the hierarchy
//! only. Not where the coarsest level is solved on the host.

use std::cell::RefCell;
use std::sync::Mutex;

use faer::dyn_stack::MemBuffer;
use rayon::prelude::*;

use super::backend::{GpuBackend, GpuVector};
use super::kernels::{grid_2d, GatherParams, Kernel, WG};
use super::operator::GpuOperator;
use super::record::{whole, Step};
use crate::backend::{Backend, LinearOperator};
use crate::condition::sparse::Cholesky;
use crate::error::{Error, Result};
use crate::fem::operator::ElasticOperator;
use crate::multigrid::blocks::BlockJacobi;
use crate::multigrid::cycle::{vcycle, CycleOps, LevelWork};
use crate::multigrid::smoother::{chebyshev_coefficients, Chebyshev};
use crate::multigrid::Hierarchy;
use crate::solver::ApplyInverse;

/// The hierarchy on the device, level 0's operator excepted (the solver's).
pub struct DeviceMultigrid<'h> {
    coarse: Vec<GpuOperator<'h>>,
    smoothers: Vec<Smoother>,
    lattices: Vec<Lattice>,
    coarsest: Coarsest<'h>,
    work: RefCell<Vec<LevelWork<GpuVector>>>,
}

/// One level's smoother: `D⁻¹` off the blocks, the blocks, the interval,
/// and its constants on the device: the Chebyshev coefficients `(a, c)` of
/// every update in turn, then `−1` (for `r − v` and `b − r`).
struct Smoother {
    point: GpuVector,
    blocks: Option<Blocks>,
    lo: f64,
    hi: f64,
    degree: usize,
    constants: wgpu::Buffer,
}

/// The cut-band blocks of [`crate::multigrid::blocks::BlockJacobi`].
struct Blocks {
    entries: u32,
    dofs: wgpu::Buffer,
    block_of: wgpu::Buffer,
    starts: wgpu::Buffer,
    inv_starts: wgpu::Buffer,
    inverses: wgpu::Buffer,
}

/// A level's nodal lattice: nodes per axis and the active ↔ node maps.
struct Lattice {
    dims: [u32; 3],
    active: u32,
    active_to_node: wgpu::Buffer,
    node_to_active: wgpu::Buffer,
}

/// How the coarsest level is solved.
enum Coarsest<'h> {
    /// Its inverse, dense, on the device.
    Dense { inverse: wgpu::Buffer, n: u32 },
    /// On the host with the factor (the inverse would not fit one binding).
    Host(&'h Cholesky, Mutex<MemBuffer>),
}

/// `A⁻¹` of the factored matrix, dense, column `j` at `j n`.
pub(super) fn dense_inverse(factor: &Cholesky, n: usize) -> Vec<f64> {
    let mut a = vec![0.0; n * n];
    a.par_chunks_mut(n.max(1)).enumerate().for_each_init(
        || factor.solve_scratch(),
        |mem, (j, col)| {
            col[j] = 1.0;
            factor.solve_in_place_with(col, mem);
        },
    );
    a
}

/// The index arrays of `block_rows` for a block Jacobi preconditioner (the
/// device's and the mirror's): each entry's unknown and block, each block's
/// first entry (and one past the last) and the start of its inverse.
pub struct BlockArrays {
    pub dofs: Vec<u32>,
    pub block_of: Vec<u32>,
    pub starts: Vec<u32>,
    pub inv_starts: Vec<u32>,
}

impl BlockArrays {
    pub fn new(pre: &BlockJacobi) -> BlockArrays {
        let u32s = |v: &[usize]| v.iter().map(|&x| x as u32).collect();
        let block_of = (0..pre.starts.len() - 1)
            .flat_map(|b| std::iter::repeat_n(b as u32, pre.starts[b + 1] - pre.starts[b]))
            .collect();
        BlockArrays {
            dofs: u32s(&pre.dofs),
            block_of,
            starts: u32s(&pre.starts),
            inv_starts: u32s(&pre.inverse_starts),
        }
    }
}

impl<'h> DeviceMultigrid<'h> {
    /// Uploads `hierarchy` (built for the host operator `fine`) to the device
    /// of `be`.
    pub fn new(
        be: &GpuBackend,
        fine: &'h ElasticOperator,
        hierarchy: &'h Hierarchy,
    ) -> Result<DeviceMultigrid<'h>> {
        let levels = hierarchy.num_levels();
        let ops: Vec<&ElasticOperator> = (0..levels).map(|i| hierarchy.level(fine, i)).collect();
        let bytes = be.precision().bytes();
        let max = be.bindings().max_bytes;
        for op in &ops {
            let lattice = op.dofs.node_to_active.len() as u64 * 4;
            if op.nrows() as u64 * bytes > max || lattice > max {
                return Err(Error::DeviceTooSmall {
                    what: format!(
                        "the multigrid level of {} dofs exceeds one storage binding of {max} \
                         bytes; use solver.preconditioner = \"jacobi\" or --backend cpu",
                        op.nrows()
                    ),
                });
            }
        }
        let coarse = ops[1..]
            .iter()
            .map(|op| GpuOperator::new(be, op))
            .collect::<Result<Vec<_>>>()?;
        let smoothers = hierarchy
            .smoothers
            .iter()
            .map(|s| Smoother::new(be, s))
            .collect::<Result<Vec<_>>>()?;
        let lattices = ops
            .iter()
            .map(|op| {
                let d = op.grid.nodes_per_axis(op.dofs.order);
                Lattice {
                    dims: d.map(|x| x as u32),
                    active: op.dofs.num_active() as u32,
                    active_to_node: be.buffer_init(
                        "active to node",
                        bytemuck::cast_slice(&op.dofs.active_to_node),
                    ),
                    node_to_active: be.buffer_init(
                        "node to active",
                        bytemuck::cast_slice(&op.dofs.node_to_active),
                    ),
                }
            })
            .collect();
        let n = ops[levels - 1].nrows();
        let coarsest = if (n * n) as u64 * bytes <= max {
            let inverse = dense_inverse(&hierarchy.direct, n);
            Coarsest::Dense {
                inverse: be.buffer_init("coarsest inverse", &be.to_bytes(&inverse)),
                n: n as u32,
            }
        } else {
            let scratch = Mutex::new(hierarchy.direct.solve_scratch());
            Coarsest::Host(&hierarchy.direct, scratch)
        };
        Ok(DeviceMultigrid {
            coarse,
            smoothers,
            lattices,
            coarsest,
            work: RefCell::new(Vec::new()),
        })
    }

    /// The V-cycle over the solve's operator `fine` on the device, its work
    /// vectors allocated on first use.
    pub fn cycle<'a>(&'a self, be: &'a GpuBackend, fine: &'a GpuOperator<'a>) -> DeviceCycle<'a> {
        let cycle = DeviceCycle {
            be,
            fine,
            mg: self,
            enc: RefCell::new(None),
            tape: RefCell::new(None),
        };
        if self.work.borrow().len() != self.coarse.len() {
            *self.work.borrow_mut() = LevelWork::all(&cycle);
        }
        cycle
    }
}

impl Smoother {
    fn new(be: &GpuBackend, s: &Chebyshev) -> Result<Smoother> {
        let pre = &s.pre;
        let max = be.bindings().max_bytes;
        let blocks = if pre.dofs.is_empty() {
            None
        } else {
            if pre.inverses.len() as u64 * be.precision().bytes() > max {
                return Err(Error::DeviceTooSmall {
                    what: format!(
                        "the smoother's cut-band blocks ({} entries) exceed one storage \
                         binding of {max} bytes; use solver.preconditioner = \"jacobi\" \
                         or --backend cpu",
                        pre.inverses.len()
                    ),
                });
            }
            let a = BlockArrays::new(pre);
            let u32s = |label: &str, v: &[u32]| be.buffer_init(label, bytemuck::cast_slice(v));
            Some(Blocks {
                entries: a.dofs.len() as u32,
                dofs: u32s("block dofs", &a.dofs),
                block_of: u32s("block of entry", &a.block_of),
                starts: u32s("block starts", &a.starts),
                inv_starts: u32s("block inverse starts", &a.inv_starts),
                inverses: be.buffer_init("block inverses", &be.to_bytes(&pre.inverses)),
            })
        };
        let mut constants: Vec<f64> = chebyshev_coefficients(s.lo, s.hi, s.degree)
            .into_iter()
            .flat_map(|(a, c)| [a, c])
            .collect();
        constants.push(-1.0);
        Ok(Smoother {
            point: be.upload(&pre.point),
            blocks,
            lo: s.lo,
            hi: s.hi,
            degree: s.degree,
            constants: be.buffer_init("smoother constants", &be.to_bytes(&constants)),
        })
    }
}

/// The V-cycle on the device: [`CycleOps`] over the uploaded hierarchy and
/// the solve's operator, and the preconditioner of a GPU Krylov solve. Its
/// steps record into one command encoder, submitted once per cycle (every
/// scalar the cycle needs is on the device beforehand); [`DeviceCycle::flush`]
/// submits what is recorded.
pub struct DeviceCycle<'a> {
    be: &'a GpuBackend,
    fine: &'a GpuOperator<'a>,
    mg: &'a DeviceMultigrid<'a>,
    enc: RefCell<Option<wgpu::CommandEncoder>>,
    /// The steps of the last application and its `r`, `z`.
    tape: RefCell<Option<Tape>>,
}

/// A cycle's steps for the vectors `r`, `z` it was applied to.
struct Tape {
    r: wgpu::Buffer,
    z: wgpu::Buffer,
    steps: Vec<Step>,
}

impl DeviceCycle<'_> {
    fn op(&self, level: usize) -> &GpuOperator<'_> {
        match level {
            0 => self.fine,
            i => &self.mg.coarse[i - 1],
        }
    }

    /// Records with `f` into the open encoder (opened if none is).
    fn record(&self, f: impl FnOnce(&mut wgpu::CommandEncoder)) {
        let mut enc = self.enc.borrow_mut();
        f(enc.get_or_insert_with(|| self.be.encoder()));
    }

    /// Submits what is recorded.
    pub fn flush(&self) {
        if let Some(enc) = self.enc.borrow_mut().take() {
            self.be.submit(enc);
        }
    }

    /// Records one gather kernel over `prm.n` invocations.
    fn gather(&self, kernel: Kernel, prm: GatherParams, binds: &[wgpu::BindingResource<'_>]) {
        if prm.n == 0 {
            return;
        }
        let (x, y, stride) = grid_2d(prm.n, WG, self.be.max_dim());
        let prm = GatherParams { stride, ..prm };
        let bytes = bytemuck::bytes_of(&prm);
        self.record(|enc| self.be.record(enc, kernel, bytes, binds, (x, y)));
    }

    /// Records an element-wise kernel over `n` entries, its scalars at slots
    /// `slots` of `scalars`.
    fn vector(&self, kernel: Kernel, n: usize, slots: (u32, u32), bufs: &[&wgpu::Buffer]) {
        self.record(|enc| self.be.record_vec(enc, kernel, n, slots, bufs));
    }

    /// The slot of `−1` in `level`'s constants.
    fn minus_one(&self, level: usize) -> u32 {
        2 * self.mg.smoothers[level].degree as u32
    }

    /// Records a transfer between `level` and `level + 1` (`restrict` or
    /// `prolong_add`): one invocation per active node of the lattice written,
    /// gathering from the lattice read.
    fn transfer(
        &self,
        kernel: Kernel,
        level: usize,
        (input, from): (&GpuVector, &Lattice),
        (output, to): (&GpuVector, &Lattice),
    ) {
        let (f, c) = (&self.mg.lattices[level], &self.mg.lattices[level + 1]);
        let prm = GatherParams {
            n: to.active,
            stride: 0,
            fx: f.dims[0],
            fy: f.dims[1],
            fz: f.dims[2],
            cx: c.dims[0],
            cy: c.dims[1],
            cz: c.dims[2],
        };
        let binds = [
            whole(&input.buf),
            whole(&output.buf),
            whole(&to.active_to_node),
            whole(&from.node_to_active),
        ];
        self.gather(kernel, prm, &binds);
    }
}

impl ApplyInverse<GpuBackend> for DeviceCycle<'_> {
    fn apply_inverse(&self, r: &GpuVector, z: &mut GpuVector) {
        if let Some(tape) = self.tape.borrow().as_ref() {
            if tape.r == r.buf && tape.z == z.buf {
                let mut enc = self.be.encoder();
                self.be.replay(&mut enc, &tape.steps);
                self.be.submit(enc);
                return;
            }
        }
        let replayable = matches!(self.mg.coarsest, Coarsest::Dense { .. });
        if replayable {
            self.be.begin_capture();
        }
        let mut work = self.mg.work.borrow_mut();
        vcycle(self, 0, r, z, &mut work);
        self.flush();
        *self.tape.borrow_mut() = replayable.then(|| Tape {
            r: r.buf.clone(),
            z: z.buf.clone(),
            steps: self.be.end_capture(),
        });
    }
}

impl CycleOps for DeviceCycle<'_> {
    type Vector = GpuVector;

    fn num_levels(&self) -> usize {
        self.mg.coarse.len() + 1
    }

    fn nrows(&self, level: usize) -> usize {
        self.op(level).nrows()
    }

    fn zeros(&self, n: usize) -> GpuVector {
        self.be.zeros(n)
    }

    fn apply(&self, level: usize, x: &GpuVector, y: &mut GpuVector) {
        self.record(|enc| self.op(level).record_apply(self.be, enc, &x.buf, &y.buf));
    }

    fn precondition(&self, level: usize, r: &GpuVector, z: &mut GpuVector) {
        let s = &self.mg.smoothers[level];
        let bufs = [&s.point.buf, &r.buf, &z.buf];
        self.vector(Kernel::PointwiseMul, r.len, (0, 0), &bufs);
        if let Some(b) = &s.blocks {
            let prm = GatherParams {
                n: b.entries,
                ..Default::default()
            };
            let binds = [
                whole(&r.buf),
                whole(&z.buf),
                whole(&b.dofs),
                whole(&b.block_of),
                whole(&b.starts),
                whole(&b.inv_starts),
                whole(&b.inverses),
            ];
            self.gather(Kernel::BlockRows, prm, &binds);
        }
    }

    fn chebyshev(&self, level: usize) -> (f64, f64, usize) {
        let s = &self.mg.smoothers[level];
        (s.lo, s.hi, s.degree)
    }

    fn chebyshev_update(
        &self,
        level: usize,
        step: usize,
        _coef: (f64, f64),
        z: &GpuVector,
        d: &mut GpuVector,
        x: &mut GpuVector,
    ) {
        let s = &self.mg.smoothers[level];
        let bufs = [&s.constants, &z.buf, &d.buf, &x.buf];
        let slots = (2 * step as u32, 2 * step as u32 + 1);
        self.vector(Kernel::ChebyshevUpdate, x.len, slots, &bufs);
    }

    fn sub_assign(&self, level: usize, r: &mut GpuVector, v: &GpuVector) {
        let bufs = [&self.mg.smoothers[level].constants, &v.buf, &r.buf];
        self.vector(Kernel::Axpy, r.len, (self.minus_one(level), 0), &bufs);
    }

    fn rsub_assign(&self, level: usize, r: &mut GpuVector, b: &GpuVector) {
        let bufs = [&self.mg.smoothers[level].constants, &b.buf, &r.buf];
        self.vector(Kernel::Xpay, r.len, (self.minus_one(level), 0), &bufs);
    }

    fn copy(&self, src: &GpuVector, dst: &mut GpuVector) {
        self.vector(Kernel::Copy, src.len, (0, 0), &[&src.buf, &dst.buf]);
    }

    fn fill_zero(&self, x: &mut GpuVector) {
        self.record(|enc| self.be.record_clear(enc, &x.buf));
    }

    fn restrict(&self, level: usize, fine: &GpuVector, coarse: &mut GpuVector) {
        let (f, c) = (&self.mg.lattices[level], &self.mg.lattices[level + 1]);
        self.transfer(Kernel::Restrict, level, (fine, f), (coarse, c));
    }

    fn prolong_add(&self, level: usize, coarse: &GpuVector, fine: &mut GpuVector) {
        let (f, c) = (&self.mg.lattices[level], &self.mg.lattices[level + 1]);
        self.transfer(Kernel::ProlongAdd, level, (coarse, c), (fine, f));
    }

    fn coarse_solve(&self, b: &GpuVector, x: &mut GpuVector) {
        match &self.mg.coarsest {
            Coarsest::Dense { inverse, n } => {
                let prm = GatherParams {
                    n: *n,
                    ..Default::default()
                };
                let binds = [whole(inverse), whole(&b.buf), whole(&x.buf)];
                self.gather(Kernel::DenseMatvec, prm, &binds);
            }
            Coarsest::Host(factor, scratch) => {
                self.flush();
                let mut v = self.be.download(b);
                let mut mem = scratch.lock().unwrap_or_else(|e| e.into_inner());
                factor.solve_in_place_with(&mut v, &mut mem);
                let queue = &self.be.context().queue;
                queue.write_buffer(&x.buf, 0, &self.be.to_bytes(&v));
            }
        }
    }
}
