//! The multigrid kernels: their mirrors equal the host's steps of the
//! V-cycle (transfers, block Jacobi, Chebyshev update: bitwise; the coarsest
//! inverse: to round-off), each kernel equals its mirror on the device (f64
//! to 1e-12, f32 to 1e-5 relative), and one V-cycle on the device equals the
//! CPU's. Device tests skip without an adapter unless `CI=true`.

use super::backend::GpuBackend;
use super::context::{GpuContext, Precision, PrecisionChoice};
use super::kernels::{GatherParams, VecParams};
use super::mirror::pointwise_mul;
use super::mirror_multigrid as mm;
use super::multigrid::{dense_inverse, BlockArrays, DeviceMultigrid};
use super::operator::GpuOperator;
use crate::backend::{Backend, LinearOperator};
use crate::driver::setup::Setup;
use crate::fem::operator::ElasticOperator;
use crate::multigrid::cycle::{CycleOps, Multigrid};
use crate::multigrid::smoother::{chebyshev_coefficients, chebyshev_update};
use crate::multigrid::tests::{scrambled, sphere};
use crate::multigrid::Hierarchy;
use crate::solver::ApplyInverse;

/// The Q1 sphere at level 4 (with the S-term) and the Q2 sphere at level 3:
/// an h-step and a p-step between their levels.
fn setups() -> Vec<Setup> {
    [("q1", 4), ("q2", 3)]
        .into_iter()
        .map(|(element, level)| Setup::new(&sphere(element, 0.01), Some(level)).unwrap())
        .collect()
}

fn hierarchy(setup: &Setup) -> &Hierarchy {
    setup.multigrid.as_ref().expect("auto builds the hierarchy")
}

/// The params of the transfer between `f` and `c` over `n` invocations.
fn transfer_params(f: &ElasticOperator, c: &ElasticOperator, n: usize) -> GatherParams {
    let d = |op: &ElasticOperator| op.grid.nodes_per_axis(op.dofs.order).map(|x| x as u32);
    let (fd, cd) = (d(f), d(c));
    GatherParams {
        n: n as u32,
        stride: 0,
        fx: fd[0],
        fy: fd[1],
        fz: fd[2],
        cx: cd[0],
        cy: cd[1],
        cz: cd[2],
    }
}

/// `B⁻¹ r` of level `i`'s smoother by the mirrors (`pointwise_mul`, then
/// `block_rows`), with its inverses as `inverses` (rounded as the device).
fn mirror_precondition(
    h: &Hierarchy,
    i: usize,
    inverses: &[f64],
    point: &[f64],
    r: &[f64],
) -> Vec<f64> {
    let pre = &h.smoothers[i].pre;
    let n = r.len();
    let mut z = vec![0.0; n];
    let vp = VecParams {
        n: n as u32,
        ..Default::default()
    };
    pointwise_mul(&vp, point, r, &mut z);
    let a = BlockArrays::new(pre);
    let gp = GatherParams {
        n: a.dofs.len() as u32,
        ..Default::default()
    };
    mm::block_rows(
        &gp,
        r,
        &mut z,
        &a.dofs,
        &a.block_of,
        &a.starts,
        &a.inv_starts,
        inverses,
    );
    z
}

#[test]
fn multigrid_mirrors_equal_the_host_cycle_steps() {
    for setup in setups() {
        let (fine, h) = (&setup.op, hierarchy(&setup));
        for i in 0..h.num_levels() - 1 {
            let (f, c) = (h.level(fine, i), h.level(fine, i + 1));
            let t = h.transfer(fine, i);
            let xc = scrambled(c.nrows(), 1);
            let mut want = scrambled(f.nrows(), 2);
            let mut got = want.clone();
            t.prolong_add(&xc, &mut want);
            let prm = transfer_params(f, c, f.dofs.num_active());
            let (fa, cn) = (&f.dofs.active_to_node, &c.dofs.node_to_active);
            mm::prolong_add(&prm, &xc, &mut got, fa, cn);
            assert_eq!(got, want, "level {i}: prolong_add");

            let xf = scrambled(f.nrows(), 3);
            let (mut want, mut got) = (vec![0.0; c.nrows()], vec![0.0; c.nrows()]);
            t.restrict(&xf, &mut want);
            let prm = transfer_params(f, c, c.dofs.num_active());
            let (ca, fn_) = (&c.dofs.active_to_node, &f.dofs.node_to_active);
            mm::restrict(&prm, &xf, &mut got, ca, fn_);
            assert_eq!(got, want, "level {i}: restrict");

            let pre = &h.smoothers[i].pre;
            let r = scrambled(f.nrows(), 4);
            let mut want = vec![0.0; f.nrows()];
            pre.apply(&r, &mut want);
            let got = mirror_precondition(h, i, &pre.inverses, &pre.point, &r);
            assert_eq!(got, want, "level {i}: block Jacobi");

            let (z, mut d, mut x) = (scrambled(f.nrows(), 5), scrambled(f.nrows(), 6), r);
            let (mut d2, mut x2) = (d.clone(), x.clone());
            chebyshev_update(0.75, 1.5, &z, &mut d, &mut x);
            let vp = VecParams {
                n: f.nrows() as u32,
                ia: 0,
                ib: 1,
                stride: 0,
            };
            mm::chebyshev_update(&vp, &[0.75, 1.5], &z, &mut d2, &mut x2);
            assert_eq!((d2, x2), (d, x), "level {i}: chebyshev_update");
        }
        let n = h.level(fine, h.num_levels() - 1).nrows();
        let b = scrambled(n, 7);
        let mut want = b.clone();
        h.direct.solve_in_place(&mut want);
        let mut got = vec![0.0; n];
        let gp = GatherParams {
            n: n as u32,
            ..Default::default()
        };
        mm::dense_matvec(&gp, &dense_inverse(&h.direct, n), &b, &mut got);
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = got
            .iter()
            .zip(&want)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(diff <= 1e-10 * scale, "coarsest: {diff:e} of {scale:e}");
    }
}

/// `max |a − b| ≤ tol · max |b|`.
fn assert_close(what: &str, a: &[f64], b: &[f64], tol: f64) {
    let scale = b.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
    let diff = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(
        diff <= tol * scale,
        "{what}: max difference {diff:e}, scale {scale:e}"
    );
}

/// Values as the device holds them.
fn as_device(ctx: &GpuContext, v: &[f64]) -> Vec<f64> {
    match ctx.precision {
        Precision::F64 => v.to_vec(),
        Precision::F32 => v.iter().map(|&x| x as f32 as f64).collect(),
    }
}

fn kernels_match_their_mirrors(ctx: std::sync::Arc<GpuContext>) {
    let tol = match ctx.precision {
        Precision::F64 => 1e-12,
        Precision::F32 => 1e-5,
    };
    let be = GpuBackend::new(ctx.clone());
    for setup in setups() {
        let (fine, h) = (&setup.op, hierarchy(&setup));
        let gop = GpuOperator::new(&be, fine).unwrap();
        let dm = DeviceMultigrid::new(&be, fine, h).unwrap();
        let cycle = dm.cycle(&be, &gop);
        let dev = |v: &[f64]| as_device(&ctx, v);
        for i in 0..h.num_levels() - 1 {
            let (f, c) = (h.level(fine, i), h.level(fine, i + 1));
            let what = format!("{:?} level {i}", fine.dofs.order);
            let xc = dev(&scrambled(c.nrows(), 1));
            let xf = dev(&scrambled(f.nrows(), 2));
            let mut g = be.upload(&xf);
            cycle.prolong_add(i, &be.upload(&xc), &mut g);
            cycle.flush();
            let mut want = xf.clone();
            let prm = transfer_params(f, c, f.dofs.num_active());
            mm::prolong_add(
                &prm,
                &xc,
                &mut want,
                &f.dofs.active_to_node,
                &c.dofs.node_to_active,
            );
            assert_close(
                &format!("{what}: prolong_add"),
                &be.download(&g),
                &want,
                tol,
            );

            let mut g = be.zeros(c.nrows());
            cycle.restrict(i, &be.upload(&xf), &mut g);
            cycle.flush();
            let mut want = vec![0.0; c.nrows()];
            let prm = transfer_params(f, c, c.dofs.num_active());
            mm::restrict(
                &prm,
                &xf,
                &mut want,
                &c.dofs.active_to_node,
                &f.dofs.node_to_active,
            );
            assert_close(&format!("{what}: restrict"), &be.download(&g), &want, tol);

            let pre = &h.smoothers[i].pre;
            let mut g = be.zeros(f.nrows());
            cycle.precondition(i, &be.upload(&xf), &mut g);
            cycle.flush();
            let want = mirror_precondition(h, i, &dev(&pre.inverses), &dev(&pre.point), &xf);
            assert_close(
                &format!("{what}: block Jacobi"),
                &be.download(&g),
                &want,
                tol,
            );

            let (z, d) = (dev(&scrambled(f.nrows(), 3)), dev(&scrambled(f.nrows(), 4)));
            let (mut gd, mut gx) = (be.upload(&d), be.upload(&xf));
            let s = &h.smoothers[i];
            let coef = chebyshev_coefficients(s.lo, s.hi, s.degree)[1];
            cycle.chebyshev_update(i, 1, coef, &be.upload(&z), &mut gd, &mut gx);
            cycle.flush();
            let (a, cc) = (dev(&[coef.0])[0], dev(&[coef.1])[0]);
            let (mut wd, mut wx) = (d, xf);
            let vp = VecParams {
                n: f.nrows() as u32,
                ia: 0,
                ib: 1,
                stride: 0,
            };
            mm::chebyshev_update(&vp, &[a, cc], &z, &mut wd, &mut wx);
            assert_close(
                &format!("{what}: chebyshev_update d"),
                &be.download(&gd),
                &wd,
                tol,
            );
            assert_close(
                &format!("{what}: chebyshev_update x"),
                &be.download(&gx),
                &wx,
                tol,
            );
        }
        let n = h.level(fine, h.num_levels() - 1).nrows();
        let b = dev(&scrambled(n, 5));
        let mut g = be.zeros(n);
        cycle.coarse_solve(&be.upload(&b), &mut g);
        cycle.flush();
        let mut want = vec![0.0; n];
        let gp = GatherParams {
            n: n as u32,
            ..Default::default()
        };
        mm::dense_matvec(&gp, &dev(&dense_inverse(&h.direct, n)), &b, &mut want);
        assert_close("dense_matvec", &be.download(&g), &want, tol);
    }
}

#[test]
fn multigrid_kernels_match_their_mirrors_f64_and_f32() {
    for precision in [PrecisionChoice::F64, PrecisionChoice::F32] {
        if let Some(ctx) = super::context_or_skip(precision) {
            kernels_match_their_mirrors(ctx);
        }
    }
}

/// One V-cycle on the device equals the CPU's (the coarsest solve by the
/// dense inverse against the Cholesky factor: round-off apart), recorded on
/// its first application, replayed on the next to the same vectors (new
/// values in `r`), recorded again for another `z`.
#[test]
fn device_v_cycle_equals_the_cpu_v_cycle() {
    let Some(ctx) = super::context_or_skip(PrecisionChoice::F64) else {
        return;
    };
    let be = GpuBackend::new(ctx);
    for setup in setups() {
        let (fine, h) = (&setup.op, hierarchy(&setup));
        let n = fine.nrows();
        let gop = GpuOperator::new(&be, fine).unwrap();
        let dm = DeviceMultigrid::new(&be, fine, h).unwrap();
        let cycle = dm.cycle(&be, &gop);
        let (mut rv, mut z, mut other) = (be.zeros(n), be.zeros(n), be.zeros(n));
        let mut dispatches = Vec::new();
        for (seed, fresh) in [(9, false), (4, false), (7, true)] {
            let r = scrambled(n, seed);
            let mut want = vec![0.0; n];
            Multigrid::new(fine, h).apply(&r, &mut want);
            be.copy(&be.upload(&r), &mut rv);
            let out = if fresh { &mut other } else { &mut z };
            let before = be.dispatches();
            cycle.apply_inverse(&rv, out);
            dispatches.push(be.dispatches() - before);
            let what = format!("V-cycle, r from seed {seed}, new z: {fresh}");
            assert_close(&what, &be.download(out), &want, 1e-11);
        }
        assert!(
            dispatches.iter().all(|&d| d == dispatches[0]),
            "{dispatches:?}"
        );
    }
}

/// A hierarchy whose level vectors exceed one storage binding: refused
/// ([`crate::error::Error::DeviceTooSmall`]), or, where the case said
/// `"auto"`, the solver without it and the error beside it for the note.
#[test]
fn a_hierarchy_beyond_one_binding_is_refused_or_left_to_jacobi() {
    use super::linear::{GpuSolver, Scalars};
    use crate::error::Error;
    let Some(ctx) = super::context_or_skip(PrecisionChoice::F64) else {
        return;
    };
    let setup = Setup::new(&sphere("q1", 0.01), Some(4)).unwrap();
    let half_a_vector = 4 * setup.op.nrows() as u64;
    let small = || GpuBackend::with_max_binding_bytes(ctx.clone(), half_a_vector);
    match GpuSolver::for_setup(small(), &setup, Scalars::Device, false) {
        Err(Error::DeviceTooSmall { what }) => {
            assert!(what.contains("exceeds one storage binding"), "{what}")
        }
        Err(e) => panic!("{e}"),
        Ok(_) => panic!("a hierarchy beyond one binding was taken"),
    }
    let (_, note) = GpuSolver::for_setup(small(), &setup, Scalars::Device, true).unwrap();
    assert!(
        matches!(note, Some(Error::DeviceTooSmall { .. })),
        "{note:?}"
    );
    let (_, note) =
        GpuSolver::for_setup(GpuBackend::new(ctx), &setup, Scalars::Device, true).unwrap();
    assert!(note.is_none(), "{note:?}");
}
