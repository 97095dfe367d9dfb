// cg_update: CG's vector step and the first pass of its two dot products in
// one sweep: x = x + α p, r = r + (−α) q, z = d ∘ r with a preconditioner
// (precond = 1; else z is r and not written), then (r · r, r · z) reduced per
// workgroup exactly like `dot2`: partials[base + g] and
// partials[base + groups + g]. It replaces axpy, axpy, pointwise_mul and
// dot2's pass over one window.
// α: with terms = 0, α = scal[ia] and −α = scal[ib]. With terms > 0 every
// workgroup takes α itself (the fused CG iteration, no scalar kernel
// between): σ = p · Ap from partials[0 .. terms) (thread t sums entries
// t, t + WG, … in order, then the two-level sum of `dot`, so every
// workgroup gets the same σ), ρ = scal[rho], α = ρ / σ. Unless the solve is done
// (scal[done] ≠ 0), a ρ or σ that is not > 0 is a breakdown: workgroup 0
// records (ρ, σ, ia) at scal[bad..bad + 3] and sets scal[broke] = 1 (which
// `cg_direction` turns into done = 2). Done or broken, x, r and z stay as
// they are (the dots are still taken). Workgroup 0 writes α, −α to
// scal[ia], scal[ib].
// CPU mirror: `cgfem_gpu::gpu::mirror_krylov::cg_update` (same name, same binding order).
// Written for `real = f64`; the host swaps the alias line to build the f32 twin.
alias real = f64;

// Keep in sync with `UpdateParams` and `WG`, `PER` in src/gpu/kernels.rs.
struct UpdateParams {
    n: u32, groups: u32, ia: u32, ib: u32, precond: u32, terms: u32, rho: u32, done: u32,
    bad: u32, broke: u32, base: u32, pad0: u32,
}
const WG: u32 = 256u;
const PER: u32 = 8u;
@group(0) @binding(0) var<uniform> prm: UpdateParams;
@group(0) @binding(1) var<storage, read_write> scal: array<real>;
@group(0) @binding(2) var<storage, read> p: array<real>;
@group(0) @binding(3) var<storage, read> q: array<real>;
@group(0) @binding(4) var<storage, read> d: array<real>;
@group(0) @binding(5) var<storage, read_write> x: array<real>;
@group(0) @binding(6) var<storage, read_write> r: array<real>;
@group(0) @binding(7) var<storage, read_write> z: array<real>;
@group(0) @binding(8) var<storage, read_write> partials: array<real>;

var<workgroup> sy: array<real, 256>;
var<workgroup> sz: array<real, 256>;

// Σ partials[0 .. terms) in the fixed order of the header (every thread
// gets it).
fn sum_terms(t: u32) -> real {
    var s: real = 0.0;
    for (var i = t; i < prm.terms; i += WG) {
        s += partials[i];
    }
    sy[t] = s;
    workgroupBarrier();
    if (t < 16u) {
        var a: real = 0.0;
        for (var j = 0u; j < 16u; j++) { a += sy[16u * t + j]; }
        sy[16u * t] = a;
    }
    workgroupBarrier();
    var total: real = 0.0;
    for (var j = 0u; j < 16u; j++) { total += sy[16u * j]; }
    workgroupBarrier();
    return total;
}

@compute @workgroup_size(256)
fn main(
    @builtin(local_invocation_index) t: u32,
    @builtin(workgroup_id) w: vec3<u32>,
    @builtin(num_workgroups) nw: vec3<u32>,
) {
    let group = w.x + w.y * nw.x;
    if (group >= prm.groups) { return; }
    var alpha = scal[prm.ia];
    var nalpha = scal[prm.ib];
    var step = true;
    if (prm.terms > 0u) {
        let sigma = sum_terms(t);
        let rho = scal[prm.rho];
        let done = scal[prm.done] != 0.0;
        let ok = rho > 0.0 && sigma > 0.0;
        step = !done && ok;
        alpha = 0.0;
        if (step) { alpha = rho / sigma; }
        nalpha = -alpha;
        if (group == 0u && t == 0u) {
            scal[prm.ia] = alpha;
            scal[prm.ib] = nalpha;
            if (!done && !ok) {
                scal[prm.bad] = rho;
                scal[prm.bad + 1u] = sigma;
                scal[prm.bad + 2u] = real(prm.ia);
                scal[prm.broke] = 1.0;
            }
        }
    }
    let base = group * WG * PER;
    var a: real = 0.0;
    var b: real = 0.0;
    for (var j = 0u; j < PER; j++) {
        let i = base + j * WG + t;
        if (i < prm.n) {
            var ri = r[i];
            var zi = ri;
            if (step) {
                x[i] = x[i] + alpha * p[i];
                ri = ri + nalpha * q[i];
                r[i] = ri;
                zi = ri;
                if (prm.precond == 1u) {
                    zi = d[i] * ri;
                    z[i] = zi;
                }
            } else if (prm.precond == 1u) {
                zi = z[i];
            }
            a += ri * ri;
            b += ri * zi;
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
        partials[prm.base + prm.groups + group] = az;
    }
}
