// krylov_check: one invocation, after an iteration's reductions. Unless done:
// count the iteration (scal[iters] += 1) and mark done (done = 1) when
// ‖r‖² = scal[num] ≤ scal[tol2]; with early = 1 (BiCGStab's half step, ‖s‖²)
// count it only when it marks done. A non-finite ‖r‖² is the host's to catch
// when it reads the slots back (drivers may compile NaN/∞ tests away).
// CPU mirror: `cgfem_gpu::gpu::mirror_krylov::krylov_check` (same name, same binding order).
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
    if (scal[prm.done] != 0.0) { return; }
    let met = scal[prm.num] <= scal[prm.tol2];
    if (prm.early == 0u || met) {
        scal[prm.iters] = scal[prm.iters] + 1.0;
    }
    if (met) {
        scal[prm.done] = 1.0;
    }
}
