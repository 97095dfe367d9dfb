//! [`DistBackend`]: the [`Backend`] of one rank. Its vectors are the
//! rank's unknowns with the ghosts' entries kept at zero, so a local dot
//! product counts every owned unknown once and the exact sum over the ranks
//! is the whole product, to the bit the one-rank product; the apply brings the ghosts of its input from their
//! owners, applies the rank's operator and zeroes the ghost rows again.
//! Every other kernel is the CPU backend's, on the local entries, so the
//! Krylov methods of [`crate::solver`] run unchanged on P ranks.

use std::cell::RefCell;

use super::halo::{Halo, Reach};
use crate::backend::{Backend, CpuBackend, LinearOperator};
use crate::comm::Comm;

/// A rank's operator: its set-up's operator over its window and its halo.
pub struct DistOperator<'o> {
    local: &'o dyn LinearOperator,
    halo: &'o Halo,
    /// The input with its ghosts filled in.
    filled: RefCell<Vec<f64>>,
}

impl<'o> DistOperator<'o> {
    pub fn new(local: &'o dyn LinearOperator, halo: &'o Halo) -> Self {
        DistOperator {
            local,
            halo,
            filled: RefCell::new(vec![0.0; local.nrows()]),
        }
    }
}

/// The backend of one rank of a distributed solve.
pub struct DistBackend<'c> {
    cpu: CpuBackend,
    comm: &'c dyn Comm,
}

impl<'c> DistBackend<'c> {
    pub fn new(comm: &'c dyn Comm) -> Self {
        DistBackend {
            cpu: CpuBackend::new(),
            comm,
        }
    }

    /// The ranks' messages.
    pub fn comm(&self) -> &'c dyn Comm {
        self.comm
    }

    /// `a · b` over the ranks: each rank's exact partial sum, added
    /// exactly over the ranks and rounded once, so that the product does
    /// not depend on the rank count. Collective.
    pub fn total_dot(&self, a: &[f64], b: &[f64]) -> f64 {
        let mut s = [self.cpu.exact_dot(a, b)];
        self.comm.sum_exact(&mut s);
        s[0].value()
    }
}

impl Backend for DistBackend<'_> {
    type Vector = Vec<f64>;
    type Operator<'o> = DistOperator<'o>;

    fn name(&self) -> String {
        format!("cpu×{}", self.comm.size())
    }

    fn len(&self, v: &Vec<f64>) -> usize {
        v.len()
    }

    fn nrows(&self, op: &DistOperator<'_>) -> usize {
        op.local.nrows()
    }

    fn zeros(&self, n: usize) -> Vec<f64> {
        vec![0.0; n]
    }

    fn upload(&self, data: &[f64]) -> Vec<f64> {
        data.to_vec()
    }

    fn download(&self, v: &Vec<f64>) -> Vec<f64> {
        v.clone()
    }

    /// `y = A x`: the ghosts of `x` from their owners, the rank's rows, the
    /// ghost rows zeroed. Collective.
    fn apply(&self, op: &DistOperator<'_>, x: &Vec<f64>, y: &mut Vec<f64>) {
        let mut filled = op.filled.borrow_mut();
        filled.copy_from_slice(x);
        op.halo.fill_ghosts(self.comm, &mut filled, Reach::Near);
        op.local.apply(&filled, y);
        op.halo.zero_ghosts(y);
    }

    /// The owned rows' diagonal; 1 at the ghosts (whose residual entries
    /// stay zero, so the Jacobi step keeps them zero).
    fn diagonal(&self, op: &DistOperator<'_>) -> Vec<f64> {
        let mut d = op.local.diagonal();
        for (a, node) in d.chunks_exact_mut(3).enumerate() {
            if !op.halo.owns(a) {
                node.fill(1.0);
            }
        }
        d
    }

    fn copy(&self, src: &Vec<f64>, dst: &mut Vec<f64>) {
        self.cpu.copy(src, dst)
    }

    fn scale(&self, a: f64, x: &mut Vec<f64>) {
        self.cpu.scale(a, x)
    }

    fn axpy(&self, a: f64, x: &Vec<f64>, y: &mut Vec<f64>) {
        self.cpu.axpy(a, x, y)
    }

    fn xpay(&self, x: &Vec<f64>, a: f64, y: &mut Vec<f64>) {
        self.cpu.xpay(x, a, y)
    }

    fn axpy2(&self, a: f64, u: &Vec<f64>, b: f64, w: &Vec<f64>, y: &mut Vec<f64>) {
        self.cpu.axpy2(a, u, b, w, y)
    }

    fn pointwise_mul(&self, x: &Vec<f64>, y: &Vec<f64>, z: &mut Vec<f64>) {
        self.cpu.pointwise_mul(x, y, z)
    }

    /// [`DistBackend::total_dot`]. Collective.
    fn dot(&self, x: &Vec<f64>, y: &Vec<f64>) -> f64 {
        self.total_dot(x, y)
    }

    /// Both products added over the ranks in one gather. Collective.
    fn dot2(&self, x: &Vec<f64>, y: &Vec<f64>, z: &Vec<f64>) -> (f64, f64) {
        let (a, b) = self.cpu.exact_dot2(x, y, z);
        let mut s = [a, b];
        self.comm.sum_exact(&mut s);
        (s[0].value(), s[1].value())
    }

    fn cgs_update_up(
        &self,
        beta: f64,
        r: &Vec<f64>,
        q: &Vec<f64>,
        u: &mut Vec<f64>,
        p: &mut Vec<f64>,
    ) {
        self.cpu.cgs_update_up(beta, r, q, u, p)
    }

    fn cgs_update_qu(&self, alpha: f64, v: &Vec<f64>, q: &mut Vec<f64>, u: &mut Vec<f64>) {
        self.cpu.cgs_update_qu(alpha, v, q, u)
    }

    fn bicgstab_update_p(
        &self,
        beta: f64,
        omega: f64,
        r: &Vec<f64>,
        v: &Vec<f64>,
        p: &mut Vec<f64>,
    ) {
        self.cpu.bicgstab_update_p(beta, omega, r, v, p)
    }
}
