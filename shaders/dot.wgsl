// dot: first pass of x · y. Workgroup g owns the chunk [g·WG·PER, (g+1)·WG·PER); thread t sums entries t, t + WG, … of it in order, then the fixed two-level sum over the threads (threads t < 16 add sh[16t .. 16t + 16) in order, thread 0 adds those 16 in order) gives partials[base + g]. `reduce` finishes. The order depends on n only: reproducible.
// A vector beyond one binding runs in windows of whole chunks (src/gpu/windows.rs): x, y bound from the window's start, base = its first group, so the partials are those of one unsplit run.
// CPU mirror: `cgfem_gpu::gpu::mirror::dot` (same name, same binding order).
// Written for `real = f64`; the host swaps the alias line to build the f32 twin.
alias real = f64;

// Keep in sync with `RedParams` and `WG`, `PER` in src/gpu/kernels.rs.
struct RedParams { n: u32, out: u32, groups: u32, comps: u32, base: u32, total: u32, pad0: u32, pad1: u32 }
const WG: u32 = 256u;
const PER: u32 = 8u;
@group(0) @binding(0) var<uniform> prm: RedParams;
@group(0) @binding(1) var<storage, read> x: array<real>;
@group(0) @binding(2) var<storage, read> y: array<real>;
@group(0) @binding(3) var<storage, read_write> partials: array<real>;

var<workgroup> sh: array<real, 256>;

@compute @workgroup_size(256)
fn main(
    @builtin(local_invocation_index) t: u32,
    @builtin(workgroup_id) w: vec3<u32>,
    @builtin(num_workgroups) nw: vec3<u32>,
) {
    let group = w.x + w.y * nw.x;
    if (group >= prm.groups) { return; }
    let base = group * WG * PER;
    var s: real = 0.0;
    for (var j = 0u; j < PER; j++) {
        let i = base + j * WG + t;
        if (i < prm.n) { s += x[i] * y[i]; }
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
        partials[prm.base + group] = a;
    }
}
