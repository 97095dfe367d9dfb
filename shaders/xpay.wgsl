// xpay: y = x + a y, a = scal[ia]
// CPU mirror: `cgfem_gpu::gpu::mirror::xpay` (same name, same binding order).
// Every kernel is written for `real = f64`; the host swaps the alias line for
// `alias real = f32;` to build the f32 twin. One invocation per entry, 2D
// dispatch: entry = gid.x + gid.y * stride.
alias real = f64;

// Keep in sync with `VecParams` in src/gpu/kernels.rs.
struct VecParams { n: u32, ia: u32, ib: u32, stride: u32 }
@group(0) @binding(0) var<uniform> prm: VecParams;
@group(0) @binding(1) var<storage, read> scal: array<real>;
@group(0) @binding(2) var<storage, read> x: array<real>;
@group(0) @binding(3) var<storage, read_write> y: array<real>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x + g.y * prm.stride;
    if (i >= prm.n) { return; }
    y[i] = x[i] + scal[prm.ia] * y[i];
}
