// dot2: first pass of (x · y, x · z) in one sweep over x, each reduced like `dot`; partials[base + g] and partials[total + base + g] (total: the groups of all windows, see dot.wgsl).
// CPU mirror: `cgfem_gpu::gpu::mirror::dot2` (same name, same binding order).
// Written for `real = f64`; the host swaps the alias line to build the f32 twin.
alias real = f64;

// Keep in sync with `RedParams` and `WG`, `PER` in src/gpu/kernels.rs.
struct RedParams { n: u32, out: u32, groups: u32, comps: u32, base: u32, total: u32, pad0: u32, pad1: u32 }
const WG: u32 = 256u;
const PER: u32 = 8u;
@group(0) @binding(0) var<uniform> prm: RedParams;
@group(0) @binding(1) var<storage, read> x: array<real>;
@group(0) @binding(2) var<storage, read> y: array<real>;
@group(0) @binding(3) var<storage, read> z: array<real>;
@group(0) @binding(4) var<storage, read_write> partials: array<real>;

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
    var a: real = 0.0;
    var b: real = 0.0;
    for (var j = 0u; j < PER; j++) {
        let i = base + j * WG + t;
        if (i < prm.n) {
            a += x[i] * y[i];
            b += x[i] * z[i];
        }
    }
    sy[t] = a;
    sz[t] = b;
    workgroupBarrier();
    if (t < 16u) {
        var ay: real = 0.0;
        var az: real = 0.0;
        for (var j = 0u; j < 16u; j++) {
            ay += sy[16u * t + j];
            az += sz[16u * t + j];
        }
        sy[16u * t] = ay;
        sz[16u * t] = az;
    }
    workgroupBarrier();
    if (t == 0u) {
        var ay: real = 0.0;
        var az: real = 0.0;
        for (var j = 0u; j < 16u; j++) {
            ay += sy[16u * j];
            az += sz[16u * j];
        }
        partials[prm.base + group] = ay;
        partials[prm.total + prm.base + group] = az;
    }
}
