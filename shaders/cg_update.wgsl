// cg_update: CG's vector step and the first pass of its two dot products in
// one sweep: x = x + α p, r = r + (−α) q (α = scal[ia], −α = scal[ib]),
// z = d ∘ r with a preconditioner (precond = 1; else z is r and not written),
// then (r · r, r · z) reduced per workgroup exactly like `dot2`:
// partials[g] and partials[groups + g]. It replaces axpy, axpy, pointwise_mul
// and dot2's pass over one window.
// CPU mirror: `cgfem_gpu::gpu::mirror::cg_update` (same name, same binding order).
// Written for `real = f64`; the host swaps the alias line to build the f32 twin.
alias real = f64;

// Keep in sync with `UpdateParams` and `WG`, `PER` in src/gpu/kernels.rs.
struct UpdateParams { n: u32, groups: u32, ia: u32, ib: u32, precond: u32, pad0: u32, pad1: u32, pad2: u32 }
const WG: u32 = 256u;
const PER: u32 = 8u;
@group(0) @binding(0) var<uniform> prm: UpdateParams;
@group(0) @binding(1) var<storage, read> scal: array<real>;
@group(0) @binding(2) var<storage, read> p: array<real>;
@group(0) @binding(3) var<storage, read> q: array<real>;
@group(0) @binding(4) var<storage, read> d: array<real>;
@group(0) @binding(5) var<storage, read_write> x: array<real>;
@group(0) @binding(6) var<storage, read_write> r: array<real>;
@group(0) @binding(7) var<storage, read_write> z: array<real>;
@group(0) @binding(8) var<storage, read_write> partials: array<real>;

var<workgroup> sy: array<real, 256>;
var<workgroup> sz: array<real, 256>;

@compute @workgroup_size(256)
fn main(
    @builtin(local_invocation_index) t: u32,
    @builtin(workgroup_id) w: vec3<u32>,
    @builtin(num_workgroups) nw: vec3<u32>,
) {
    let group = w.x + w.y * nw.x;
    if (group >= prm.groups) { return; }
    let base = group * WG * PER;
    let alpha = scal[prm.ia];
    let nalpha = scal[prm.ib];
    var a: real = 0.0;
    var b: real = 0.0;
    for (var j = 0u; j < PER; j++) {
        let i = base + j * WG + t;
        if (i < prm.n) {
            x[i] = x[i] + alpha * p[i];
            let ri = r[i] + nalpha * q[i];
            r[i] = ri;
            var zi = ri;
            if (prm.precond == 1u) {
                zi = d[i] * ri;
                z[i] = zi;
            }
            a += ri * ri;
            b += ri * zi;
        }
    }
    sy[t] = a;
    sz[t] = b;
    workgroupBarrier();
    for (var k = WG / 2u; k > 0u; k = k / 2u) {
        if (t < k) {
            sy[t] = sy[t] + sy[t + k];
            sz[t] = sz[t] + sz[t + k];
        }
        workgroupBarrier();
    }
    if (t == 0u) {
        partials[group] = sy[0];
        partials[prm.groups + group] = sz[0];
    }
}
