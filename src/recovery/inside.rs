//! The moments of an inside cell's samples as one product with its nodal
//! values ([`InsideMoments`]), for the recoveries of the fixed-point loop
//! ([`super::moments`]).
//!
//! An inside cell's samples are the points of one rule, at the same place in
//! every inside cell, and a recovered field that is linear in the cell's
//! nodal values (the displacement, or the stress of the linear material)
//! takes there `v_{q,c} = Σ_k L_{q,c,k} u_k`, with the same `L` in every
//! inside cell. So are its moments about the cell's centre:
//! `m_{j,c} = Σ_q φ_j(ξ_q − ½) v_{q,c} = Σ_k M_{(j,c),k} u_k`, where
//! `M = Σ_q φ(ξ_q − ½) ⊗ L_q` is made once. A cell then costs one small
//! product with its gathered values instead of an evaluation per sample.

use super::Monomials;

/// `M` of one rule and one linear map to the samples (module doc): the
/// moments of `NC` components about an inside cell's centre from its
/// `cols` nodal values.
#[derive(Clone, Debug)]
pub struct InsideMoments {
    degree: usize,
    cols: usize,
    /// Row `j·NC + c`, `cols` entries each.
    m: Vec<f64>,
}

impl InsideMoments {
    /// `M` for the basis of `degree`, the rule's points `xi` (reference
    /// coordinates in `[0, 1]³`) and, per point `q`, the map `map(q, c, k)
    /// = L_{q,c,k}` from the `cols` nodal values to component `c` of the
    /// `nc` components.
    pub fn new(
        degree: usize,
        xi: &[[f64; 3]],
        nc: usize,
        cols: usize,
        map: impl Fn(usize, usize, usize) -> f64,
    ) -> InsideMoments {
        let basis = Monomials::new(degree);
        let nb = basis.len();
        let mut m = vec![0.0; nb * nc * cols];
        let mut phi = vec![0.0; nb];
        for (q, x) in xi.iter().enumerate() {
            basis.values(x.map(|v| v - 0.5), &mut phi);
            for (j, p) in phi.iter().enumerate() {
                for c in 0..nc {
                    let row = &mut m[(j * nc + c) * cols..(j * nc + c + 1) * cols];
                    for (k, r) in row.iter_mut().enumerate() {
                        *r += p * map(q, c, k);
                    }
                }
            }
        }
        InsideMoments { degree, cols, m }
    }

    /// The moments `out[j·NC + c]` of a cell with nodal values `u`
    /// (`cols` of them), for a recovery of `basis`; `false` (nothing
    /// written) when `basis` is not the degree `M` was made for.
    pub fn moments(&self, basis: &Monomials, u: &[f64], out: &mut [f64]) -> bool {
        if basis.degree() != self.degree {
            return false;
        }
        debug_assert_eq!(u.len(), self.cols, "nodal values of a cell");
        for (o, row) in out.iter_mut().zip(self.m.chunks_exact(self.cols)) {
            *o = row.iter().zip(u).map(|(a, b)| a * b).sum();
        }
        true
    }
}
