// cgs_update_qu: q = u − α v, then u = u + q; α = scal[ia]
// CPU mirror: `cgfem_gpu::gpu::mirror::cgs_update_qu` (same name, same binding order).
// Every kernel is written for `real = f64`; the host swaps the alias line for
// `alias real = f32;` to build the f32 twin. One invocation per entry, 2D
// dispatch: entry = gid.x + gid.y * stride.
alias real = f64;

// Keep in sync with `VecParams` in src/gpu/kernels.rs.
struct VecParams { n: u32, ia: u32, ib: u32, stride: u32 }
@group(0) @binding(0) var<uniform> prm: VecParams;
@group(0) @binding(1) var<storage, read> scal: array<real>;
@group(0) @binding(2) var<storage, read> v: array<real>;
@group(0) @binding(3) var<storage, read_write> q: array<real>;
@group(0) @binding(4) var<storage, read_write> u: array<real>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x + g.y * prm.stride;
    if (i >= prm.n) { return; }
    let qi = u[i] - scal[prm.ia] * v[i];
    q[i] = qi;
    u[i] = u[i] + qi;
}
