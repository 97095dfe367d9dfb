// block_rows: z[dofs[k]] = Σ_j inv_b[row, j] r[dofs[s_b + j]] for every entry k
// of the cut-band blocks (block b = block_of[k], its entries from s_b =
// starts[b], row = k − s_b, its inverse row-major from inv_starts[b]).
// CPU mirror: `cgfem_gpu::gpu::mirror::block_rows` (same name, same binding order).
// The block part of the smoother's B⁻¹ (src/multigrid/blocks.rs); the point
// part is `pointwise_mul` before it, which leaves 0 on the blocks' entries.
// Blocks do not overlap: each invocation writes its own entry, no atomics.
// One invocation per block entry, 2D dispatch: k = gid.x + gid.y * stride.
alias real = f64;

// Keep in sync with `GatherParams` in src/gpu/kernels.rs.
struct GatherParams { n: u32, stride: u32, fx: u32, fy: u32, fz: u32, cx: u32, cy: u32, cz: u32 }
@group(0) @binding(0) var<uniform> prm: GatherParams;
@group(0) @binding(1) var<storage, read> r: array<real>;
@group(0) @binding(2) var<storage, read_write> z: array<real>;
@group(0) @binding(3) var<storage, read> dofs: array<u32>;
@group(0) @binding(4) var<storage, read> block_of: array<u32>;
@group(0) @binding(5) var<storage, read> starts: array<u32>;
@group(0) @binding(6) var<storage, read> inv_starts: array<u32>;
@group(0) @binding(7) var<storage, read> inverses: array<real>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
    let k = g.x + g.y * prm.stride;
    if (k >= prm.n) { return; }
    let b = block_of[k];
    let s = starts[b];
    let m = starts[b + 1u] - s;
    let row = inv_starts[b] + (k - s) * m;
    var acc: real = 0.0;
    for (var j = 0u; j < m; j = j + 1u) {
        acc = acc + inverses[row + j] * r[dofs[s + j]];
    }
    z[dofs[k]] = acc;
}
