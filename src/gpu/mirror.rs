//! CPU mirrors of the WGSL kernels of `shaders/`: same name, same argument
//! order as the bindings (params first), explicit index loops, one loop body
//! per invocation, so each reads side by side with its shader. The tests
//! compare every kernel with its mirror; the mirrors also document the
//! reduction tree of `dot`/`dot2`/`reduce` exactly.
// Index loops, not slice methods, to read like the shaders.
#![allow(clippy::manual_memcpy)]

use super::kernels::{ApplyParams, GatherParams, Q1Params, RedParams, VecParams};
use super::kernels::{PER, WG};
use super::q1_terms::{
    form_product, mass_product, stencil_terms, NO_PARTIAL, PARTIAL_LEN, SEG, SEGMENT_WORDS,
};
use crate::fem::operator::{INSIDE, OUTSIDE};
use crate::fem::q1_forms::{FORM_LEN, MASS};

/// `dst = src`.
pub fn copy(prm: &VecParams, src: &[f64], dst: &mut [f64]) {
    for i in 0..prm.n as usize {
        dst[i] = src[i];
    }
}

/// `x = a x`, `a = scal[ia]`.
pub fn scale(prm: &VecParams, scal: &[f64], x: &mut [f64]) {
    for i in 0..prm.n as usize {
        x[i] *= scal[prm.ia as usize];
    }
}

/// `y = y + a x`, `a = scal[ia]`.
pub fn axpy(prm: &VecParams, scal: &[f64], x: &[f64], y: &mut [f64]) {
    for i in 0..prm.n as usize {
        y[i] += scal[prm.ia as usize] * x[i];
    }
}

/// `y = x + a y`, `a = scal[ia]`.
pub fn xpay(prm: &VecParams, scal: &[f64], x: &[f64], y: &mut [f64]) {
    for i in 0..prm.n as usize {
        y[i] = x[i] + scal[prm.ia as usize] * y[i];
    }
}

/// `y = y + a u + b w`, `a = scal[ia]`, `b = scal[ib]`.
pub fn axpy2(prm: &VecParams, scal: &[f64], u: &[f64], w: &[f64], y: &mut [f64]) {
    let (a, b) = (scal[prm.ia as usize], scal[prm.ib as usize]);
    for i in 0..prm.n as usize {
        y[i] = y[i] + a * u[i] + b * w[i];
    }
}

/// `z = x ∘ y`.
pub fn pointwise_mul(prm: &VecParams, x: &[f64], y: &[f64], z: &mut [f64]) {
    for i in 0..prm.n as usize {
        z[i] = x[i] * y[i];
    }
}

/// `out[k] = v[idx[k]]`.
pub fn gather_entries(prm: &GatherParams, v: &[f64], out: &mut [f64], idx: &[u32]) {
    for k in 0..prm.n as usize {
        out[k] = v[idx[k] as usize];
    }
}

/// `v[idx[k]] = values[k]`.
pub fn scatter_entries(prm: &GatherParams, values: &[f64], v: &mut [f64], idx: &[u32]) {
    for k in 0..prm.n as usize {
        v[idx[k] as usize] = values[k];
    }
}

/// `u = r + β q`, then `p = u + β (q + β p)`; `β = scal[ia]`.
pub fn cgs_update_up(
    prm: &VecParams,
    scal: &[f64],
    r: &[f64],
    q: &[f64],
    u: &mut [f64],
    p: &mut [f64],
) {
    let beta = scal[prm.ia as usize];
    for i in 0..prm.n as usize {
        u[i] = r[i] + beta * q[i];
        p[i] = u[i] + beta * (q[i] + beta * p[i]);
    }
}

/// `q = u − α v`, then `u = u + q`; `α = scal[ia]`.
pub fn cgs_update_qu(prm: &VecParams, scal: &[f64], v: &[f64], q: &mut [f64], u: &mut [f64]) {
    for i in 0..prm.n as usize {
        q[i] = u[i] - scal[prm.ia as usize] * v[i];
        u[i] += q[i];
    }
}

/// `p = r + β (p − ω v)`; `β = scal[ia]`, `ω = scal[ib]`.
pub fn bicgstab_update_p(prm: &VecParams, scal: &[f64], r: &[f64], v: &[f64], p: &mut [f64]) {
    let (beta, omega) = (scal[prm.ia as usize], scal[prm.ib as usize]);
    for i in 0..prm.n as usize {
        p[i] = r[i] + beta * (p[i] - omega * v[i]);
    }
}

/// The workgroup's fixed two-level sum of its `WG` = 256 values: threads
/// `t < 16` add `sh[16 t .. 16 t + 16]` in order into `sh[16 t]`, then those
/// 16 are added in order (two barriers in the shaders, not eight).
pub(super) fn tree(sh: &mut [f64]) -> f64 {
    for t in 0..16 {
        let mut a = 0.0;
        for j in 0..16 {
            a += sh[16 * t + j];
        }
        sh[16 * t] = a;
    }
    let mut total = 0.0;
    for j in 0..16 {
        total += sh[16 * j];
    }
    total
}

/// First pass of `x · y` over one window: `partials[base + g]` for each of its
/// `groups` workgroups.
pub fn dot(prm: &RedParams, x: &[f64], y: &[f64], partials: &mut [f64]) {
    let (wg, per) = (WG as usize, PER as usize);
    let mut sh = vec![0.0; wg];
    for g in 0..prm.groups as usize {
        for t in 0..wg {
            let mut s = 0.0;
            for j in 0..per {
                let i = g * wg * per + j * wg + t;
                if i < prm.n as usize {
                    s += x[i] * y[i];
                }
            }
            sh[t] = s;
        }
        partials[prm.base as usize + g] = tree(&mut sh);
    }
}

/// First pass of `(x · y, x · z)` over one window: `partials[base + g]`,
/// `partials[total + base + g]`.
pub fn dot2(prm: &RedParams, x: &[f64], y: &[f64], z: &[f64], partials: &mut [f64]) {
    let (wg, per, base) = (WG as usize, PER as usize, prm.base as usize);
    let (mut sy, mut sz) = (vec![0.0; wg], vec![0.0; wg]);
    for g in 0..prm.groups as usize {
        for t in 0..wg {
            let (mut a, mut b) = (0.0, 0.0);
            for j in 0..per {
                let i = g * wg * per + j * wg + t;
                if i < prm.n as usize {
                    a += x[i] * y[i];
                    b += x[i] * z[i];
                }
            }
            sy[t] = a;
            sz[t] = b;
        }
        partials[base + g] = tree(&mut sy);
        partials[prm.total as usize + base + g] = tree(&mut sz);
    }
}

/// Second pass: `scal[out + c] = Σ_i partials[c n + i]`, thread `t` summing
/// `i = t, t + WG, …` in order, then the tree.
pub fn reduce(prm: &RedParams, partials: &[f64], scal: &mut [f64]) {
    let wg = WG as usize;
    let n = prm.n as usize;
    let mut sh = vec![0.0; wg];
    for c in 0..prm.comps as usize {
        for t in 0..wg {
            let mut s = 0.0;
            let mut i = t;
            while i < n {
                s += partials[c * n + i];
                i += wg;
            }
            sh[t] = s;
        }
        scal[prm.out as usize + c] = tree(&mut sh);
    }
}

/// `y = A x` (one pass over the own-matrix chunk `[own_lo, own_hi)` for the
/// active nodes of one window, see apply.wgsl): per active node, its ≤ 8
/// cells, their matrices' rows. The index arrays, `x` and `y` are the
/// window's slices (`x` from active node `x_base`, `node_to_active` from
/// lattice node `lattice_base`, `slots` from cell `cell_base`).
#[allow(clippy::too_many_arguments)]
pub fn apply(
    prm: &ApplyParams,
    active_to_node: &[u32],
    node_to_active: &[u32],
    slots: &[u32],
    k_inside: &[f64],
    k_own: &[f64],
    x: &[f64],
    y: &mut [f64],
) {
    let p = prm.degree as usize;
    let np = p + 1;
    let nc = [prm.ncx as usize, prm.ncy as usize, prm.ncz as usize];
    let (m0, m1) = (p * nc[0] + 1, p * nc[1] + 1);
    let ne = prm.ne as usize;
    for a in 0..prm.n_active as usize {
        let node = active_to_node[a] as usize;
        let ijk = [node % m0, (node / m0) % m1, node / (m0 * m1)];
        let mut cell_of = [[0usize; 2]; 3];
        let mut local_of = [[0usize; 2]; 3];
        let mut count = [0usize; 3];
        for ax in 0..3 {
            let (q, r) = (ijk[ax] / p, ijk[ax] % p);
            let mut k = 0;
            if r == 0 {
                if q > 0 {
                    (cell_of[ax][k], local_of[ax][k]) = (q - 1, p);
                    k += 1;
                }
                if q < nc[ax] {
                    (cell_of[ax][k], local_of[ax][k]) = (q, 0);
                    k += 1;
                }
            } else {
                (cell_of[ax][0], local_of[ax][0]) = (q, r);
                k = 1;
            }
            count[ax] = k;
        }
        let mut acc = [0.0; 3];
        if prm.first == 0 {
            acc.copy_from_slice(&y[3 * a..3 * a + 3]);
        }
        for cz in 0..count[2] {
            for cy in 0..count[1] {
                for cx in 0..count[0] {
                    let (ci, cj, ck) = (cell_of[0][cx], cell_of[1][cy], cell_of[2][cz]);
                    let cell = ci + nc[0] * (cj + nc[1] * ck);
                    let l = local_of[0][cx] + np * (local_of[1][cy] + np * local_of[2][cz]);
                    let s = slots[cell - prm.cell_base as usize];
                    let (k, base): (&[f64], usize) = if s == OUTSIDE {
                        continue;
                    } else if s == INSIDE {
                        if prm.first == 0 {
                            continue;
                        }
                        (k_inside, 0)
                    } else {
                        if s < prm.own_lo || s >= prm.own_hi {
                            continue;
                        }
                        (k_own, (s - prm.own_lo) as usize * ne * ne)
                    };
                    let mut m = 0;
                    for c in 0..np {
                        for b in 0..np {
                            for aa in 0..np {
                                let nn = (p * ci + aa) + m0 * ((p * cj + b) + m1 * (p * ck + c));
                                let act = (node_to_active[nn - prm.lattice_base as usize]
                                    - prm.x_base)
                                    as usize;
                                for j in 0..3 {
                                    let xj = x[3 * act + j];
                                    for i in 0..3 {
                                        acc[i] += k[base + (3 * l + i) * ne + 3 * m + j] * xj;
                                    }
                                }
                                m += 1;
                            }
                        }
                    }
                }
            }
        }
        y[3 * a..3 * a + 3].copy_from_slice(&acc);
    }
}

/// `z[24 c ..][.. 24] = K_c x_c` for cells `c < n_cells` from the factored
/// forms: entry `k` of a cut cell's at `k_cells[k n_cut + c]`, of a rim
/// cell's (the shared whole-cell form) at `k_cells[114 n_cut + k]`, λ and μ
/// after it, then the partial-mask penalties that `partial_of` indexes.
pub fn q1_cells(
    prm: &Q1Params,
    cell_nodes: &[u32],
    partial_of: &[u32],
    k_cells: &[f64],
    x: &[f64],
    z: &mut [f64],
) {
    let n_cut = prm.n_cut as usize;
    let shared = FORM_LEN * n_cut;
    let lame = (k_cells[shared + FORM_LEN], k_cells[shared + FORM_LEN + 1]);
    let partial_base = shared + FORM_LEN + 2;
    for c in 0..prm.n_cells as usize {
        let (base, step) = if c < n_cut { (c, n_cut) } else { (shared, 1) };
        let t = |k: usize| k_cells[base + k * step];
        let mut u = [0.0; 24];
        for m in 0..8 {
            let n = 3 * cell_nodes[8 * c + m] as usize;
            for j in 0..3 {
                u[3 * m + j] = x[n + j];
            }
        }
        let mut zc = [0.0; 24];
        form_product(t, lame, &u, &mut zc);
        if c < n_cut {
            mass_product(|_, k| t(MASS + k), &u, &mut zc);
            if partial_of[c] != NO_PARTIAL {
                let pb = partial_base + PARTIAL_LEN * partial_of[c] as usize;
                mass_product(|i, k| k_cells[pb + 36 * i + k], &u, &mut zc);
            }
        }
        z[24 * c..24 * c + 24].copy_from_slice(&zc);
    }
}

/// `y = A x` at every active node from the interior stencil (`stencil`, the
/// uniform's values) over each segment's neighbour rows, and for the
/// boundary nodes the sum of their 8 linked triples of `z`. With
/// `partials` (the dot variant), `partials[g]` is workgroup `g`'s `x · y`
/// (its [`SEG`] threads' sums added in order).
#[allow(clippy::too_many_arguments)]
pub fn q1_nodes(
    prm: &Q1Params,
    stencil: &[f64],
    segments: &[u32],
    boundary: &[u32],
    links: &[u32],
    z: &[f64],
    x: &[f64],
    y: &mut [f64],
    mut partials: Option<&mut [f64]>,
) {
    let terms = stencil_terms();
    let seg = SEG;
    let mut sh = vec![0.0; seg];
    for g in 0..prm.n_segments as usize {
        let s = &segments[SEGMENT_WORDS * g..SEGMENT_WORDS * (g + 1)];
        let (start, len) = (s[0] as usize, s[1] as usize);
        sh.fill(0.0);
        for t in 0..len {
            let mut acc = [0.0; 3];
            for term in &terms {
                let b = s[2 + term.r] as usize + t;
                acc[term.i] += stencil[term.k] * x[3 * (b + term.shift) + term.j];
            }
            let a = start + t;
            for i in 0..3 {
                y[3 * a + i] = acc[i];
            }
            sh[t] = x[3 * a] * acc[0] + x[3 * a + 1] * acc[1] + x[3 * a + 2] * acc[2];
        }
        if let Some(partials) = partials.as_deref_mut() {
            partials[g] = in_order(&sh);
        }
    }
    let n_boundary = prm.n_boundary as usize;
    for (k, g) in (prm.n_segments as usize..).enumerate() {
        if k * seg >= n_boundary {
            break;
        }
        sh.fill(0.0);
        for t in 0..seg.min(n_boundary - k * seg) {
            let b = k * seg + t;
            let mut acc = [0.0; 3];
            for cc in 0..8 {
                let o = links[8 * b + cc] as usize;
                for i in 0..3 {
                    acc[i] += z[o + i];
                }
            }
            let a = boundary[b] as usize;
            let mut c = 0.0;
            for i in 0..3 {
                y[3 * a + i] = acc[i];
                c += x[3 * a + i] * acc[i];
            }
            sh[t] = c;
        }
        if let Some(partials) = partials.as_deref_mut() {
            partials[g] = in_order(&sh);
        }
    }
}

/// `Σ sh[t]` added in the order of `t` (thread 0's loop in `q1_nodes`).
fn in_order(sh: &[f64]) -> f64 {
    let mut s = 0.0;
    for v in sh {
        s += v;
    }
    s
}
