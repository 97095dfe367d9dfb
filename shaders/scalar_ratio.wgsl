// scalar_ratio: one invocation. Unless the solve is done (scal[done] ≠ 0):
// q = scal[num] / scal[den]; a zero divisor marks the solve done with a
// breakdown (done = 2) and q = 0. (Non-finite values are caught by the host:
// drivers may compile NaN/∞ tests away.) Then scal[out] = q,
// scal[out + 1] = −q: after done, α = 0 and x, r stay put. With roll = 1 then
// scal[den] = scal[num] (ρ ← ρ' after β = ρ'/ρ).
// CPU mirror: `cgfem_gpu::gpu::mirror::scalar_ratio` (same name, same binding order).
// Written for `real = f64`; the host swaps the alias line to build the f32 twin.
alias real = f64;

// Keep in sync with `ScalParams` in src/gpu/kernels.rs. Fields are slot
// indices into `scal` (the device scalars of a solve), `roll` a flag.
struct ScalParams { num: u32, den: u32, out: u32, roll: u32, done: u32, iters: u32, tol2: u32, pad: u32 }
@group(0) @binding(0) var<uniform> prm: ScalParams;
@group(0) @binding(1) var<storage, read_write> scal: array<real>;

@compute @workgroup_size(1)
fn main() {
    var q: real = 0.0;
    if (scal[prm.done] == 0.0) {
        if (scal[prm.den] == 0.0) {
            scal[prm.done] = 2.0;
        } else {
            q = scal[prm.num] / scal[prm.den];
        }
    }
    scal[prm.out] = q;
    scal[prm.out + 1u] = -q;
    if (prm.roll != 0u) {
        scal[prm.den] = scal[prm.num];
    }
}
