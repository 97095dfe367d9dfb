// restrict: xc = Pᵀ xf, the transpose of `prolong_add`: coarse node i gathers
// the fine nodes 2i − 1, 2i, 2i + 1 (per axis, inside the fine lattice) at
// weights 1/2, 1, 1/2, the inactive ones skipped. Overwrites xc.
// CPU mirror: `cgfem_gpu::gpu::mirror::restrict` (same name, same binding order);
// the host's `crate::multigrid::transfer` in the same order of terms.
// One invocation per coarse active node (three components), 2D dispatch:
// a = gid.x + gid.y * stride. A gather: no atomics.
alias real = f64;

// Keep in sync with `GatherParams` in src/gpu/kernels.rs.
struct GatherParams { n: u32, stride: u32, fx: u32, fy: u32, fz: u32, cx: u32, cy: u32, cz: u32 }
@group(0) @binding(0) var<uniform> prm: GatherParams;
@group(0) @binding(1) var<storage, read> xf: array<real>;
@group(0) @binding(2) var<storage, read_write> xc: array<real>;
@group(0) @binding(3) var<storage, read> coarse_active_to_node: array<u32>;
@group(0) @binding(4) var<storage, read> fine_node_to_active: array<u32>;

const INACTIVE: u32 = 0xffffffffu;

// Along one axis of m fine nodes: candidate t (0, 1, 2) of coarse index i is
// fine index 2i − 1 + t (weight 1/2, 1, 1/2), or −1 outside [0, m).
fn candidate(i: u32, t: u32, m: u32) -> i32 {
    let f = i32(2u * i + t) - 1;
    return select(f, -1, f >= i32(m));
}

fn weight(t: u32) -> f32 {
    return select(0.5, 1.0, t == 1u);
}

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
    let a = g.x + g.y * prm.stride;
    if (a >= prm.n) { return; }
    let node = coarse_active_to_node[a];
    let i = node % prm.cx;
    let j = (node / prm.cx) % prm.cy;
    let k = node / (prm.cx * prm.cy);
    var y0: real = 0.0;
    var y1: real = 0.0;
    var y2: real = 0.0;
    for (var tk = 0u; tk < 3u; tk = tk + 1u) {
        let fk = candidate(k, tk, prm.fz);
        if (fk < 0) { continue; }
        for (var tj = 0u; tj < 3u; tj = tj + 1u) {
            let fj = candidate(j, tj, prm.fy);
            if (fj < 0) { continue; }
            for (var ti = 0u; ti < 3u; ti = ti + 1u) {
                let fi = candidate(i, ti, prm.fx);
                if (fi < 0) { continue; }
                let f = fine_node_to_active[u32(fi) + prm.fx * (u32(fj) + prm.fy * u32(fk))];
                if (f == INACTIVE) { continue; }
                let w = real(weight(ti) * weight(tj) * weight(tk));
                y0 = y0 + w * xf[3u * f];
                y1 = y1 + w * xf[3u * f + 1u];
                y2 = y2 + w * xf[3u * f + 2u];
            }
        }
    }
    xc[3u * a] = y0;
    xc[3u * a + 1u] = y1;
    xc[3u * a + 2u] = y2;
}
