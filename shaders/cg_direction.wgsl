// cg_direction: the end of a fused CG iteration. Every workgroup reduces the
// `terms` pairs of partials that `cg_update` left from `base` (‖r‖² from
// partials[base ..], ρ' = r · z from partials[base + terms ..]; thread t sums
// entries t, t + WG, … in order, then the two-level sum of `dot`, so every
// workgroup gets the same values), takes β = ρ' / ρ (ρ = scal[rho_old]; 0 unless both
// are > 0) and sets p = z + β p over its WG · PER entries (z is r without a
// preconditioner). Workgroup 0 then does what `krylov_check` and
// `scalar_ratio` do on one invocation: scal[rr] = ‖r‖², scal[rho_new] = ρ',
// scal[beta] = β; unless done: a breakdown flagged by `cg_update`
// (scal[broke] ≠ 0) sets done = 2; else the iteration is counted
// (scal[iters] += 1), done = 1 when ‖r‖² ≤ scal[tol2], and otherwise a ρ' or
// ρ that is not > 0 sets done = 2 with (ρ', ρ, beta) at scal[bad..bad + 3].
// ρ and ρ' alternate between two slots over the iterations, so no workgroup
// reads a slot that another writes.
// CPU mirror: `cgfem_gpu::gpu::mirror_krylov::cg_direction` (same name, same binding order).
// Written for `real = f64`; the host swaps the alias line to build the f32 twin.
alias real = f64;

// Keep in sync with `DirectionParams` and `WG`, `PER` in src/gpu/kernels.rs.
struct DirectionParams {
    n: u32, groups: u32, terms: u32, base: u32, rr: u32, rho_old: u32, rho_new: u32, beta: u32,
    done: u32, iters: u32, tol2: u32, bad: u32, broke: u32, pad0: u32, pad1: u32, pad2: u32,
}
const WG: u32 = 256u;
const PER: u32 = 8u;
@group(0) @binding(0) var<uniform> prm: DirectionParams;
@group(0) @binding(1) var<storage, read_write> scal: array<real>;
@group(0) @binding(2) var<storage, read> partials: array<real>;
@group(0) @binding(3) var<storage, read> z: array<real>;
@group(0) @binding(4) var<storage, read_write> p: array<real>;

var<workgroup> sh: array<real, 256>;

// Σ partials[first .. first + terms) in the fixed order of the header.
fn sum_terms(t: u32, first: u32) -> real {
    var s: real = 0.0;
    for (var i = t; i < prm.terms; i += WG) {
        s += partials[first + i];
    }
    sh[t] = s;
    workgroupBarrier();
    if (t < 16u) {
        var a: real = 0.0;
        for (var j = 0u; j < 16u; j++) { a += sh[16u * t + j]; }
        sh[16u * t] = a;
    }
    workgroupBarrier();
    var total: real = 0.0;
    for (var j = 0u; j < 16u; j++) { total += sh[16u * j]; }
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
    let rr = sum_terms(t, prm.base);
    let rho_new = sum_terms(t, prm.base + prm.terms);
    let rho = scal[prm.rho_old];
    let ok = rho_new > 0.0 && rho > 0.0;
    var beta: real = 0.0;
    if (ok) { beta = rho_new / rho; }
    let base = group * WG * PER;
    for (var j = 0u; j < PER; j++) {
        let i = base + j * WG + t;
        if (i < prm.n) {
            p[i] = z[i] + beta * p[i];
        }
    }
    if (group == 0u && t == 0u) {
        scal[prm.rr] = rr;
        scal[prm.rho_new] = rho_new;
        scal[prm.beta] = beta;
        if (scal[prm.done] == 0.0) {
            if (scal[prm.broke] != 0.0) {
                scal[prm.done] = 2.0;
            } else {
                scal[prm.iters] = scal[prm.iters] + 1.0;
                if (rr <= scal[prm.tol2]) {
                    scal[prm.done] = 1.0;
                } else if (!ok) {
                    scal[prm.done] = 2.0;
                    scal[prm.bad] = rho_new;
                    scal[prm.bad + 1u] = rho;
                    scal[prm.bad + 2u] = real(prm.beta);
                }
            }
        }
    }
}
