// scalar_ratio: one invocation. Unless the solve is done (scal[done] ≠ 0):
// q = scal[num] / scal[den]. A breakdown marks the solve done (done = 2),
// q = 0, and records (num, den, out) at scal[bad], scal[bad + 1],
// scal[bad + 2] for the host's message: a zero num or den (ρ or σ), or with positive = 1
// (CG: r·M⁻¹r and p·Ap) a num or den that is not > 0 (NaN included where the
// driver keeps NaN comparisons; other non-finite values are caught by the
// host, which reads ‖r‖² back). Then scal[out] = q, scal[out + 1] = −q: after
// done, α = 0 and x, r stay put. With roll = 1 then scal[den] = scal[num]
// (ρ ← ρ' after β = ρ'/ρ). With product = 1, q = scal[num] · scal[den]
// instead, with no breakdown test (BiCGStab's β = (ρ/ρ_prev)(α/ω)).
// CPU mirror: `cgfem_gpu::gpu::mirror_krylov::scalar_ratio` (same name, same binding order).
// Written for `real = f64`; the host swaps the alias line to build the f32 twin.
alias real = f64;

// Keep in sync with `ScalParams` in src/gpu/kernels.rs. Fields are slot
// indices into `scal` (the device scalars of a solve); `roll`, `positive`,
// `product` and `early` are flags.
struct ScalParams {
    num: u32, den: u32, out: u32, roll: u32, done: u32, iters: u32, tol2: u32, positive: u32,
    bad: u32, product: u32, early: u32, pad2: u32,
}
@group(0) @binding(0) var<uniform> prm: ScalParams;
@group(0) @binding(1) var<storage, read_write> scal: array<real>;

@compute @workgroup_size(1)
fn main() {
    var q: real = 0.0;
    if (scal[prm.done] == 0.0) {
        let num = scal[prm.num];
        let den = scal[prm.den];
        var broken = num == 0.0 || den == 0.0;
        if (prm.positive != 0u) {
            broken = !(num > 0.0 && den > 0.0);
        }
        if (prm.product != 0u) {
            q = num * den;
        } else if (broken) {
            scal[prm.done] = 2.0;
            scal[prm.bad] = num;
            scal[prm.bad + 1u] = den;
            scal[prm.bad + 2u] = real(prm.out);
        } else {
            q = num / den;
        }
    }
    scal[prm.out] = q;
    scal[prm.out + 1u] = -q;
    if (prm.roll != 0u) {
        scal[prm.den] = scal[prm.num];
    }
}
