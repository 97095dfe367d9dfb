//! The CPU reference backend: vectors are `Vec<f64>` in host memory,
//! the operator is anything implementing [`LinearOperator`], and every kernel of
//! [`Backend`] is a small per-chunk function named like the WGSL kernel that will
//! mirror it (`axpy_kernel` ↔ `axpy` in the shader).
//!
//! # Chunking and reproducibility
//! Every kernel works on fixed chunks of `CHUNK` (8192) entries. Long vectors are
//! processed with rayon, one task per chunk; short ones sequentially, over the
//! same chunks. A dot product adds the rounded products `x_i y_i` exactly
//! ([`ExactSum`]) and rounds once: the result depends on the terms only,
//! never on the number of threads, the chunks or the order of the entries,
//! so it is bitwise the same run to run, on the sequential and the parallel
//! path, and on one rank or several ([`crate::distributed`] adds the
//! ranks' exact partial sums).

use std::ops::Range;

use rayon::prelude::*;

use super::Backend;
use crate::comm::Comm;
use crate::exact::ExactSum;

/// Entries per chunk (one rayon task; one partial sum of a dot product).
const CHUNK: usize = 8192;

/// Vectors at least this long are processed in parallel by default.
const DEFAULT_PARALLEL_MIN_LEN: usize = 4 * CHUNK;

/// Vectors at least this long are reduced (dot products) in parallel by
/// default.
const REDUCE_PARALLEL_MIN_LEN: usize = 2 * CHUNK;

/// A square linear operator on host vectors: what the CPU backend applies.
pub trait LinearOperator {
    /// Number of rows (= columns).
    fn nrows(&self) -> usize;
    /// `y = A x` (overwrites `y`).
    fn apply(&self, x: &[f64], y: &mut [f64]);
    /// The diagonal of `A`.
    fn diagonal(&self) -> Vec<f64>;
}

/// The CPU backend: host vectors, rayon-parallel kernels for long vectors.
#[derive(Clone, Debug)]
pub struct CpuBackend {
    parallel_min_len: usize,
}

impl Default for CpuBackend {
    fn default() -> Self {
        Self::new()
    }
}

impl CpuBackend {
    /// The backend with the default threshold for going parallel.
    pub fn new() -> Self {
        Self::with_parallel_min_len(DEFAULT_PARALLEL_MIN_LEN)
    }

    /// The backend that processes vectors of at least `parallel_min_len` entries
    /// in parallel (`0`: always, `usize::MAX`: never; dot products from
    /// [`REDUCE_PARALLEL_MIN_LEN`] if that is lower). Results do not depend on it.
    pub fn with_parallel_min_len(parallel_min_len: usize) -> Self {
        CpuBackend { parallel_min_len }
    }

    fn parallel(&self, n: usize) -> bool {
        n >= self.parallel_min_len
    }

    /// Runs `kernel(range, y_chunk)` over the chunks of `y`.
    fn map1<K>(&self, y: &mut [f64], kernel: K)
    where
        K: Fn(Range<usize>, &mut [f64]) + Sync,
    {
        let run = |(c, yc): (usize, &mut [f64])| kernel(span(c, yc.len()), yc);
        if self.parallel(y.len()) {
            y.par_chunks_mut(CHUNK).enumerate().for_each(run);
        } else {
            y.chunks_mut(CHUNK).enumerate().for_each(run);
        }
    }

    /// Runs `kernel(range, y_chunk, z_chunk)` over the chunks of `y` and `z`.
    fn map2<K>(&self, y: &mut [f64], z: &mut [f64], kernel: K)
    where
        K: Fn(Range<usize>, &mut [f64], &mut [f64]) + Sync,
    {
        assert_eq!(y.len(), z.len(), "cpu backend: length mismatch");
        let run =
            |(c, (yc, zc)): (usize, (&mut [f64], &mut [f64]))| kernel(span(c, yc.len()), yc, zc);
        if self.parallel(y.len()) {
            let zs = z.par_chunks_mut(CHUNK);
            y.par_chunks_mut(CHUNK).zip(zs).enumerate().for_each(run);
        } else {
            let zs = z.chunks_mut(CHUNK);
            y.chunks_mut(CHUNK).zip(zs).enumerate().for_each(run);
        }
    }

    /// `x · y` as the exact sum of the rounded products (what
    /// [`Backend::dot`] rounds).
    pub fn exact_dot(&self, x: &[f64], y: &[f64]) -> ExactSum {
        check_len("dot", x.len(), &[y.len()]);
        let kernel = |r: Range<usize>| dot_kernel(&x[r.clone()], &y[r]);
        self.reduce(x.len(), ExactSum::new(), kernel, merge)
    }

    /// `a · b` over the ranks of `comm`: this rank's exact partial sum,
    /// added exactly over the ranks and rounded once, so that the product
    /// does not depend on how the ranks split it. Collective.
    pub fn total_dot(&self, comm: &dyn Comm, a: &[f64], b: &[f64]) -> f64 {
        let mut s = [self.exact_dot(a, b)];
        comm.sum_exact(&mut s);
        s[0].value()
    }

    /// `(x · y, x · z)` as exact sums, in one pass over the chunks.
    pub fn exact_dot2(&self, x: &[f64], y: &[f64], z: &[f64]) -> (ExactSum, ExactSum) {
        check_len("dot2", x.len(), &[y.len(), z.len()]);
        let kernel = |r: Range<usize>| dot2_kernel(&x[r.clone()], &y[r.clone()], &z[r]);
        self.reduce(x.len(), (ExactSum::new(), ExactSum::new()), kernel, merge2)
    }

    /// Per-chunk partial results of `kernel(range)` over `0..n`, folded
    /// in chunk order with `combine`, starting from `zero`. Parallel from
    /// [`REDUCE_PARALLEL_MIN_LEN`] entries (or the backend's threshold, if
    /// lower): an exact product costs a few times a plain pass per entry,
    /// and sits between the parallel applies of a Krylov iteration.
    fn reduce<T, K>(&self, n: usize, zero: T, kernel: K, combine: fn(T, T) -> T) -> T
    where
        T: Send,
        K: Fn(Range<usize>) -> T + Sync,
    {
        let chunks = n.div_ceil(CHUNK);
        let range = |c: usize| span(c, CHUNK.min(n - c * CHUNK));
        let parallel = self.parallel_min_len != usize::MAX
            && n >= self.parallel_min_len.min(REDUCE_PARALLEL_MIN_LEN);
        let partials: Vec<T> = if parallel {
            (0..chunks)
                .into_par_iter()
                .map(|c| kernel(range(c)))
                .collect()
        } else {
            (0..chunks).map(|c| kernel(range(c))).collect()
        };
        partials.into_iter().fold(zero, combine)
    }
}

/// The index range of chunk `c` holding `len` entries.
fn span(c: usize, len: usize) -> Range<usize> {
    c * CHUNK..c * CHUNK + len
}

fn check_len(kernel: &str, n: usize, others: &[usize]) {
    for &m in others {
        assert_eq!(n, m, "cpu backend: {kernel}: vector lengths differ");
    }
}

fn merge(mut a: ExactSum, b: ExactSum) -> ExactSum {
    a.merge(&b);
    a
}

fn merge2(a: (ExactSum, ExactSum), b: (ExactSum, ExactSum)) -> (ExactSum, ExactSum) {
    (merge(a.0, b.0), merge(a.1, b.1))
}

// ---- Per-chunk kernels: the bodies the WGSL kernels mirror. ----

fn scale_kernel(a: f64, x: &mut [f64]) {
    x.iter_mut().for_each(|xi| *xi *= a);
}

fn axpy_kernel(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

fn xpay_kernel(x: &[f64], a: f64, y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi = xi + a * *yi;
    }
}

fn axpy2_kernel(a: f64, u: &[f64], b: f64, w: &[f64], y: &mut [f64]) {
    for ((yi, ui), wi) in y.iter_mut().zip(u).zip(w) {
        *yi += a * ui + b * wi;
    }
}

fn pointwise_mul_kernel(x: &[f64], y: &[f64], z: &mut [f64]) {
    for ((zi, xi), yi) in z.iter_mut().zip(x).zip(y) {
        *zi = xi * yi;
    }
}

fn dot_kernel(x: &[f64], y: &[f64]) -> ExactSum {
    ExactSum::dot(x, y)
}

fn dot2_kernel(x: &[f64], y: &[f64], z: &[f64]) -> (ExactSum, ExactSum) {
    (ExactSum::dot(x, y), ExactSum::dot(x, z))
}

fn cgs_update_up_kernel(beta: f64, r: &[f64], q: &[f64], u: &mut [f64], p: &mut [f64]) {
    for (((ui, pi), ri), qi) in u.iter_mut().zip(p.iter_mut()).zip(r).zip(q) {
        *ui = ri + beta * qi;
        *pi = *ui + beta * (qi + beta * *pi);
    }
}

fn cgs_update_qu_kernel(alpha: f64, v: &[f64], q: &mut [f64], u: &mut [f64]) {
    for ((qi, ui), vi) in q.iter_mut().zip(u.iter_mut()).zip(v) {
        *qi = *ui - alpha * vi;
        *ui += *qi;
    }
}

fn bicgstab_update_p_kernel(beta: f64, omega: f64, r: &[f64], v: &[f64], p: &mut [f64]) {
    for ((pi, ri), vi) in p.iter_mut().zip(r).zip(v) {
        *pi = ri + beta * (*pi - omega * vi);
    }
}

impl Backend for CpuBackend {
    type Vector = Vec<f64>;
    type Operator<'o> = dyn LinearOperator + 'o;

    fn name(&self) -> String {
        "cpu".to_string()
    }

    fn len(&self, v: &Vec<f64>) -> usize {
        v.len()
    }

    fn nrows(&self, op: &(dyn LinearOperator + '_)) -> usize {
        op.nrows()
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

    fn apply(&self, op: &(dyn LinearOperator + '_), x: &Vec<f64>, y: &mut Vec<f64>) {
        check_len("apply", op.nrows(), &[x.len(), y.len()]);
        op.apply(x, y);
    }

    fn diagonal(&self, op: &(dyn LinearOperator + '_)) -> Vec<f64> {
        let d = op.diagonal();
        check_len("diagonal", op.nrows(), &[d.len()]);
        d
    }

    fn copy(&self, src: &Vec<f64>, dst: &mut Vec<f64>) {
        check_len("copy", src.len(), &[dst.len()]);
        self.map1(dst, |r, d| d.copy_from_slice(&src[r]));
    }

    fn scale(&self, a: f64, x: &mut Vec<f64>) {
        self.map1(x, |_, xc| scale_kernel(a, xc));
    }

    fn axpy(&self, a: f64, x: &Vec<f64>, y: &mut Vec<f64>) {
        check_len("axpy", x.len(), &[y.len()]);
        self.map1(y, |r, yc| axpy_kernel(a, &x[r], yc));
    }

    fn xpay(&self, x: &Vec<f64>, a: f64, y: &mut Vec<f64>) {
        check_len("xpay", x.len(), &[y.len()]);
        self.map1(y, |r, yc| xpay_kernel(&x[r], a, yc));
    }

    fn axpy2(&self, a: f64, u: &Vec<f64>, b: f64, w: &Vec<f64>, y: &mut Vec<f64>) {
        check_len("axpy2", y.len(), &[u.len(), w.len()]);
        self.map1(y, |r, yc| axpy2_kernel(a, &u[r.clone()], b, &w[r], yc));
    }

    fn pointwise_mul(&self, x: &Vec<f64>, y: &Vec<f64>, z: &mut Vec<f64>) {
        check_len("pointwise_mul", z.len(), &[x.len(), y.len()]);
        self.map1(z, |r, zc| pointwise_mul_kernel(&x[r.clone()], &y[r], zc));
    }

    fn dot(&self, x: &Vec<f64>, y: &Vec<f64>) -> f64 {
        self.exact_dot(x, y).value()
    }

    fn dot2(&self, x: &Vec<f64>, y: &Vec<f64>, z: &Vec<f64>) -> (f64, f64) {
        let (xy, xz) = self.exact_dot2(x, y, z);
        (xy.value(), xz.value())
    }

    fn dot_sum(&self, x: &Vec<f64>, y: &Vec<f64>) -> ExactSum {
        self.exact_dot(x, y)
    }

    fn dot2_sums(&self, x: &Vec<f64>, y: &Vec<f64>, z: &Vec<f64>) -> (ExactSum, ExactSum) {
        self.exact_dot2(x, y, z)
    }

    fn read_entries(&self, v: &Vec<f64>, idx: &[usize]) -> Vec<f64> {
        idx.iter().map(|&i| v[i]).collect()
    }

    fn write_entries(&self, values: &[f64], idx: &[usize], v: &mut Vec<f64>) {
        for (&i, &x) in idx.iter().zip(values) {
            v[i] = x;
        }
    }

    fn cgs_update_up(
        &self,
        beta: f64,
        r: &Vec<f64>,
        q: &Vec<f64>,
        u: &mut Vec<f64>,
        p: &mut Vec<f64>,
    ) {
        check_len("cgs_update_up", r.len(), &[q.len(), u.len(), p.len()]);
        self.map2(u, p, |s, uc, pc| {
            cgs_update_up_kernel(beta, &r[s.clone()], &q[s], uc, pc)
        });
    }

    fn cgs_update_qu(&self, alpha: f64, v: &Vec<f64>, q: &mut Vec<f64>, u: &mut Vec<f64>) {
        check_len("cgs_update_qu", v.len(), &[q.len(), u.len()]);
        self.map2(q, u, |s, qc, uc| cgs_update_qu_kernel(alpha, &v[s], qc, uc));
    }

    fn bicgstab_update_p(
        &self,
        beta: f64,
        omega: f64,
        r: &Vec<f64>,
        v: &Vec<f64>,
        p: &mut Vec<f64>,
    ) {
        check_len("bicgstab_update_p", p.len(), &[r.len(), v.len()]);
        self.map1(p, |s, pc| {
            bicgstab_update_p_kernel(beta, omega, &r[s.clone()], &v[s], pc)
        });
    }
}
