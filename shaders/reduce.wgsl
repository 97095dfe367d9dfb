// reduce: second pass of `dot`/`dot2`, one workgroup: for each of the `comps` components c, thread t sums partials[c·n + t + WG·j] over j in order, the two-level sum of `dot` over the threads gives scal[out + c].
// CPU mirror: `cgfem_gpu::gpu::mirror::reduce` (same name, same binding order).
// Written for `real = f64`; the host swaps the alias line to build the f32 twin.
alias real = f64;

// Keep in sync with `RedParams` and `WG`, `PER` in src/gpu/kernels.rs.
struct RedParams { n: u32, out: u32, groups: u32, comps: u32, base: u32, total: u32, pad0: u32, pad1: u32 }
const WG: u32 = 256u;
const PER: u32 = 8u;
@group(0) @binding(0) var<uniform> prm: RedParams;
@group(0) @binding(1) var<storage, read> partials: array<real>;
@group(0) @binding(2) var<storage, read_write> scal: array<real>;

var<workgroup> sh: array<real, 256>;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) t: u32) {
    for (var c = 0u; c < prm.comps; c++) {
        var s: real = 0.0;
        for (var i = t; i < prm.n; i += WG) {
            s += partials[c * prm.n + i];
        }
        sh[t] = s;
        workgroupBarrier();
        if (t < 16u) {
            var a: real = 0.0;
            for (var j = 0u; j < 16u; j++) { a += sh[16u * t + j]; }
            sh[16u * t] = a;
        }
        workgroupBarrier();
        if (t == 0u) {
            var a: real = 0.0;
            for (var j = 0u; j < 16u; j++) { a += sh[16u * j]; }
            scal[prm.out + c] = a;
        }
        workgroupBarrier();
    }
}
