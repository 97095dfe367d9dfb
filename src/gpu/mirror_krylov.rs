//! CPU mirrors of the kernels that keep a Krylov solve's scalars on the
//! device (`cg_update`, `cg_direction`, `scalar_ratio`, `krylov_check`), in
//! the manner of [`super::mirror`]: same name, same argument order as the
//! bindings, one loop body per invocation.
// Index loops, not slice methods, to read like the shaders.
#![allow(clippy::needless_range_loop)]

use super::kernels::{DirectionParams, ScalParams, UpdateParams, PER, WG};
use super::mirror::tree;

/// `Σ partials[from + i]` for `i < terms` the way every workgroup of the
/// fused CG kernels sums them: thread `t` takes `i = t, t + WG, …` in order,
/// then the tree.
fn sum_terms(partials: &[f64], from: usize, terms: usize) -> f64 {
    let wg = WG as usize;
    let mut sh = vec![0.0; wg];
    for t in 0..wg {
        let mut s = 0.0;
        let mut i = t;
        while i < terms {
            s += partials[from + i];
            i += wg;
        }
        sh[t] = s;
    }
    tree(&mut sh)
}

/// CG's step and the first pass of its dots: `x += α p`, `r += (−α) q`,
/// `z = d ∘ r` (when `precond`; else `z` is `r`), then `(r · r, r · z)`
/// per workgroup like `dot2`: `partials[base + g]`,
/// `partials[base + groups + g]`. α is `scal[ia]` (−α `scal[ib]`), or with
/// `terms > 0` `ρ / σ` from `ρ = scal[rho]` and `σ` the sum of
/// `partials[..terms]`; then unless done a `ρ` or `σ` not `> 0` records
/// `(ρ, σ, ia)` at `scal[bad..]` and sets `scal[broke] = 1`, and done or
/// broken the vectors stay as they are.
#[allow(clippy::too_many_arguments)]
pub fn cg_update(
    prm: &UpdateParams,
    scal: &mut [f64],
    p: &[f64],
    q: &[f64],
    d: &[f64],
    x: &mut [f64],
    r: &mut [f64],
    z: &mut [f64],
    partials: &mut [f64],
) {
    let (wg, per, groups) = (WG as usize, PER as usize, prm.groups as usize);
    let (mut alpha, mut nalpha) = (scal[prm.ia as usize], scal[prm.ib as usize]);
    let mut step = true;
    if prm.terms > 0 {
        let sigma = sum_terms(partials, 0, prm.terms as usize);
        let rho = scal[prm.rho as usize];
        let done = scal[prm.done as usize] != 0.0;
        let ok = rho > 0.0 && sigma > 0.0;
        step = !done && ok;
        alpha = if step { rho / sigma } else { 0.0 };
        nalpha = -alpha;
        scal[prm.ia as usize] = alpha;
        scal[prm.ib as usize] = nalpha;
        if !done && !ok {
            let bad = prm.bad as usize;
            scal[bad..bad + 3].copy_from_slice(&[rho, sigma, prm.ia as f64]);
            scal[prm.broke as usize] = 1.0;
        }
    }
    let base = prm.base as usize;
    let (mut sy, mut sz) = (vec![0.0; wg], vec![0.0; wg]);
    for g in 0..groups {
        for t in 0..wg {
            let (mut a, mut b) = (0.0, 0.0);
            for j in 0..per {
                let i = g * wg * per + j * wg + t;
                if i < prm.n as usize {
                    let mut ri = r[i];
                    let mut zi = ri;
                    if step {
                        x[i] += alpha * p[i];
                        ri += nalpha * q[i];
                        r[i] = ri;
                        zi = ri;
                        if prm.precond == 1 {
                            zi = d[i] * ri;
                            z[i] = zi;
                        }
                    } else if prm.precond == 1 {
                        zi = z[i];
                    }
                    a += ri * ri;
                    b += ri * zi;
                }
            }
            (sy[t], sz[t]) = (a, b);
        }
        partials[base + g] = tree(&mut sy);
        partials[base + groups + g] = tree(&mut sz);
    }
}

/// The end of a fused CG iteration: `‖r‖²` and `ρ'` summed from the
/// `terms` pairs of partials at `base`, `β = ρ' / ρ` (0 unless both are
/// `> 0`), `p = z + β p`; then `scal[rr]`, `scal[rho_new]`, `scal[beta]`
/// and, unless done, the breakdown flag (done = 2) or the count and the
/// test of `krylov_check` and a `ρ'` or `ρ` not `> 0` (done = 2, `(ρ', ρ,
/// beta)` at `scal[bad..]`).
pub fn cg_direction(
    prm: &DirectionParams,
    scal: &mut [f64],
    partials: &[f64],
    z: &[f64],
    p: &mut [f64],
) {
    let (terms, base) = (prm.terms as usize, prm.base as usize);
    let rr = sum_terms(partials, base, terms);
    let rho_new = sum_terms(partials, base + terms, terms);
    let rho = scal[prm.rho_old as usize];
    let ok = rho_new > 0.0 && rho > 0.0;
    let beta = if ok { rho_new / rho } else { 0.0 };
    for i in 0..prm.n as usize {
        p[i] = z[i] + beta * p[i];
    }
    scal[prm.rr as usize] = rr;
    scal[prm.rho_new as usize] = rho_new;
    scal[prm.beta as usize] = beta;
    let done = prm.done as usize;
    if scal[done] != 0.0 {
        return;
    }
    if scal[prm.broke as usize] != 0.0 {
        scal[done] = 2.0;
        return;
    }
    scal[prm.iters as usize] += 1.0;
    if rr <= scal[prm.tol2 as usize] {
        scal[done] = 1.0;
    } else if !ok {
        scal[done] = 2.0;
        let bad = prm.bad as usize;
        scal[bad..bad + 3].copy_from_slice(&[rho_new, rho, prm.beta as f64]);
    }
}

/// Unless done: `q = scal[num] / scal[den]`; a breakdown (a zero num or den, or
/// with `positive` a `num` or `den` not `> 0`) sets done = 2, q = 0 and
/// `scal[bad..bad + 3] = (num, den, out)`. Then `scal[out] = q`,
/// `scal[out + 1] = −q` (0 once done); with `roll`, `scal[den] = scal[num]`.
/// With `product`, `q = scal[num] · scal[den]` and no breakdown test.
pub fn scalar_ratio(prm: &ScalParams, scal: &mut [f64]) {
    let mut q = 0.0;
    if scal[prm.done as usize] == 0.0 {
        let (num, den) = (scal[prm.num as usize], scal[prm.den as usize]);
        let broken = if prm.positive != 0 {
            !(num > 0.0 && den > 0.0)
        } else {
            num == 0.0 || den == 0.0
        };
        if prm.product != 0 {
            q = num * den;
        } else if broken {
            scal[prm.done as usize] = 2.0;
            let bad = prm.bad as usize;
            scal[bad..bad + 3].copy_from_slice(&[num, den, prm.out as f64]);
        } else {
            q = num / den;
        }
    }
    scal[prm.out as usize] = q;
    scal[prm.out as usize + 1] = -q;
    if prm.roll != 0 {
        scal[prm.den as usize] = scal[prm.num as usize];
    }
}

/// Unless done: count the iteration (with `early`, only when it is the
/// last); done = 1 when `scal[num] ≤ scal[tol2]`.
pub fn krylov_check(prm: &ScalParams, scal: &mut [f64]) {
    if scal[prm.done as usize] != 0.0 {
        return;
    }
    let met = scal[prm.num as usize] <= scal[prm.tol2 as usize];
    if prm.early == 0 || met {
        scal[prm.iters as usize] += 1.0;
    }
    if met {
        scal[prm.done as usize] = 1.0;
    }
}
