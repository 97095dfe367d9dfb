//! CPU mirrors of the multigrid kernels of `shaders/` (`chebyshev_update`,
//! `block_rows`, `prolong_add`, `restrict`, `dense_matvec`), in the manner of
//! [`super::mirror`]: same name, same argument order as the bindings, one
//! loop body per invocation.

use super::kernels::{GatherParams, VecParams};

/// An inactive lattice node in `node_to_active`.
const INACTIVE: u32 = u32::MAX;

/// `d = a d + c z`, then `x = x + d`; `a = scal[ia]`, `c = scal[ib]`.
pub fn chebyshev_update(prm: &VecParams, scal: &[f64], z: &[f64], d: &mut [f64], x: &mut [f64]) {
    let (a, c) = (scal[prm.ia as usize], scal[prm.ib as usize]);
    for i in 0..prm.n as usize {
        let di = a * d[i] + c * z[i];
        d[i] = di;
        x[i] += di;
    }
}

/// `z[dofs[k]] = Σ_j inv_b[row, j] r[dofs[s_b + j]]` for every block entry `k`.
#[allow(clippy::too_many_arguments)]
pub fn block_rows(
    prm: &GatherParams,
    r: &[f64],
    z: &mut [f64],
    dofs: &[u32],
    block_of: &[u32],
    starts: &[u32],
    inv_starts: &[u32],
    inverses: &[f64],
) {
    for k in 0..prm.n as usize {
        let b = block_of[k] as usize;
        let s = starts[b] as usize;
        let m = starts[b + 1] as usize - s;
        let row = inv_starts[b] as usize + (k - s) * m;
        let mut acc = 0.0;
        for j in 0..m {
            acc += inverses[row + j] * r[dofs[s + j] as usize];
        }
        z[dofs[k] as usize] = acc;
    }
}

/// `(i, j, k)` of lattice node `node` with `(mx, my)` nodes along x and y.
fn ijk(node: u32, mx: u32, my: u32) -> [u32; 3] {
    [node % mx, (node / mx) % my, node / (mx * my)]
}

/// `xf = xf + P xc` (trilinear), one fine active node at a time.
pub fn prolong_add(
    prm: &GatherParams,
    xc: &[f64],
    xf: &mut [f64],
    fine_active_to_node: &[u32],
    coarse_node_to_active: &[u32],
) {
    for a in 0..prm.n as usize {
        let [i, j, k] = ijk(fine_active_to_node[a], prm.fx, prm.fy);
        let (ni, nj, nk) = (1 + (i & 1), 1 + (j & 1), 1 + (k & 1));
        let w = |n: u32| if n == 2 { 0.5 } else { 1.0 };
        let mut y = [xf[3 * a], xf[3 * a + 1], xf[3 * a + 2]];
        for ck in 0..nk {
            for cj in 0..nj {
                for ci in 0..ni {
                    let node = (i / 2 + ci) + prm.cx * ((j / 2 + cj) + prm.cy * (k / 2 + ck));
                    let c = coarse_node_to_active[node as usize];
                    if c == INACTIVE {
                        continue;
                    }
                    let wt = w(ni) * w(nj) * w(nk);
                    for (comp, yc) in y.iter_mut().enumerate() {
                        *yc += wt * xc[3 * c as usize + comp];
                    }
                }
            }
        }
        xf[3 * a..3 * a + 3].copy_from_slice(&y);
    }
}

/// `xc = Pᵀ xf`, one coarse active node at a time.
pub fn restrict(
    prm: &GatherParams,
    xf: &[f64],
    xc: &mut [f64],
    coarse_active_to_node: &[u32],
    fine_node_to_active: &[u32],
) {
    // Candidate t of coarse index i along an axis of m fine nodes.
    let candidate =
        |i: u32, t: u32, m: u32| -> Option<u32> { (2 * i + t).checked_sub(1).filter(|&f| f < m) };
    let weight = |t: u32| if t == 1 { 1.0 } else { 0.5 };
    for a in 0..prm.n as usize {
        let [i, j, k] = ijk(coarse_active_to_node[a], prm.cx, prm.cy);
        let mut y = [0.0; 3];
        for tk in 0..3 {
            let Some(fk) = candidate(k, tk, prm.fz) else {
                continue;
            };
            for tj in 0..3 {
                let Some(fj) = candidate(j, tj, prm.fy) else {
                    continue;
                };
                for ti in 0..3 {
                    let Some(fi) = candidate(i, ti, prm.fx) else {
                        continue;
                    };
                    let f = fine_node_to_active[(fi + prm.fx * (fj + prm.fy * fk)) as usize];
                    if f == INACTIVE {
                        continue;
                    }
                    let w = weight(ti) * weight(tj) * weight(tk);
                    for (comp, yc) in y.iter_mut().enumerate() {
                        *yc += w * xf[3 * f as usize + comp];
                    }
                }
            }
        }
        xc[3 * a..3 * a + 3].copy_from_slice(&y);
    }
}

/// `y = A x`, `A` dense `n × n` and symmetric, row `i` read as column `i`.
pub fn dense_matvec(prm: &GatherParams, a: &[f64], x: &[f64], y: &mut [f64]) {
    let n = prm.n as usize;
    for i in 0..n {
        let mut acc = 0.0;
        for j in 0..n {
            acc += a[j * n + i] * x[j];
        }
        y[i] = acc;
    }
}
