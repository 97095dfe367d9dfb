// dense_matvec: y = A x with A dense, n × n, symmetric (the coarsest level's
// inverse), stored row-major: invocation i sums A[j n + i] x[j] over j, so
// neighbouring invocations read neighbouring entries.
// CPU mirror: `cgfem_gpu::gpu::mirror::dense_matvec` (same name, same binding order).
// One invocation per row, 2D dispatch: i = gid.x + gid.y * stride.
alias real = f64;

// Keep in sync with `GatherParams` in src/gpu/kernels.rs.
struct GatherParams { n: u32, stride: u32, fx: u32, fy: u32, fz: u32, cx: u32, cy: u32, cz: u32 }
@group(0) @binding(0) var<uniform> prm: GatherParams;
@group(0) @binding(1) var<storage, read> a: array<real>;
@group(0) @binding(2) var<storage, read> x: array<real>;
@group(0) @binding(3) var<storage, read_write> y: array<real>;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x + g.y * prm.stride;
    if (i >= prm.n) { return; }
    var acc: real = 0.0;
    for (var j = 0u; j < prm.n; j = j + 1u) {
        acc = acc + a[j * prm.n + i] * x[j];
    }
    y[i] = acc;
}
