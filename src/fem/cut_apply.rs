//! The cut cells' part of the apply, `z_c = K_c x_c` for every cut cell `c`,
//! from the moment-fitted weights ([`super::moment_fit`]):
//!
//! ```text
//! K_c x_c = Σ_q W_q B_qᵀ D B_q x_c + Σ_q M_q N_qᵀ N_q x_c,
//! ```
//! at the `n³ = (2p+1)³` fitting points. Per cell: the displacement gradient
//! `G = ∇u` and the value `u` at every point, the weighted stress
//! `τ_q = W_q σ(G_q) = W_q (λ tr G I + μ (G + Gᵀ))` and mass term `M_q u_q`,
//! and the test functions' side `z_{a,i} = Σ_q ∇N_a(ξ_q)·τ_q[i,:] + N_a(ξ_q) M_q u_{q,i}`.
//!
//! # Sum factorisation
//! `N_{abc}(ξ) = φ_a(ξ_x) φ_b(ξ_y) φ_c(ξ_z)`, so with the 1D matrices
//! `I[q][a] = φ_a(t_q)` and `D[q][a] = φ_a'(t_q)` (`n × (p+1)`), the values
//! at the points are `(I ⊗ I ⊗ I) u`, the x-derivatives `(I ⊗ I ⊗ D) u`
//! (z ⊗ y ⊗ x), and so on: three passes of 1D products, one axis at a time,
//! sharing the partial results (`x`: `I u`, `D u`; `y`: `I I u`, `D I u`,
//! `I D u`; `z`: the four outputs). The test side is the transpose, again
//! one axis at a time, the four inputs folded into two after `z` and one
//! after `x`.
//!
//! The same kernel at the `p + 1` Gauss points per axis with the weights of
//! the whole cell ([`CutKernel::gauss`], [`Uniform`]) multiplies inside cells
//! by `h K_ref`: the fast apply's cells next to the boundary
//! ([`super::fast_apply`]).
//!
//! # Batches
//! [`LANES`] cells are processed together, one per SIMD lane: every
//! operation above is then a vector operation with no shuffles. Where the CPU
//! has AVX2 and FMA the kernel is compiled for them.

use rayon::prelude::*;

use super::moment_fit::{lagrange, lagrange_derivative, CutWeights, FitBasis};
use super::stencil::madd;
use crate::element::ElementOrder;
use crate::quadrature::gauss::gauss_legendre_unit;

/// Cells per batch (SIMD lanes).
pub const LANES: usize = 4;
/// Batches per rayon task.
const BATCHES_PER_TASK: usize = 16;

type V = [f64; LANES];

/// Where the kernel reads a cell's stiffness and mass weights.
pub trait CellWeights: Sync {
    /// The stiffness and mass weights of cell `s`.
    fn cell(&self, s: usize) -> (&[f64], &[f64]);
}

impl CellWeights for CutWeights {
    fn cell(&self, s: usize) -> (&[f64], &[f64]) {
        CutWeights::cell(self, s)
    }
}

/// The weights of the first cell of a [`CutWeights`], for every cell.
pub struct Uniform<'a>(pub &'a CutWeights);

impl CellWeights for Uniform<'_> {
    fn cell(&self, _: usize) -> (&[f64], &[f64]) {
        self.0.cell(0)
    }
}

/// The constants of the cut-cell kernel.
#[derive(Clone, Debug)]
pub struct CutKernel {
    order: ElementOrder,
    /// Points per axis.
    q: usize,
    /// `φ_a(t_q)` and `φ_a'(t_q)`, `[q][a]` (sized for Q2).
    interp: [[f64; 3]; 5],
    deriv: [[f64; 3]; 5],
    lambda: f64,
    mu: f64,
    inv_h: f64,
    fma: bool,
}

impl CutKernel {
    /// The kernel of `basis` for Lamé parameters `(λ, μ)` and cell size `h`.
    pub fn new(basis: &FitBasis, lame: (f64, f64), h: f64) -> CutKernel {
        CutKernel::at_points(basis.order, &basis.points, lame, h)
    }

    /// The Q2 kernel at the 3 Gauss points per axis, and the weights that
    /// make it multiply a cell by the inside-cell matrix `h K_ref` (read
    /// through [`Uniform`]).
    pub fn gauss(lame: (f64, f64), h: f64) -> (CutKernel, CutWeights) {
        let (points, w) = gauss_legendre_unit(3);
        let mut data = vec![0.0; 2 * 27];
        for (q, v) in data[..27].iter_mut().enumerate() {
            *v = h * h * h * w[q % 3] * w[(q / 3) % 3] * w[q / 9];
        }
        let kernel = CutKernel::at_points(ElementOrder::Q2, &points, lame, h);
        (kernel, CutWeights { nq: 27, data })
    }

    /// The kernel of `order` at the 1D points `points` (3 or 5 for Q2, 3
    /// for Q1).
    fn at_points(
        order: ElementOrder,
        points: &[f64],
        (lambda, mu): (f64, f64),
        h: f64,
    ) -> CutKernel {
        let p = order.degree();
        let nodes: Vec<f64> = (0..=p).map(|a| a as f64 / p as f64).collect();
        let mut interp = [[0.0; 3]; 5];
        let mut deriv = [[0.0; 3]; 5];
        for (q, &t) in points.iter().enumerate() {
            interp[q][..=p].copy_from_slice(&lagrange(&nodes, t)[..=p]);
            deriv[q][..=p].copy_from_slice(&lagrange_derivative(&nodes, t)[..=p]);
        }
        CutKernel {
            order,
            q: points.len(),
            interp,
            deriv,
            lambda,
            mu,
            inv_h: 1.0 / h,
            fma: super::fast_apply::fma_available(),
        }
    }

    /// `z[ne s .. ne (s+1)] = K_s x_s` for every cut cell `s` of `w`, with
    /// `gather(s, xe)` filling the cell's `ne` dofs (node-major) from `x`.
    pub fn apply<W, G>(&self, w: &W, gather: G, z: &mut [f64])
    where
        W: CellWeights,
        G: Fn(usize, &mut [f64]) + Sync,
    {
        let ne = 3 * self.order.nodes_per_cell();
        let per_task = LANES * BATCHES_PER_TASK;
        z.par_chunks_mut(ne * per_task)
            .enumerate()
            .for_each(|(t, zt)| {
                #[cfg(target_arch = "x86_64")]
                if self.fma {
                    // SAFETY: `fma` is set only when the CPU reports AVX2 and FMA.
                    unsafe { self.task_fma(w, &gather, t * per_task, zt) };
                    return;
                }
                self.task::<false, W, G>(w, &gather, t * per_task, zt);
            });
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn task_fma<W: CellWeights, G: Fn(usize, &mut [f64])>(
        &self,
        w: &W,
        g: &G,
        first: usize,
        z: &mut [f64],
    ) {
        self.task::<true, W, G>(w, g, first, z);
    }

    /// The batches of one task: cells `first ..`, `z` their products.
    #[inline(always)]
    fn task<const FMA: bool, W: CellWeights, G: Fn(usize, &mut [f64])>(
        &self,
        w: &W,
        gather: &G,
        first: usize,
        z: &mut [f64],
    ) {
        match self.order {
            ElementOrder::Q1 => {
                for (b, zb) in z.chunks_mut(24 * LANES).enumerate() {
                    let s0 = first + b * LANES;
                    self.batch::<FMA, 2, 3, 8, 27, 12, 18, 24>(w, gather, s0, zb);
                }
            }
            ElementOrder::Q2 if self.q == 3 => {
                for (b, zb) in z.chunks_mut(81 * LANES).enumerate() {
                    let s0 = first + b * LANES;
                    self.batch::<FMA, 3, 3, 27, 27, 27, 27, 81>(w, gather, s0, zb);
                }
            }
            ElementOrder::Q2 => {
                for (b, zb) in z.chunks_mut(81 * LANES).enumerate() {
                    let s0 = first + b * LANES;
                    self.batch::<FMA, 3, 5, 27, 125, 45, 75, 81>(w, gather, s0, zb);
                }
            }
        }
    }

    /// One batch: cells `s0 .. s0 + LANES` (fewer at the end: `z` holds `NE`
    /// entries per cell present). `P` nodes and `Q` points per axis;
    /// `NP = P³`, `NQ = Q³`, `PPQ = P²Q`, `PQQ = PQ²`, `NE = 3 P³`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn batch<
        const FMA: bool,
        const P: usize,
        const Q: usize,
        const NP: usize,
        const NQ: usize,
        const PPQ: usize,
        const PQQ: usize,
        const NE: usize,
    >(
        &self,
        w: &impl CellWeights,
        gather: &impl Fn(usize, &mut [f64]),
        s0: usize,
        z: &mut [f64],
    ) {
        let cells = z.len() / NE;
        let mut u = [[[0.0; LANES]; NP]; 3];
        let mut wk = [[0.0; LANES]; NQ];
        let mut wm = [[0.0; LANES]; NQ];
        let mut xe = [0.0; NE];
        for l in 0..cells {
            gather(s0 + l, &mut xe);
            for a in 0..NP {
                for j in 0..3 {
                    u[j][a][l] = xe[3 * a + j];
                }
            }
            let (ws, ms) = w.cell(s0 + l);
            for q in 0..NQ {
                wk[q][l] = ws[q];
                wm[q][l] = ms[q];
            }
        }
        let (im, dm) = self.matrices::<P, Q>();
        // g[j][d][q]: ∂u_j/∂ξ_d, then the weighted stress; val[j][q]: u_j, then M_q u_j.
        let mut g = [[[[0.0; LANES]; NQ]; 3]; 3];
        let mut val = [[[0.0; LANES]; NQ]; 3];
        for j in 0..3 {
            forward::<FMA, P, Q, NP, NQ, PPQ, PQQ>(&im, &dm, &u[j], &mut g[j], &mut val[j]);
        }
        self.stress::<NQ>(&wk, &wm, &mut g, &mut val);
        let mut f = [[0.0; LANES]; NP];
        for i in 0..3 {
            backward::<FMA, P, Q, NP, NQ, PPQ, PQQ>(&im, &dm, &g[i], &val[i], &mut f);
            for (l, zl) in z.chunks_exact_mut(NE).enumerate() {
                for a in 0..NP {
                    zl[3 * a + i] = f[a][l];
                }
            }
        }
    }

    /// The 1D matrices `I`, `D` as `[q][a]` arrays of the batch's size.
    #[inline(always)]
    fn matrices<const P: usize, const Q: usize>(&self) -> ([[f64; P]; Q], [[f64; P]; Q]) {
        let pick = |m: &[[f64; 3]; 5]| std::array::from_fn(|q| std::array::from_fn(|a| m[q][a]));
        (pick(&self.interp), pick(&self.deriv))
    }

    /// At every point: `g[i][d] ← W_q h⁻² σ(g)[i][d]`, `val[j] ← M_q val[j]`
    /// (`h⁻²`: one `h⁻¹` for the gradient, one for the test gradient).
    #[inline(always)]
    fn stress<const NQ: usize>(
        &self,
        wk: &[V; NQ],
        wm: &[V; NQ],
        g: &mut [[[V; NQ]; 3]; 3],
        val: &mut [[V; NQ]; 3],
    ) {
        let (lambda, mu, s) = (self.lambda, self.mu, self.inv_h * self.inv_h);
        for q in 0..NQ {
            for l in 0..LANES {
                let w = wk[q][l] * s;
                let div = g[0][0][q][l] + g[1][1][q][l] + g[2][2][q][l];
                let pressure = lambda * div;
                let sym = |i: usize, d: usize| mu * (g[i][d][q][l] + g[d][i][q][l]);
                let (s01, s02, s12) = (sym(0, 1), sym(0, 2), sym(1, 2));
                let (s00, s11, s22) = (sym(0, 0), sym(1, 1), sym(2, 2));
                g[0][0][q][l] = w * (pressure + s00);
                g[1][1][q][l] = w * (pressure + s11);
                g[2][2][q][l] = w * (pressure + s22);
                g[0][1][q][l] = w * s01;
                g[1][0][q][l] = w * s01;
                g[0][2][q][l] = w * s02;
                g[2][0][q][l] = w * s02;
                g[1][2][q][l] = w * s12;
                g[2][1][q][l] = w * s12;
                for v in val.iter_mut() {
                    v[q][l] *= wm[q][l];
                }
            }
        }
    }
}

/// `Σ_a m[r][a] x[a]` on lanes, for the 1D product of one row `r`.
#[inline(always)]
fn dot<const FMA: bool>(acc: &mut V, c: f64, x: &V) {
    for l in 0..LANES {
        acc[l] = madd::<FMA>(c, x[l], acc[l]);
    }
}

/// Values and reference gradients of one component at the points, from its
/// nodal values `u` (index `a + P (b + P c)`); points `x + Q (y + Q z)`.
#[inline(always)]
fn forward<
    const FMA: bool,
    const P: usize,
    const Q: usize,
    const NP: usize,
    const NQ: usize,
    const PPQ: usize,
    const PQQ: usize,
>(
    im: &[[f64; P]; Q],
    dm: &[[f64; P]; Q],
    u: &[V; NP],
    g: &mut [[V; NQ]; 3],
    val: &mut [V; NQ],
) {
    // x: (I u), (D u), index qx + Q (b + P c).
    let (mut vx, mut dx) = ([[0.0; LANES]; PPQ], [[0.0; LANES]; PPQ]);
    for cb in 0..P * P {
        for qx in 0..Q {
            let (v, d) = (&mut vx[cb * Q + qx], &mut dx[cb * Q + qx]);
            for a in 0..P {
                dot::<FMA>(v, im[qx][a], &u[cb * P + a]);
                dot::<FMA>(d, dm[qx][a], &u[cb * P + a]);
            }
        }
    }
    // y: (I I u), (D I u) [∂y], (I D u) [∂x], index qx + Q (qy + Q c).
    let (mut vv, mut vd, mut dv) = (
        [[0.0; LANES]; PQQ],
        [[0.0; LANES]; PQQ],
        [[0.0; LANES]; PQQ],
    );
    for c in 0..P {
        for qy in 0..Q {
            for qx in 0..Q {
                let o = qx + Q * (qy + Q * c);
                for b in 0..P {
                    let i = qx + Q * (b + P * c);
                    dot::<FMA>(&mut vv[o], im[qy][b], &vx[i]);
                    dot::<FMA>(&mut vd[o], dm[qy][b], &vx[i]);
                    dot::<FMA>(&mut dv[o], im[qy][b], &dx[i]);
                }
            }
        }
    }
    // z: the value and the three derivatives.
    for qz in 0..Q {
        for qyx in 0..Q * Q {
            let q = qyx + Q * Q * qz;
            let mut out = [[0.0; LANES]; 4];
            for c in 0..P {
                let i = qyx + Q * Q * c;
                dot::<FMA>(&mut out[0], im[qz][c], &vv[i]);
                dot::<FMA>(&mut out[1], im[qz][c], &dv[i]);
                dot::<FMA>(&mut out[2], im[qz][c], &vd[i]);
                dot::<FMA>(&mut out[3], dm[qz][c], &vv[i]);
            }
            val[q] = out[0];
            g[0][q] = out[1];
            g[1][q] = out[2];
            g[2][q] = out[3];
        }
    }
}

/// The transpose of [`forward`]: `f_a = Σ_q ∇_ξ N_a · t_q + N_a m_q` for one
/// output component, `t = g[i]` its three weighted stress columns and `m` its
/// weighted values.
#[inline(always)]
fn backward<
    const FMA: bool,
    const P: usize,
    const Q: usize,
    const NP: usize,
    const NQ: usize,
    const PPQ: usize,
    const PQQ: usize,
>(
    im: &[[f64; P]; Q],
    dm: &[[f64; P]; Q],
    t: &[[V; NQ]; 3],
    m: &[V; NQ],
    f: &mut [V; NP],
) {
    // zᵀ: sx = Iᵀ t_x, sy = Iᵀ t_y, sv = Dᵀ t_z + Iᵀ m, index qx + Q (qy + Q c).
    let (mut sx, mut sy, mut sv) = (
        [[0.0; LANES]; PQQ],
        [[0.0; LANES]; PQQ],
        [[0.0; LANES]; PQQ],
    );
    for c in 0..P {
        for qyx in 0..Q * Q {
            let o = qyx + Q * Q * c;
            for qz in 0..Q {
                let q = qyx + Q * Q * qz;
                dot::<FMA>(&mut sx[o], im[qz][c], &t[0][q]);
                dot::<FMA>(&mut sy[o], im[qz][c], &t[1][q]);
                dot::<FMA>(&mut sv[o], dm[qz][c], &t[2][q]);
                dot::<FMA>(&mut sv[o], im[qz][c], &m[q]);
            }
        }
    }
    // yᵀ: rx = Iᵀ sx, rv = Dᵀ sy + Iᵀ sv, index qx + Q (b + P c).
    let (mut rx, mut rv) = ([[0.0; LANES]; PPQ], [[0.0; LANES]; PPQ]);
    for c in 0..P {
        for b in 0..P {
            for qx in 0..Q {
                let o = qx + Q * (b + P * c);
                for qy in 0..Q {
                    let i = qx + Q * (qy + Q * c);
                    dot::<FMA>(&mut rx[o], im[qy][b], &sx[i]);
                    dot::<FMA>(&mut rv[o], dm[qy][b], &sy[i]);
                    dot::<FMA>(&mut rv[o], im[qy][b], &sv[i]);
                }
            }
        }
    }
    // xᵀ: f = Dᵀ rx + Iᵀ rv.
    for cb in 0..P * P {
        for a in 0..P {
            let mut acc = [0.0; LANES];
            for qx in 0..Q {
                dot::<FMA>(&mut acc, dm[qx][a], &rx[cb * Q + qx]);
                dot::<FMA>(&mut acc, im[qx][a], &rv[cb * Q + qx]);
            }
            f[cb * P + a] = acc;
        }
    }
}
