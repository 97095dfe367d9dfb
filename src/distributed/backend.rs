//! [`DistBackend`]: the [`Backend`] of one rank, over the rank's own
//! backend (the CPU's, or its GPU's). Its vectors are the rank's unknowns
//! with the ghosts' entries kept at zero, so a local dot product counts
//! every owned unknown once and the exact sum of the ranks' parts is the
//! whole product (on the CPU, to the bit the one-rank product); the apply
//! brings the ghosts of its input from their owners
//! ([`Backend::read_entries`], [`Backend::write_entries`]), applies the
//! rank's operator and zeroes the ghost rows again. Every other kernel is
//! the rank's backend's, on the local entries, so the Krylov methods of
//! [`crate::solver`] run unchanged on P ranks.

use std::cell::RefCell;

use super::halo::{Halo, Reach};
use crate::backend::{Backend, CpuBackend};
use crate::comm::Comm;

/// A rank's operator: its set-up's operator over its window, as its
/// backend applies it, and its halo.
pub struct DistOperator<'o, B: Backend + 'static = CpuBackend> {
    local: &'o B::Operator<'o>,
    halo: &'o Halo,
    /// The input with its ghosts filled in.
    filled: RefCell<B::Vector>,
}

impl<'o, B: Backend + 'static> DistOperator<'o, B> {
    pub fn new(be: &DistBackend<'_, B>, local: &'o B::Operator<'o>, halo: &'o Halo) -> Self {
        DistOperator {
            local,
            halo,
            filled: RefCell::new(be.inner.zeros(be.inner.nrows(local))),
        }
    }
}

/// The backend of one rank of a distributed solve: the rank's own backend
/// (the CPU's, or its GPU's) with the ghost exchange around the apply and
/// the dot products summed over the ranks.
pub struct DistBackend<'c, B: Backend = CpuBackend> {
    inner: B,
    comm: &'c dyn Comm,
}

impl<'c> DistBackend<'c, CpuBackend> {
    /// The CPU backend on the ranks of `comm`.
    pub fn new(comm: &'c dyn Comm) -> Self {
        DistBackend::on(CpuBackend::new(), comm)
    }

    /// `a · b` over the ranks for host vectors ([`CpuBackend::total_dot`]).
    /// Collective.
    pub fn total_dot(&self, a: &[f64], b: &[f64]) -> f64 {
        self.inner.total_dot(self.comm, a, b)
    }
}

impl<'c, B: Backend> DistBackend<'c, B> {
    /// `inner` on the ranks of `comm`.
    pub fn on(inner: B, comm: &'c dyn Comm) -> Self {
        DistBackend { inner, comm }
    }

    /// The ranks' messages.
    pub fn comm(&self) -> &'c dyn Comm {
        self.comm
    }

    /// The rank's own backend.
    pub fn inner(&self) -> &B {
        &self.inner
    }
}

impl<B: Backend + 'static> Backend for DistBackend<'_, B> {
    type Vector = B::Vector;
    type Operator<'o> = DistOperator<'o, B>;

    fn name(&self) -> String {
        format!("{}×{}", self.inner.name(), self.comm.size())
    }

    fn len(&self, v: &B::Vector) -> usize {
        self.inner.len(v)
    }

    fn nrows(&self, op: &DistOperator<'_, B>) -> usize {
        self.inner.nrows(op.local)
    }

    fn zeros(&self, n: usize) -> B::Vector {
        self.inner.zeros(n)
    }

    fn upload(&self, data: &[f64]) -> B::Vector {
        self.inner.upload(data)
    }

    fn download(&self, v: &B::Vector) -> Vec<f64> {
        self.inner.download(v)
    }

    /// `y = A x`: the ghosts of `x` from their owners, the rank's rows, the
    /// ghost rows zeroed. Collective.
    fn apply(&self, op: &DistOperator<'_, B>, x: &B::Vector, y: &mut B::Vector) {
        let mut filled = op.filled.borrow_mut();
        self.inner.copy(x, &mut filled);
        op.halo
            .fill_ghosts_on(self.comm, &self.inner, &mut filled, Reach::Near);
        self.inner.apply(op.local, &filled, y);
        op.halo.zero_ghosts_on(&self.inner, y);
    }

    /// The owned rows' diagonal; 1 at the ghosts (whose residual entries
    /// stay zero, so the Jacobi step keeps them zero).
    fn diagonal(&self, op: &DistOperator<'_, B>) -> B::Vector {
        let mut d = self.inner.download(&self.inner.diagonal(op.local));
        for (a, node) in d.chunks_exact_mut(3).enumerate() {
            if !op.halo.owns(a) {
                node.fill(1.0);
            }
        }
        self.inner.upload(&d)
    }

    fn copy(&self, src: &B::Vector, dst: &mut B::Vector) {
        self.inner.copy(src, dst)
    }

    fn scale(&self, a: f64, x: &mut B::Vector) {
        self.inner.scale(a, x)
    }

    fn axpy(&self, a: f64, x: &B::Vector, y: &mut B::Vector) {
        self.inner.axpy(a, x, y)
    }

    fn xpay(&self, x: &B::Vector, a: f64, y: &mut B::Vector) {
        self.inner.xpay(x, a, y)
    }

    fn axpy2(&self, a: f64, u: &B::Vector, b: f64, w: &B::Vector, y: &mut B::Vector) {
        self.inner.axpy2(a, u, b, w, y)
    }

    fn pointwise_mul(&self, x: &B::Vector, y: &B::Vector, z: &mut B::Vector) {
        self.inner.pointwise_mul(x, y, z)
    }

    /// The rank's part ([`Backend::dot_sum`]) added exactly over the
    /// ranks and rounded once. Collective.
    fn dot(&self, x: &B::Vector, y: &B::Vector) -> f64 {
        let mut s = [self.inner.dot_sum(x, y)];
        self.comm.sum_exact(&mut s);
        s[0].value()
    }

    /// Both products added over the ranks in one reduction. Collective.
    fn dot2(&self, x: &B::Vector, y: &B::Vector, z: &B::Vector) -> (f64, f64) {
        let (a, b) = self.inner.dot2_sums(x, y, z);
        let mut s = [a, b];
        self.comm.sum_exact(&mut s);
        (s[0].value(), s[1].value())
    }

    fn cgs_update_up(
        &self,
        beta: f64,
        r: &B::Vector,
        q: &B::Vector,
        u: &mut B::Vector,
        p: &mut B::Vector,
    ) {
        self.inner.cgs_update_up(beta, r, q, u, p)
    }

    fn cgs_update_qu(&self, alpha: f64, v: &B::Vector, q: &mut B::Vector, u: &mut B::Vector) {
        self.inner.cgs_update_qu(alpha, v, q, u)
    }

    fn bicgstab_update_p(
        &self,
        beta: f64,
        omega: f64,
        r: &B::Vector,
        v: &B::Vector,
        p: &mut B::Vector,
    ) {
        self.inner.bicgstab_update_p(beta, omega, r, v, p)
    }
}
