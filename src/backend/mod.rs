//! Compute backends: the [`Backend`] trait that the Krylov methods of
//! [`crate::solver`] are written against once, and the CPU reference backend.
//!
//! A backend owns where vectors live and how the few kernels of a Krylov solve run
//! over them: allocation, upload/download, the operator apply `y = A x`, vector
//! updates and dot products. Each kernel is a small named primitive so that a WGSL
//! kernel of the same name (and the same argument/binding order: scalars first,
//! then the read-only vectors, then the written ones) can mirror it on the GPU.
//!
//! # Where a GPU backend will differ
//! - **Residency.** [`Backend::Vector`] is a device buffer; no method hands out a
//!   `&[f64]` of it except the explicit [`Backend::upload`]/[`Backend::download`].
//! - **Reductions.** [`Backend::dot`] and [`Backend::dot2`] are reduced on the
//!   device (workgroup partial sums, then one more pass over the partials), with a
//!   fixed reduction tree so that results are reproducible run to run, like the
//!   chunked reduction of the CPU backend.
//! - **Scalars.** Here the reductions return `f64` to the host and the update
//!   kernels take `f64` arguments, which costs one read-back per dot product. The
//!   GPU backend will keep ρ, σ, α, β, ω in a small device buffer (computed by a
//!   one-thread kernel from the reduced dot products) and read the residual norm
//!   back only every few iterations; its update kernels then read their scalars
//!   from that buffer instead of taking them as arguments. The algorithms of
//!   [`crate::solver`] are written so that every scalar is a function of the dot
//!   products of the same iteration, which is what that needs.

mod cpu;
#[cfg(test)]
mod tests;

pub use cpu::{CpuBackend, LinearOperator};

use crate::exact::ExactSum;

/// The primitives of a Krylov solve on some device.
///
/// Vectors are passed by reference; every method that writes names its output
/// last and takes it `&mut`. All vectors of one call have the same length
/// (implementations panic otherwise).
pub trait Backend {
    /// A vector of `f64` resident on the backend's device.
    type Vector;
    /// The linear operator `A` as the backend applies it; `'o` lets it borrow
    /// (the grid, the cut-cell data) for as long as the solve runs.
    type Operator<'o>: ?Sized;

    /// Short name for reports (`"cpu"`, `"gpu:<adapter>"`).
    fn name(&self) -> String;
    /// Number of entries of `v`.
    fn len(&self, v: &Self::Vector) -> usize;
    /// Number of rows (= columns) of `op`.
    fn nrows(&self, op: &Self::Operator<'_>) -> usize;

    /// A new vector of `n` zeros.
    fn zeros(&self, n: usize) -> Self::Vector;
    /// A new device vector holding `data`.
    fn upload(&self, data: &[f64]) -> Self::Vector;
    /// The entries of `v`, copied to the host.
    fn download(&self, v: &Self::Vector) -> Vec<f64>;

    /// `y = A x`.
    fn apply(&self, op: &Self::Operator<'_>, x: &Self::Vector, y: &mut Self::Vector);
    /// The diagonal of `A` as a new vector (for the Jacobi preconditioner).
    fn diagonal(&self, op: &Self::Operator<'_>) -> Self::Vector;

    /// `dst = src`.
    fn copy(&self, src: &Self::Vector, dst: &mut Self::Vector);
    /// `x = a x`.
    fn scale(&self, a: f64, x: &mut Self::Vector);
    /// `y = y + a x`.
    fn axpy(&self, a: f64, x: &Self::Vector, y: &mut Self::Vector);
    /// `y = x + a y`.
    fn xpay(&self, x: &Self::Vector, a: f64, y: &mut Self::Vector);
    /// `y = y + a u + b w` (fused two-term update, one pass over `y`).
    fn axpy2(&self, a: f64, u: &Self::Vector, b: f64, w: &Self::Vector, y: &mut Self::Vector);
    /// `z = x ∘ y`, entry by entry (the Jacobi preconditioner with `x = D⁻¹`).
    fn pointwise_mul(&self, x: &Self::Vector, y: &Self::Vector, z: &mut Self::Vector);

    /// `x · y`, reduced in a fixed order (bitwise reproducible).
    fn dot(&self, x: &Self::Vector, y: &Self::Vector) -> f64;
    /// `(x · y, x · z)` in one pass over `x`, each reduced like [`Backend::dot`].
    fn dot2(&self, x: &Self::Vector, y: &Self::Vector, z: &Self::Vector) -> (f64, f64);

    /// `x · y` as an exact sum, to be added with other ranks' parts
    /// ([`ExactSum::merge`]): the exact sum of the rounded products where
    /// the backend has it, else its rounded product.
    fn dot_sum(&self, x: &Self::Vector, y: &Self::Vector) -> ExactSum {
        ExactSum::of([self.dot(x, y)])
    }
    /// `(x · y, x · z)` as [`Backend::dot_sum`] gives each.
    fn dot2_sums(
        &self,
        x: &Self::Vector,
        y: &Self::Vector,
        z: &Self::Vector,
    ) -> (ExactSum, ExactSum) {
        let (a, b) = self.dot2(x, y, z);
        (ExactSum::of([a]), ExactSum::of([b]))
    }

    /// `v[idx[k]]` for every `k`, copied to the host (the entries a rank
    /// sends its neighbours). By default through the whole vector.
    fn read_entries(&self, v: &Self::Vector, idx: &[usize]) -> Vec<f64> {
        let host = self.download(v);
        idx.iter().map(|&i| host[i]).collect()
    }
    /// `v[idx[k]] = values[k]` for every `k` (the ghosts a rank receives).
    /// By default through the whole vector.
    fn write_entries(&self, values: &[f64], idx: &[usize], v: &mut Self::Vector) {
        let mut host = self.download(v);
        for (&i, &x) in idx.iter().zip(values) {
            host[i] = x;
        }
        *v = self.upload(&host);
    }

    /// CGS direction update, fused:
    /// `u = r + β q`, then `p = u + β (q + β p)`.
    fn cgs_update_up(
        &self,
        beta: f64,
        r: &Self::Vector,
        q: &Self::Vector,
        u: &mut Self::Vector,
        p: &mut Self::Vector,
    );
    /// CGS half-step update, fused: `q = u − α v`, then `u = u + q`.
    fn cgs_update_qu(
        &self,
        alpha: f64,
        v: &Self::Vector,
        q: &mut Self::Vector,
        u: &mut Self::Vector,
    );
    /// BiCGStab direction update: `p = r + β (p − ω v)`.
    fn bicgstab_update_p(
        &self,
        beta: f64,
        omega: f64,
        r: &Self::Vector,
        v: &Self::Vector,
        p: &mut Self::Vector,
    );
}
