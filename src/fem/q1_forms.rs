//! Q1 cut cells in factored form: the matrix of the moment-fitted weights
//! ([`super::moment_fit`]) rewritten through the Q1 structure, 114 numbers a
//! cell, applied at about the cost of a dense 24 × 24 product without its
//! 4.6 kB of data.
//!
//! # The factorisation
//! For Q1 (`ξ ∈ [0,1]³`, `φ_0 = 1 − t`, `φ_1 = t`), `∂_d N_a = s^d_a ψ^d_{o_d(a)}`:
//! the sign `s^d_a = ±1` is `+` where node `a` has coordinate 1 along `d`, and
//! `ψ^d_α` is the bilinear product of the 1D functions of the two other axes,
//! indexed by `α = o_d(a) ∈ 0..4` (the node's coordinates along them). So
//! `A^{de}_{ab} = Σ_q W_q ∂_d N_a ∂_e N_b = s^d_a s^e_b T^{de}[o_d(a), o_e(b)]`
//! with the 4 × 4 matrices
//!
//! ```text
//! T^{de}[α, β] = h⁻² Σ_q W_q ψ^d_α(ξ_q) ψ^e_β(ξ_q),   T^{ed} = (T^{de})ᵀ,
//! ```
//! and, from `K[3a+i, 3b+j] = λ A^{ij}_{ab} + μ A^{ji}_{ab} + δ_ij (μ Σ_d A^{dd}_{ab} + M_{ab})`,
//! with the differences `D_e(v)[β] = v_{hi(e,β)} − v_{lo(e,β)}` (the nodes
//! `β` with coordinate 1 and 0 along `e`),
//!
//! ```text
//! (K x)_{a,i} = Σ_d s^d_a E_{d,i}[o_d(a)] + Σ_b M_{ab} x_{b,i},
//! E_{d,i} = δ_di λ Σ_e T^{de} D_e(x_e) + μ T^{di} D_i(x_d) + μ T^{dd} D_d(x_i),
//! ```
//! `M_ab = Σ_q M_q N_a N_b` the scalar mass of the penalty (and S-term). A
//! cell stores `T^{dd}` (symmetric, 10 each), `T^{01}, T^{02}, T^{12}` (16
//! each) and `M` (symmetric, 36): 114 numbers, exact rearrangements of its
//! weights. The apply works on [`LANES`] cells at once, one per SIMD lane,
//! the forms stored lane-interleaved per batch. Each rayon task first
//! gathers its cells' dofs through their node indices (prefetched a few
//! cells ahead: the nodes are scattered), then computes its batches. The
//! whole cell has a form too ([`Q1Forms::inside`]), which
//! [`Q1Forms::apply_uniform`] applies to any number of inside cells.

use rayon::prelude::*;

use super::fast_apply::fma_available;
use super::moment_fit::{CutWeights, FitBasis};
use super::stencil::{madd, prefetch};
use crate::element::reference::{reference_box_mass, reference_mass};
use crate::element::ElementOrder;

/// Cells per batch (SIMD lanes).
pub const LANES: usize = 4;
/// Numbers per cell.
pub const FORM_LEN: usize = 114;
/// Batches per rayon task.
const BATCHES_PER_TASK: usize = 32;
/// How many cells ahead of its gather a cell's dofs are prefetched.
const PREFETCH_AHEAD: usize = 12;
/// Offsets of the parts of a form.
const DIAG: usize = 0;
const MIXED: usize = 30;
/// Offset of the scalar mass `M` (packed symmetric 8 × 8) in a form.
pub const MASS: usize = 78;

type V = [f64; LANES];

/// Index of `M_ab` in a form.
const MASS_INDEX: [[usize; 8]; 8] = {
    let mut t = [[0; 8]; 8];
    let mut a = 0;
    while a < 8 {
        let mut b = 0;
        while b < 8 {
            t[a][b] = MASS + sym(8, a, b);
            b += 1;
        }
        a += 1;
    }
    t
};

/// Packed index of `(r, c)` in a symmetric `n × n` matrix (upper triangle).
pub const fn sym(n: usize, r: usize, c: usize) -> usize {
    let (r, c) = if r <= c { (r, c) } else { (c, r) };
    r * n - r * (r + 1) / 2 + c
}

/// The two axes other than `d`, ascending.
const fn others(d: usize) -> (usize, usize) {
    match d {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// The node with coordinate `v` along `d` and `α` along the other two axes.
pub const fn node(d: usize, alpha: usize, v: usize) -> usize {
    let (o1, o2) = others(d);
    (v << d) | ((alpha & 1) << o1) | ((alpha >> 1) << o2)
}

/// `o_d(a)`: node `a`'s coordinates along the axes other than `d`.
const fn other_index(d: usize, a: usize) -> usize {
    let (o1, o2) = others(d);
    ((a >> o1) & 1) | (((a >> o2) & 1) << 1)
}

/// Index of `T^{de}[α, β]` in a form.
pub const fn t_index(d: usize, e: usize, alpha: usize, beta: usize) -> usize {
    if d == e {
        DIAG + 10 * d + sym(4, alpha, beta)
    } else if d < e {
        MIXED + 16 * (d + e - 1) + 4 * alpha + beta
    } else {
        MIXED + 16 * (d + e - 1) + 4 * beta + alpha
    }
}

/// `s^d_a`.
fn sign(d: usize, a: usize) -> f64 {
    if (a >> d) & 1 == 1 {
        1.0
    } else {
        -1.0
    }
}

/// The factored forms of all Q1 cut cells, lane-interleaved per batch.
#[derive(Clone, Debug)]
pub struct Q1Forms {
    /// `data[(s / LANES) FORM_LEN + k][s % LANES]`: entry `k` of cell `s`.
    data: Vec<V>,
    lambda: f64,
    mu: f64,
    /// The reference scalar mass `M_ref`, packed (for the S-term).
    mass_ref: [f64; 36],
    fma: bool,
}

impl Q1Forms {
    /// The forms of the weights `w` (Q1 `basis`), for Lamé parameters
    /// `(λ, μ)` and cell size `h`.
    pub fn new(basis: &FitBasis, w: &CutWeights, (lambda, mu): (f64, f64), h: f64) -> Q1Forms {
        assert_eq!(basis.order, ElementOrder::Q1);
        let cells = w.len();
        let batches = cells.div_ceil(LANES);
        let mut data = vec![[0.0; LANES]; batches * FORM_LEN];
        let s2 = 1.0 / (h * h);
        data.par_chunks_mut(FORM_LEN)
            .enumerate()
            .for_each(|(b, chunk)| {
                for l in 0..LANES.min(cells - b * LANES) {
                    let form = cell_form(basis, w, b * LANES + l, s2);
                    for (c, v) in chunk.iter_mut().zip(form) {
                        c[l] = v;
                    }
                }
            });
        let m = reference_mass(ElementOrder::Q1);
        let mut mass_ref = [0.0; 36];
        for a in 0..8 {
            for b in a..8 {
                mass_ref[sym(8, a, b)] = m[(a, b)];
            }
        }
        Q1Forms {
            data,
            lambda,
            mu,
            mass_ref,
            fma: fma_available(),
        }
    }

    /// The form of the whole (inside) cell, `h K_ref`, in every lane of one
    /// batch: the full-cell Gauss rule as stiffness weights, no mass.
    pub fn inside(basis: &FitBasis, lame: (f64, f64), h: f64) -> Q1Forms {
        let nq = basis.num_points();
        let mut data = vec![0.0; 2 * nq * LANES];
        for cell in data.chunks_exact_mut(2 * nq) {
            basis.add_cell_rule(h * h * h, &mut cell[..nq]);
        }
        Q1Forms::new(basis, &CutWeights { nq, data }, lame, h)
    }

    /// Bytes of the forms.
    pub fn bytes(&self) -> usize {
        8 * LANES * self.data.len()
    }

    fn at(&self, s: usize, k: usize) -> f64 {
        self.data[(s / LANES) * FORM_LEN + k][s % LANES]
    }

    /// The form of cell `s` (what a device backend uploads).
    pub fn form(&self, s: usize) -> [f64; FORM_LEN] {
        std::array::from_fn(|k| self.at(s, k))
    }

    /// The Lamé parameters `(λ, μ)` the forms are applied with.
    pub fn lame(&self) -> (f64, f64) {
        (self.lambda, self.mu)
    }

    /// Adds `factor_h3 M_ref` to cell `s`'s mass (the S-term's whole-cell mass).
    pub fn add_cell_mass(&mut self, s: usize, factor_h3: f64) {
        for (k, m) in self.mass_ref.iter().enumerate() {
            self.data[(s / LANES) * FORM_LEN + MASS + k][s % LANES] += factor_h3 * m;
        }
    }

    /// Adds `factor_h3 M_box` to cell `s`'s mass, `M_box` the scalar mass of
    /// the cell's shape functions over the reference box `[lo, hi]`
    /// ([`reference_box_mass`]).
    pub fn add_box_mass(&mut self, s: usize, factor_h3: f64, lo: [f64; 3], hi: [f64; 3]) {
        let m = reference_box_mass(ElementOrder::Q1, lo, hi);
        for a in 0..8 {
            for b in a..8 {
                self.data[(s / LANES) * FORM_LEN + MASS + sym(8, a, b)][s % LANES] +=
                    factor_h3 * m[(a, b)];
            }
        }
    }

    /// `A^{de}_{ab}` of cell `s`.
    fn a(&self, s: usize, d: usize, e: usize, a: usize, b: usize) -> f64 {
        let t = self.at(s, t_index(d, e, other_index(d, a), other_index(e, b)));
        sign(d, a) * sign(e, b) * t
    }

    /// The dense matrix of cell `s`, row-major 24 × 24 (see the module doc).
    pub fn expand(&self, s: usize) -> Vec<f64> {
        let mut k = vec![0.0; 576];
        for a in 0..8 {
            for b in 0..8 {
                let mass = self.at(s, MASS + sym(8, a, b));
                let lap: f64 = (0..3).map(|d| self.a(s, d, d, a, b)).sum();
                for i in 0..3 {
                    for j in 0..3 {
                        let diag = if i == j { self.mu * lap + mass } else { 0.0 };
                        k[(3 * a + i) * 24 + 3 * b + j] = self.lambda * self.a(s, i, j, a, b)
                            + self.mu * self.a(s, j, i, a, b)
                            + diag;
                    }
                }
            }
        }
        k
    }

    /// The diagonal of [`Q1Forms::expand`].
    pub fn diagonal(&self, s: usize) -> Vec<f64> {
        let mut out = vec![0.0; 24];
        for a in 0..8 {
            let mass = self.at(s, MASS + sym(8, a, a));
            let lap: f64 = (0..3).map(|d| self.a(s, d, d, a, a)).sum();
            for i in 0..3 {
                out[3 * a + i] =
                    (self.lambda + self.mu) * self.a(s, i, i, a, a) + self.mu * lap + mass;
            }
        }
        out
    }

    /// `z[24 s .. 24 (s+1)] = K_s x_s` for every cell `s`, whose 8 nodes
    /// (local order) have the dofs `x[3 nodes[s][q] ..][.. 3]`.
    pub fn apply(&self, nodes: &[[u32; 8]], x: &[f64], z: &mut [f64]) {
        self.apply_batches::<false>(nodes, x, z);
    }

    /// [`Q1Forms::apply`] with the one massless matrix `K` of the first
    /// batch for every cell (as [`Q1Forms::inside`] makes).
    pub fn apply_uniform(&self, nodes: &[[u32; 8]], x: &[f64], z: &mut [f64]) {
        self.apply_batches::<true>(nodes, x, z);
    }

    /// [`Q1Forms::apply`], or with `UNIFORM` [`Q1Forms::apply_uniform`].
    fn apply_batches<const UNIFORM: bool>(&self, nodes: &[[u32; 8]], x: &[f64], z: &mut [f64]) {
        assert_eq!(z.len(), 24 * nodes.len());
        let per_task = LANES * BATCHES_PER_TASK;
        z.par_chunks_mut(24 * per_task)
            .zip(nodes.par_chunks(per_task))
            .enumerate()
            .for_each(|(t, (zt, nt))| {
                #[cfg(target_arch = "x86_64")]
                if self.fma {
                    // SAFETY: `fma` is set only when the CPU reports AVX2 and FMA.
                    unsafe { self.task_fma::<UNIFORM>(t * BATCHES_PER_TASK, nt, x, zt) };
                    return;
                }
                self.task::<false, UNIFORM>(t * BATCHES_PER_TASK, nt, x, zt);
            });
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn task_fma<const UNIFORM: bool>(
        &self,
        first: usize,
        nodes: &[[u32; 8]],
        x: &[f64],
        z: &mut [f64],
    ) {
        self.task::<true, UNIFORM>(first, nodes, x, z);
    }

    /// The batches `first, first + 1, …` of cells `nodes`: all their dofs
    /// gathered first (independent loads, many in flight), then the products.
    #[inline(always)]
    fn task<const FMA: bool, const UNIFORM: bool>(
        &self,
        first: usize,
        nodes: &[[u32; 8]],
        x: &[f64],
        z: &mut [f64],
    ) {
        let mut u = [[[[0.0; LANES]; 8]; 3]; BATCHES_PER_TASK];
        for (s, cell) in nodes.iter().enumerate() {
            if let Some(ahead) = nodes.get(s + PREFETCH_AHEAD) {
                prefetch_nodes(ahead, x);
            }
            let ub = &mut u[s / LANES];
            for (a, &node) in cell.iter().enumerate() {
                let xa = &x[3 * node as usize..3 * node as usize + 3];
                for (j, &v) in xa.iter().enumerate() {
                    ub[j][a][s % LANES] = v;
                }
            }
        }
        for (b, (zb, ub)) in z.chunks_mut(24 * LANES).zip(&u).enumerate() {
            let b0 = if UNIFORM { 0 } else { first + b };
            let form: &[V; FORM_LEN] = self.data[b0 * FORM_LEN..(b0 + 1) * FORM_LEN]
                .try_into()
                .expect("a whole batch");
            let f = self.batch::<FMA, UNIFORM>(form, ub);
            for (l, zl) in zb.chunks_exact_mut(24).enumerate() {
                for a in 0..8 {
                    for i in 0..3 {
                        zl[3 * a + i] = f[i][a][l];
                    }
                }
            }
        }
    }

    /// The terms `Σ_a s^D_a E_{D,i}[o_D(a)]` of direction `D`, all `i`.
    #[inline(always)]
    fn direction<const FMA: bool, const D: usize>(
        &self,
        form: &[V; FORM_LEN],
        diff: &[[[V; 4]; 3]; 3],
        f: &mut [[V; 8]; 3],
    ) {
        let mut p = [[0.0; LANES]; 4];
        matvec::<FMA, D, 0>(form, &diff[0][0], &mut p);
        matvec::<FMA, D, 1>(form, &diff[1][1], &mut p);
        matvec::<FMA, D, 2>(form, &diff[2][2], &mut p);
        let mut acc = [[[0.0; LANES]; 4]; 3];
        matvec::<FMA, D, 0>(form, &diff[0][D], &mut acc[0]);
        matvec::<FMA, D, 1>(form, &diff[1][D], &mut acc[1]);
        matvec::<FMA, D, 2>(form, &diff[2][D], &mut acc[2]);
        for (i, acc) in acc.iter_mut().enumerate() {
            matvec::<FMA, D, D>(form, &diff[D][i], acc);
        }
        for (i, (fi, acc)) in f.iter_mut().zip(&acc).enumerate() {
            for (alpha, e) in acc.iter().enumerate() {
                let (hi, lo) = (node(D, alpha, 1), node(D, alpha, 0));
                for l in 0..LANES {
                    let mut v = self.mu * e[l];
                    if D == i {
                        v = madd::<FMA>(self.lambda, p[alpha][l], v);
                    }
                    fi[hi][l] += v;
                    fi[lo][l] -= v;
                }
            }
        }
    }

    /// `f_i = (K x)_i` for one batch: `form` its lane-interleaved forms, `u[j][a]`
    /// component `j` of node `a`; the mass is left out when `MASSLESS`.
    #[inline(always)]
    fn batch<const FMA: bool, const MASSLESS: bool>(
        &self,
        form: &[V; FORM_LEN],
        u: &[[V; 8]; 3],
    ) -> [[V; 8]; 3] {
        // diff[e][j][β]: differences of component j along e.
        let mut diff = [[[[0.0; LANES]; 4]; 3]; 3];
        for (e, de) in diff.iter_mut().enumerate() {
            for (j, dej) in de.iter_mut().enumerate() {
                for (beta, v) in dej.iter_mut().enumerate() {
                    let (hi, lo) = (u[j][node(e, beta, 1)], u[j][node(e, beta, 0)]);
                    *v = std::array::from_fn(|l| hi[l] - lo[l]);
                }
            }
        }
        let mut f = [[[0.0; LANES]; 8]; 3];
        self.direction::<FMA, 0>(form, &diff, &mut f);
        self.direction::<FMA, 1>(form, &diff, &mut f);
        self.direction::<FMA, 2>(form, &diff, &mut f);
        if MASSLESS {
            return f;
        }
        for a in 0..8 {
            let mut acc = [f[0][a], f[1][a], f[2][a]];
            for b in 0..8 {
                let m = &form[MASS_INDEX[a][b]];
                for (acc, ui) in acc.iter_mut().zip(u) {
                    *acc = std::array::from_fn(|l| madd::<FMA>(m[l], ui[b][l], acc[l]));
                }
            }
            for (fi, acc) in f.iter_mut().zip(acc) {
                fi[a] = acc;
            }
        }
        f
    }
}

/// Asks the CPU to fetch the dofs of the nodes `cell` into its caches (the
/// cells' nodes are scattered: the hardware prefetchers do not find them).
#[inline(always)]
fn prefetch_nodes(cell: &[u32; 8], x: &[f64]) {
    for &node in cell {
        prefetch(&x[3 * node as usize..][..3]);
    }
}

/// `acc += T^{DE} v` on lanes.
#[inline(always)]
fn matvec<const FMA: bool, const D: usize, const E: usize>(
    form: &[V; FORM_LEN],
    v: &[V; 4],
    acc: &mut [V; 4],
) {
    for (alpha, acc) in acc.iter_mut().enumerate() {
        for (beta, vb) in v.iter().enumerate() {
            let t = form[t_index(D, E, alpha, beta)];
            for l in 0..LANES {
                acc[l] = madd::<FMA>(t[l], vb[l], acc[l]);
            }
        }
    }
}

/// The form of cell `s` of `w` (see the module doc), `s2 = h⁻²`.
fn cell_form(basis: &FitBasis, w: &CutWeights, s: usize, s2: f64) -> [f64; FORM_LEN] {
    let (wk, wm) = w.cell(s);
    let mut form = [0.0; FORM_LEN];
    for q in 0..basis.num_points() {
        let (n, g) = basis.point(q);
        // ψ^d_α(ξ_q) = ∂_d N_{hi(d,α)}(ξ_q).
        let psi = |d: usize, alpha: usize| g[node(d, alpha, 1)][d];
        for d in 0..3 {
            for e in d..3 {
                for alpha in 0..4 {
                    for beta in 0..4 {
                        if d == e && beta < alpha {
                            continue;
                        }
                        form[t_index(d, e, alpha, beta)] +=
                            s2 * wk[q] * psi(d, alpha) * psi(e, beta);
                    }
                }
            }
        }
        for a in 0..8 {
            for b in a..8 {
                form[MASS + sym(8, a, b)] += wm[q] * n[a] * n[b];
            }
        }
    }
    form
}

#[cfg(test)]
#[path = "q1_forms_tests.rs"]
mod tests;
