//! The GPU kernel of the tangent over inside cells, `shaders/hyper_tangent.wgsl`,
//! as the host sees it: its source, its params struct, the data it reads
//! (built from a [`TangentOperator`]) and its CPU mirror
//! [`hyper_tangent`] (same name, same binding order, same loops).
//!
//! The device needs no logarithm: per inside point the host uploads the tangent
//! coefficients `(Σ, M, G, c)` of [`crate::hyper::material::TangentCoefficients`]
//! (28 reals), so that `dP = ∇x Σ + M ∇x + λ (G : ∇x) G + c G ∇xᵀ G` is pure
//! arithmetic. Cut cells and the Dirichlet penalty stay on the CPU
//! ([`TangentOperator::add_cut_cells`]): `K_T x = hyper_tangent(x) + cut(x)`.

use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;

use super::problem::HyperProblem;
use super::tangent::TangentOperator;

/// Nodes of the kernel's cells: the kernel is Q1 ([`super::gpu::GpuHyperBody`]
/// refuses other elements).
const NODES: usize = 8;

/// Workgroup size of the kernel (`@workgroup_size(64)`).
pub const WORKGROUP: u32 = 64;
/// `inside_index` of a cell that is not inside.
pub const NOT_INSIDE: u32 = u32::MAX;
/// Reals per Gauss point in `consts`: 24 gradients and the weight.
pub const RULE_STRIDE: usize = 25;
/// Reals per inside point in `state`: Σ, M, G (row-major) and c.
pub const STATE_STRIDE: usize = 28;

/// Params of `hyper_tangent`: active nodes, 2D row stride, cells per axis.
/// Keep in sync with `HyperTangentParams` in shaders/hyper_tangent.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct HyperTangentParams {
    pub n_active: u32,
    pub stride: u32,
    pub ncx: u32,
    pub ncy: u32,
    pub ncz: u32,
    pub pad0: u32,
    pub pad1: u32,
    pub pad2: u32,
}

impl HyperTangentParams {
    /// The params of `problem` with row stride `stride` (invocations per
    /// row of a 2D dispatch).
    pub fn new(problem: &HyperProblem, stride: u32) -> HyperTangentParams {
        HyperTangentParams {
            n_active: problem.dofs.num_active() as u32,
            stride,
            ncx: problem.grid.n[0] as u32,
            ncy: problem.grid.n[1] as u32,
            ncz: problem.grid.n[2] as u32,
            ..Default::default()
        }
    }
}

/// What the kernel reads besides `x`, for one tangent.
#[derive(Clone, Debug, PartialEq)]
pub struct InsideTangentData {
    /// Per grid cell: its index among the inside cells, or [`NOT_INSIDE`].
    pub inside_index: Vec<u32>,
    /// The shared inside rule (8 × [`RULE_STRIDE`]), then `λ`.
    pub consts: Vec<f64>,
    /// Per inside cell and point, [`STATE_STRIDE`] coefficients.
    pub state: Vec<f64>,
}

impl InsideTangentData {
    /// The inside cells' data of `tangent`.
    pub fn new(tangent: &TangentOperator<'_>) -> InsideTangentData {
        let p = tangent.problem;
        let mut inside_index = vec![NOT_INSIDE; p.grid.num_cells()];
        let mut consts = Vec::with_capacity(8 * RULE_STRIDE + 1);
        for q in p.inside_rule.range(0..p.inside_rule.len()) {
            consts.extend(q.grads.iter().flatten());
            consts.push(q.w);
        }
        consts.push(p.material.lambda);
        let mut state = Vec::new();
        let mut count = 0u32;
        for (k, &cell) in p.cells.iter().enumerate() {
            if p.cut_index[k].is_some() {
                continue;
            }
            inside_index[cell] = count;
            count += 1;
            for s in tangent.cell_states(k) {
                let c = p.material.tangent_coefficients(s);
                for m in [&c.sigma, &c.m, &c.g] {
                    for i in 0..3 {
                        for j in 0..3 {
                            state.push(m[(i, j)]);
                        }
                    }
                }
                state.push(c.c);
            }
        }
        InsideTangentData {
            inside_index,
            consts,
            state,
        }
    }
}

/// CPU mirror of `hyper_tangent.wgsl`: `y = K_T x` over the inside cells,
/// gathered per active node (see the shader's header).
#[allow(clippy::too_many_arguments)]
pub fn hyper_tangent(
    prm: &HyperTangentParams,
    active_to_node: &[u32],
    node_to_active: &[u32],
    inside_index: &[u32],
    consts: &[f64],
    state: &[f64],
    x: &[f64],
    y: &mut [f64],
) {
    let n = prm.n_active as usize;
    y[..3 * n]
        .par_chunks_mut(3)
        .enumerate()
        .for_each(|(a, ya)| {
            let (m0, m1) = (prm.ncx as usize + 1, prm.ncy as usize + 1);
            let node = active_to_node[a] as usize;
            let (ni, nj, nk) = (node % m0, (node / m0) % m1, node / (m0 * m1));
            let lambda = consts[8 * RULE_STRIDE];
            let mut acc = [0.0; 3];
            for corner in 0..8 {
                let (cx, cy, cz) = (corner & 1, (corner >> 1) & 1, corner >> 2);
                if ni + cx == 0 || nj + cy == 0 || nk + cz == 0 {
                    continue;
                }
                let (ci, cj, ck) = (ni + cx - 1, nj + cy - 1, nk + cz - 1);
                let nc = [prm.ncx, prm.ncy, prm.ncz].map(|v| v as usize);
                if ci >= nc[0] || cj >= nc[1] || ck >= nc[2] {
                    continue;
                }
                let s = inside_index[ci + nc[0] * (cj + nc[1] * ck)];
                if s == NOT_INSIDE {
                    continue;
                }
                let l = (1 - cx) + 2 * ((1 - cy) + 2 * (1 - cz));
                let mut xe = [0.0; 3 * NODES];
                for b in 0..NODES {
                    let nb = (ci + (b & 1)) + m0 * ((cj + ((b >> 1) & 1)) + m1 * (ck + (b >> 2)));
                    let an = node_to_active[nb] as usize;
                    xe[3 * b..3 * b + 3].copy_from_slice(&x[3 * an..3 * an + 3]);
                }
                for q in 0..8 {
                    let r = &consts[q * RULE_STRIDE..(q + 1) * RULE_STRIDE];
                    let st = &state[(s as usize * 8 + q) * STATE_STRIDE..][..STATE_STRIDE];
                    point_row(r, st, lambda, &xe, l, &mut acc);
                }
            }
            ya.copy_from_slice(&acc);
        });
}

/// One point's `w Σ_J dP[i][J] ∂N_l/∂X_J`, added to `acc` (the shader's
/// loop body over `q`).
fn point_row(r: &[f64], st: &[f64], lambda: f64, xe: &[f64], l: usize, acc: &mut [f64; 3]) {
    let mut gx = [0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            let mut v = 0.0;
            for b in 0..NODES {
                v += xe[3 * b + i] * r[3 * b + j];
            }
            gx[3 * i + j] = v;
        }
    }
    let mut g_gx = 0.0;
    for k in 0..9 {
        g_gx += st[18 + k] * gx[k];
    }
    let (c, w) = (st[27], r[24]);
    for i in 0..3 {
        let mut row = 0.0;
        for j in 0..3 {
            let mut dp = lambda * g_gx * st[18 + 3 * i + j];
            for k in 0..3 {
                dp += gx[3 * i + k] * st[3 * k + j];
                dp += st[9 + 3 * i + k] * gx[3 * k + j];
                for m in 0..3 {
                    dp += c * st[18 + 3 * i + k] * gx[3 * m + k] * st[18 + 3 * m + j];
                }
            }
            row += dp * r[3 * l + j];
        }
        acc[i] += w * row;
    }
}

#[cfg(test)]
#[path = "mirror_tests.rs"]
mod tests;
