// chebyshev_update: d = a d + c z, then x = x + d; a = scal[ia], c = scal[ib]
// CPU mirror: `cgfem_gpu::gpu::mirror::chebyshev_update` (same name, same binding order).
// The multigrid smoother's step (src/multigrid/smoother.rs). Written for
// `real = f64`; the host swaps the alias line for the f32 twin. One
// invocation per entry, 2D dispatch: entry = gid.x + gid.y * stride.
alias real = f64;

// Keep in sync with `VecParams` in src/gpu/kernels.rs.
struct VecParams { n: u32, ia: u32, ib: u32, stride: u32 }
@group(0) @binding(0) var<uniform> prm: VecParams;
@group(0) @binding(1) var<storage, read> scal: array<real>;
@group(0) @binding(2) var<storage, read> z: array<real>;
@group(0) @binding(3) var<storage, read_write> d: array<real>;
@group(0) @binding(4) var<storage, read_write> x: array<real>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x + g.y * prm.stride;
    if (i >= prm.n) { return; }
    let di = scal[prm.ia] * d[i] + scal[prm.ib] * z[i];
    d[i] = di;
    x[i] = x[i] + di;
}
