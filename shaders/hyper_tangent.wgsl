// hyper_tangent: y = K_T x over the INSIDE cells of a hyperelastic body (Q1),
// node-centred gather (one invocation per active node a, no atomics):
//     y[3a + i] = Σ_{inside cells c ∋ node(a)} Σ_q w_q Σ_J dP_q[i][J] ∂N_l/∂X_J(q)
//     dP_q = ∇x Σ + M ∇x + λ (G : ∇x) G + c G ∇xᵀ G,   ∇x = Σ_b x_b ⊗ ∇N_b(q)
// with l the node's local index in c and (Σ, M, G, c) the point's tangent
// coefficients (src/hyper/material.rs, `TangentCoefficients`), evaluated on the
// host at the linearisation point: no logarithm on the device (WGSL has no f64
// transcendentals that every backend accepts). Cut cells and the Dirichlet
// penalty are added on the CPU. y is overwritten.
// Buffers: consts = 8 Gauss points × [24 physical gradients (node-major),
// weight], then λ; state = per inside cell, per point, 28 reals
// [Σ (9, row-major), M (9), G (9), c].
// CPU mirror: `cgfem_gpu::hyper::mirror::hyper_tangent` (same name, same
// binding order). Written for `real = f64`; an f32 twin swaps the alias line.
alias real = f64;

// Keep in sync with `HyperTangentParams` in src/hyper/mirror.rs.
struct HyperTangentParams {
    n_active: u32, stride: u32, ncx: u32, ncy: u32,
    ncz: u32, pad0: u32, pad1: u32, pad2: u32,
}
// Keep in sync with `NOT_INSIDE`, `RULE_STRIDE`, `STATE_STRIDE` in mirror.rs.
const NOT_INSIDE: u32 = 0xffffffffu;
const RULE: u32 = 25u;
const STATE: u32 = 28u;

@group(0) @binding(0) var<uniform> prm: HyperTangentParams;
@group(0) @binding(1) var<storage, read> active_to_node: array<u32>;
@group(0) @binding(2) var<storage, read> node_to_active: array<u32>;
@group(0) @binding(3) var<storage, read> inside_index: array<u32>;
@group(0) @binding(4) var<storage, read> consts: array<real>;
@group(0) @binding(5) var<storage, read> state: array<real>;
@group(0) @binding(6) var<storage, read> x: array<real>;
@group(0) @binding(7) var<storage, read_write> y: array<real>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let a = gid.x + gid.y * prm.stride;
    if (a >= prm.n_active) { return; }
    let m0 = prm.ncx + 1u;
    let m1 = prm.ncy + 1u;
    let node = active_to_node[a];
    let ni = node % m0;
    let nj = (node / m0) % m1;
    let nk = node / (m0 * m1);
    let lambda = consts[8u * RULE];
    var acc = array<real, 3>(0.0, 0.0, 0.0);
    // The cells (ni − 1 + cx, nj − 1 + cy, nk − 1 + cz), cx, cy, cz ∈ {0, 1}.
    for (var corner = 0u; corner < 8u; corner++) {
        let cx = corner & 1u;
        let cy = (corner >> 1u) & 1u;
        let cz = corner >> 2u;
        if (ni + cx == 0u || nj + cy == 0u || nk + cz == 0u) { continue; }
        let ci = ni + cx - 1u;
        let cj = nj + cy - 1u;
        let ck = nk + cz - 1u;
        if (ci >= prm.ncx || cj >= prm.ncy || ck >= prm.ncz) { continue; }
        let s = inside_index[ci + prm.ncx * (cj + prm.ncy * ck)];
        if (s == NOT_INSIDE) { continue; }
        let l = (1u - cx) + 2u * ((1u - cy) + 2u * (1u - cz));
        var xe: array<real, 24>;
        for (var b = 0u; b < 8u; b++) {
            let n = (ci + (b & 1u)) + m0 * ((cj + ((b >> 1u) & 1u)) + m1 * (ck + (b >> 2u)));
            let an = node_to_active[n];
            for (var i = 0u; i < 3u; i++) { xe[3u * b + i] = x[3u * an + i]; }
        }
        for (var q = 0u; q < 8u; q++) {
            let r = q * RULE;
            var gx: array<real, 9>;
            for (var i = 0u; i < 3u; i++) {
                for (var j = 0u; j < 3u; j++) {
                    var v: real = 0.0;
                    for (var b = 0u; b < 8u; b++) { v += xe[3u * b + i] * consts[r + 3u * b + j]; }
                    gx[3u * i + j] = v;
                }
            }
            let st = (s * 8u + q) * STATE;
            var g_gx: real = 0.0;
            for (var k = 0u; k < 9u; k++) { g_gx += state[st + 18u + k] * gx[k]; }
            let c = state[st + 27u];
            let w = consts[r + 24u];
            for (var i = 0u; i < 3u; i++) {
                var row: real = 0.0;
                for (var j = 0u; j < 3u; j++) {
                    var dp: real = lambda * g_gx * state[st + 18u + 3u * i + j];
                    for (var k = 0u; k < 3u; k++) {
                        dp += gx[3u * i + k] * state[st + 3u * k + j];
                        dp += state[st + 9u + 3u * i + k] * gx[3u * k + j];
                        for (var m = 0u; m < 3u; m++) {
                            dp += c * state[st + 18u + 3u * i + k] * gx[3u * m + k]
                                * state[st + 18u + 3u * m + j];
                        }
                    }
                    row += dp * consts[r + 3u * l + j];
                }
                acc[i] += w * row;
            }
        }
    }
    for (var i = 0u; i < 3u; i++) { y[3u * a + i] = acc[i]; }
}
