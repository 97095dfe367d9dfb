// scatter_entries: v[idx[k]] = values[k] (the ghosts a rank receives,
// uploaded in one small buffer). The indices are distinct: no atomics.
// CPU mirror: `cgfem_gpu::gpu::mirror::scatter_entries` (same name, same binding order).
// One invocation per entry written, 2D dispatch: k = gid.x + gid.y * stride.
alias real = f64;

// Keep in sync with `GatherParams` in src/gpu/kernels.rs.
struct GatherParams { n: u32, stride: u32, fx: u32, fy: u32, fz: u32, cx: u32, cy: u32, cz: u32 }
@group(0) @binding(0) var<uniform> prm: GatherParams;
@group(0) @binding(1) var<storage, read> values: array<real>;
@group(0) @binding(2) var<storage, read_write> v: array<real>;
@group(0) @binding(3) var<storage, read> idx: array<u32>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
    let k = g.x + g.y * prm.stride;
    if (k >= prm.n) { return; }
    v[idx[k]] = values[k];
}
