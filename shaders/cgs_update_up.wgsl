// cgs_update_up: u = r + β q, then p = u + β (q + β p); β = scal[ia]
// CPU mirror: `cgfem_gpu::gpu::mirror::cgs_update_up` (same name, same binding order).
// Every kernel is written for `real = f64`; the host swaps the alias line for
// `alias real = f32;` to build the f32 twin. One invocation per entry, 2D
// dispatch: entry = gid.x + gid.y * stride.
alias real = f64;

// Keep in sync with `VecParams` in src/gpu/kernels.rs.
struct VecParams { n: u32, ia: u32, ib: u32, stride: u32 }
@group(0) @binding(0) var<uniform> prm: VecParams;
@group(0) @binding(1) var<storage, read> scal: array<real>;
@group(0) @binding(2) var<storage, read> r: array<real>;
@group(0) @binding(3) var<storage, read> q: array<real>;
@group(0) @binding(4) var<storage, read_write> u: array<real>;
@group(0) @binding(5) var<storage, read_write> p: array<real>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x + g.y * prm.stride;
    if (i >= prm.n) { return; }
    let beta = scal[prm.ia];
    let ui = r[i] + beta * q[i];
    u[i] = ui;
    p[i] = ui + beta * (q[i] + beta * p[i]);
}
