//! Preconditioners as the Krylov cycles apply them: `z = M⁻¹ r` with `M = I`
//! (no work, `r` itself is used) or `M = diag(A)` (Jacobi: one
//! [`Backend::pointwise_mul`] with the inverted diagonal, set up once per solve).

use crate::backend::Backend;
use crate::error::Result;

use super::krylov::breakdown;
use super::{KrylovMethod, KrylovOptions, Preconditioner};

/// `M⁻¹` on the backend: `None` for the identity, else `D⁻¹` as a vector.
pub(crate) struct Precond<B: Backend> {
    inv_diag: Option<B::Vector>,
}

impl<B: Backend> Precond<B> {
    /// The preconditioner asked for in `opts`. For Jacobi, `diag` (or, when
    /// `None`, [`Backend::diagonal`] of `op`) is downloaded once, checked (finite
    /// and non-zero; positive for CG, which needs `M` SPD), inverted and uploaded.
    pub(crate) fn new(
        be: &B,
        op: &B::Operator<'_>,
        diag: Option<&B::Vector>,
        opts: &KrylovOptions,
    ) -> Result<Self> {
        if opts.preconditioner == Preconditioner::None {
            return Ok(Precond { inv_diag: None });
        }
        let d = match diag {
            Some(d) => be.download(d),
            None => be.download(&be.diagonal(op)),
        };
        assert_eq!(
            d.len(),
            be.nrows(op),
            "solve: diag must have the rows of the operator"
        );
        let spd = opts.method == KrylovMethod::Cg;
        if let Some((i, v)) = d
            .iter()
            .enumerate()
            .find(|&(_, &v)| !v.is_finite() || v == 0.0 || (spd && v < 0.0))
        {
            let what = format!("Jacobi preconditioner: diagonal entry {i} of A is {v:e}");
            return Err(breakdown(opts.method, 0, what));
        }
        let inv: Vec<f64> = d.iter().map(|v| 1.0 / v).collect();
        Ok(Precond {
            inv_diag: Some(be.upload(&inv)),
        })
    }

    /// `D⁻¹` for Jacobi, `None` for `M = I` (for kernels that fuse it).
    pub(crate) fn inverse_diagonal(&self) -> Option<&B::Vector> {
        self.inv_diag.as_ref()
    }

    /// Scratch space for [`Precond::apply`]: `n` entries, or none for `M = I`.
    pub fn scratch(&self, be: &B, n: usize) -> B::Vector {
        be.zeros(if self.inv_diag.is_some() { n } else { 0 })
    }

    /// `M⁻¹ r`: `r` itself for `M = I`, else written to `z` (from
    /// [`Precond::scratch`]) and returned.
    pub fn apply<'a>(&self, be: &B, r: &'a B::Vector, z: &'a mut B::Vector) -> &'a B::Vector {
        match &self.inv_diag {
            None => r,
            Some(inv) => {
                be.pointwise_mul(inv, r, z);
                z
            }
        }
    }
}
