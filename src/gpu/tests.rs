//! Tests that need no GPU: every shader parses and validates with naga (f64
//! with the FLOAT64 capability, and its f32 twin without), the params structs
//! have the layout WGSL gives them, and the mirrors agree with the host code
//! they mirror (the CPU backend, the host operator).

use std::mem::{offset_of, size_of};

use naga::valid::{Capabilities, ValidationFlags, Validator};

use super::context::Precision;
use super::kernels::{
    grid_2d, reduction_groups, ApplyParams, DirectionParams, GatherParams, Kernel, Q1Params,
    RedParams, ScalParams, UpdateParams, VecParams, ALIAS_F64, DOT_LINE,
};
use super::mirror;
use super::mirror_krylov;
use super::q1_terms::SEG;
use crate::hyper::mirror::HyperTangentParams;

fn validate(kernel: Kernel, precision: Precision) -> naga::Module {
    let src = kernel.source(precision);
    let module = naga::front::wgsl::parse_str(&src)
        .unwrap_or_else(|e| panic!("{}: {}", kernel.name(), e.emit_to_string(&src)));
    let caps = match precision {
        Precision::F64 => Capabilities::FLOAT64,
        Precision::F32 => Capabilities::empty(),
    };
    Validator::new(ValidationFlags::all(), caps)
        .validate(&module)
        .unwrap_or_else(|e| panic!("{} ({precision}): {e:?}", kernel.name()));
    module
}

#[test]
fn every_shader_file_is_a_kernel_and_validates_in_both_precisions() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");
    let mut files: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter_map(|f| f.strip_suffix(".wgsl").map(str::to_string))
        .collect();
    files.sort();
    let mut names: Vec<String> = Kernel::ALL.iter().map(|k| k.name().to_string()).collect();
    names.sort();
    // `q1_nodes` is two kernels: the plain one and its dot variant.
    names.dedup();
    assert_eq!(Kernel::Q1Nodes.source_f64().matches(DOT_LINE).count(), 1);
    assert!(!Kernel::Q1NodesDot.source(Precision::F64).contains(DOT_LINE));
    assert_eq!(files, names, "shaders/*.wgsl and Kernel::ALL differ");
    for k in Kernel::ALL {
        assert_eq!(k.source_f64().matches(ALIAS_F64).count(), 1, "{}", k.name());
        let m = validate(k, Precision::F64);
        assert_eq!(m.entry_points.len(), 1, "{}: one kernel per file", k.name());
        assert_eq!(m.entry_points[0].name, "main");
        validate(k, Precision::F32);
        // The f32 twin validates without FLOAT64; the f64 source does not.
        let without = Validator::new(ValidationFlags::all(), Capabilities::empty()).validate(&m);
        assert!(without.is_err(), "{}: no f64 in the f64 source?", k.name());
    }
}

/// The named WGSL struct's (size, member names and offsets).
fn wgsl_struct(module: &naga::Module, name: &str) -> (u32, Vec<(String, u32)>) {
    for (_, ty) in module.types.iter() {
        if ty.name.as_deref() == Some(name) {
            if let naga::TypeInner::Struct { members, span } = &ty.inner {
                let m = members
                    .iter()
                    .map(|m| (m.name.clone().unwrap(), m.offset))
                    .collect();
                return (*span, m);
            }
        }
    }
    panic!("no struct {name}");
}

macro_rules! rust_layout {
    ($t:ty, $($f:ident),*) => {
        (size_of::<$t>() as u32, vec![$((stringify!($f).to_string(), offset_of!($t, $f) as u32)),*])
    };
}

#[test]
fn params_structs_match_their_wgsl_twins() {
    let vec = rust_layout!(VecParams, n, ia, ib, stride);
    let red = rust_layout!(RedParams, n, out, groups, comps, base, total, pad0, pad1);
    let scal = rust_layout!(
        ScalParams, num, den, out, roll, done, iters, tol2, positive, bad, product, early, pad2
    );
    let apply = rust_layout!(
        ApplyParams,
        n_active,
        stride,
        ncx,
        ncy,
        ncz,
        degree,
        ne,
        own_lo,
        own_hi,
        first,
        x_base,
        lattice_base,
        cell_base,
        pad0,
        pad1,
        pad2
    );
    let q1 =
        rust_layout!(Q1Params, n_segments, n_boundary, n_cut, n_cells, stride, pad0, pad1, pad2);
    let update = rust_layout!(
        UpdateParams,
        n,
        groups,
        ia,
        ib,
        precond,
        terms,
        rho,
        done,
        bad,
        broke,
        base,
        pad0
    );
    let direction = rust_layout!(
        DirectionParams,
        n,
        groups,
        terms,
        base,
        rr,
        rho_old,
        rho_new,
        beta,
        done,
        iters,
        tol2,
        bad,
        broke,
        pad0,
        pad1,
        pad2
    );
    let gather = rust_layout!(GatherParams, n, stride, fx, fy, fz, cx, cy, cz);
    let hyper = rust_layout!(
        HyperTangentParams,
        n_active,
        stride,
        ncx,
        ncy,
        ncz,
        pad0,
        pad1,
        pad2
    );
    for k in Kernel::ALL {
        let m = validate(k, Precision::F64);
        let (name, rust) = match k {
            Kernel::Dot | Kernel::Dot2 | Kernel::Reduce => ("RedParams", &red),
            Kernel::Apply => ("ApplyParams", &apply),
            Kernel::Q1Cells | Kernel::Q1Nodes | Kernel::Q1NodesDot => ("Q1Params", &q1),
            Kernel::CgUpdate => ("UpdateParams", &update),
            Kernel::CgDirection => ("DirectionParams", &direction),
            Kernel::BlockRows
            | Kernel::ProlongAdd
            | Kernel::Restrict
            | Kernel::DenseMatvec
            | Kernel::GatherEntries
            | Kernel::ScatterEntries => ("GatherParams", &gather),
            Kernel::ScalarRatio | Kernel::KrylovCheck => ("ScalParams", &scal),
            Kernel::HyperTangent => ("HyperTangentParams", &hyper),
            _ => ("VecParams", &vec),
        };
        assert_eq!(&wgsl_struct(&m, name), rust, "{}: {name}", k.name());
        // Uniform buffers need 16-byte multiples.
        assert_eq!(rust.0 % 16, 0, "{name}");
    }
}

#[test]
fn dispatch_goes_2d_past_the_per_dimension_limit() {
    assert_eq!(grid_2d(1, 256, 65535), (1, 1, 256));
    assert_eq!(grid_2d(0, 256, 65535), (1, 1, 256));
    let (x, y, stride) = grid_2d(70_000 * 256 + 3, 256, 65535);
    assert_eq!((x, y, stride), (65535, 2, 65535 * 256));
    assert!(x as u64 * y as u64 * 256 >= 70_000 * 256 + 3);
    assert_eq!(reduction_groups(0), 0);
    assert_eq!(reduction_groups(2048), 1);
    assert_eq!(reduction_groups(2049), 2);
}

#[test]
fn reduction_mirrors_sum_like_the_cpu_backend() {
    use crate::backend::{Backend, CpuBackend};
    for n in [0usize, 1, 255, 2049, 20_000] {
        let x: Vec<f64> = (0..n)
            .map(|i| ((i * 7919) % 113) as f64 / 17.0 - 3.0)
            .collect();
        let y: Vec<f64> = (0..n).map(|i| ((i * 104_729) % 97) as f64 / 13.0).collect();
        let groups = reduction_groups(n as u32);
        let prm = RedParams {
            n: n as u32,
            out: 0,
            groups,
            comps: 2,
            total: groups,
            ..Default::default()
        };
        let mut partials = vec![0.0; 2 * groups as usize];
        mirror::dot2(&prm, &x, &y, &x, &mut partials);
        let mut scal = vec![0.0; 2];
        let second = RedParams {
            n: groups,
            out: 0,
            groups: 1,
            comps: 2,
            ..Default::default()
        };
        mirror::reduce(&second, &partials, &mut scal);
        let be = CpuBackend::new();
        let (xy, xx) = be.dot2(&x, &y, &x);
        assert!((scal[0] - xy).abs() <= 1e-12 * xy.abs().max(1.0), "{n}");
        assert!((scal[1] - xx).abs() <= 1e-12 * xx.abs().max(1.0), "{n}");
        let mut p1 = vec![0.0; groups as usize];
        mirror::dot(&RedParams { comps: 1, ..prm }, &x, &y, &mut p1);
        assert_eq!(&p1[..], &partials[..groups as usize], "dot = dot2's first");
    }
}

#[test]
fn apply_mirror_equals_the_host_operator_in_one_or_several_chunks() {
    use crate::backend::LinearOperator;
    use crate::case::Case;
    use crate::driver::setup::Setup;
    // Not held, so no multigrid (its coarsest factor needs a held body).
    let text = "[geometry]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\n\
                [material]\nyoung = 1000.0\npoisson = 0.3\n\
                [solver]\npreconditioner = \"jacobi\"\n";
    let case = Case::from_str("sphere.toml", text).unwrap();
    let setup = Setup::new(&case, Some(3)).unwrap();
    let op = &setup.op;
    let n = op.nrows();
    let x: Vec<f64> = (0..n).map(|i| ((i * 31) % 17) as f64 - 8.0).collect();
    let mut expected = vec![0.0; n];
    op.apply(&x, &mut expected);
    let ne = op.dofs_per_cell();
    let count = op.own_cells().len();
    assert!(count > 3);
    let own_all = op.own_matrices();
    for chunk in [count, count / 3 + 1] {
        let mut y = vec![f64::NAN; n];
        let mut lo = 0;
        while lo < count {
            let hi = (lo + chunk).min(count);
            let prm = ApplyParams {
                n_active: op.dofs.num_active() as u32,
                ncx: op.grid.n[0] as u32,
                ncy: op.grid.n[1] as u32,
                ncz: op.grid.n[2] as u32,
                degree: op.dofs.order.degree() as u32,
                ne: ne as u32,
                own_lo: lo as u32,
                own_hi: hi as u32,
                first: u32::from(lo == 0),
                ..Default::default()
            };
            let own = &own_all[lo * ne * ne..hi * ne * ne];
            let (a2n, n2a) = (&op.dofs.active_to_node, &op.dofs.node_to_active);
            let k_in = op.inside_matrix();
            mirror::apply(&prm, a2n, n2a, op.cell_slots(), k_in, own, &x, &mut y);
            lo = hi;
        }
        let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, b) in y.iter().zip(&expected) {
            assert!((a - b).abs() <= 1e-12 * scale, "chunk {chunk}: {a} vs {b}");
        }
    }
}

/// `cg_update`'s mirror is the four mirrors it replaces (axpy, axpy,
/// pointwise_mul, dot2), bitwise, with and without a diagonal.
#[test]
fn cg_update_mirror_is_the_steps_it_fuses() {
    for n in [1usize, 255, 2049, 4097] {
        let v =
            |k: usize| -> Vec<f64> { (0..n).map(|i| ((i * k) % 13) as f64 / 7.0 - 0.9).collect() };
        let (p, q, d, x, r) = (v(3), v(5), v(7), v(11), v(2));
        let mut scal = [0.375, -0.375];
        let groups = reduction_groups(n as u32);
        for precond in [false, true] {
            let prm = UpdateParams {
                n: n as u32,
                groups,
                ia: 0,
                ib: 1,
                precond: u32::from(precond),
                ..Default::default()
            };
            let (mut fx, mut fr, mut fz) = (x.clone(), r.clone(), vec![0.0; n]);
            let mut fused = vec![0.0; 2 * groups as usize];
            mirror_krylov::cg_update(
                &prm, &mut scal, &p, &q, &d, &mut fx, &mut fr, &mut fz, &mut fused,
            );
            let vp = VecParams {
                n: n as u32,
                ia: 0,
                ib: 0,
                stride: 0,
            };
            let (mut sx, mut sr, mut sz) = (x.clone(), r.clone(), vec![0.0; n]);
            mirror::axpy(&vp, &scal, &p, &mut sx);
            mirror::axpy(&VecParams { ia: 1, ..vp }, &scal, &q, &mut sr);
            if precond {
                mirror::pointwise_mul(&vp, &d, &sr, &mut sz);
            }
            let zr = if precond { &sz } else { &sr };
            let rp = RedParams {
                n: n as u32,
                groups,
                comps: 2,
                total: groups,
                ..Default::default()
            };
            let mut steps = vec![0.0; 2 * groups as usize];
            mirror::dot2(&rp, &sr, &sr, zr, &mut steps);
            assert_eq!((fx, fr), (sx, sr), "n={n}");
            if precond {
                assert_eq!(fz, sz, "n={n}");
            }
            assert_eq!(fused, steps, "n={n} precond={precond}");
        }
    }
}

/// The Q1 plan's two mirrors (`q1_cells`, then `q1_nodes`) on the data
/// the device would get equal the host operator's fast apply: the sphere
/// (S-term on) and the shell octant, whose rollers add partial-mask
/// penalties to its cut cells.
#[test]
fn q1_mirrors_equal_the_host_operator() {
    use super::q1_operator::Q1Arrays;
    use crate::backend::LinearOperator;
    for name in ["sphere", "shell_pressure"] {
        let path = format!("{}/cases/{name}.toml", env!("CARGO_MANIFEST_DIR"));
        let set = ["stabilisation.k2=0.01".to_string()];
        let case = crate::case::Case::from_file_with(std::path::Path::new(&path), &set).unwrap();
        let setup = crate::driver::setup::Setup::new(&case, Some(4)).unwrap();
        let op = &setup.op;
        let n = op.nrows();
        let x: Vec<f64> = (0..n).map(|i| ((i * 31) % 17) as f64 - 8.0).collect();
        let mut expected = vec![0.0; n];
        op.apply(&x, &mut expected);
        let a = Q1Arrays::new(op).expect("a Q1 plan");
        let p = &a.params;
        assert!(p.n_segments > 10 && p.n_boundary > 10 && p.n_cut > 10);
        let mut z = vec![0.0; a.z_len()];
        mirror::q1_cells(p, &a.cell_nodes, &a.partial_of, &a.k_cells, &x, &mut z);
        let mut y = vec![f64::NAN; n];
        let (segs, bnd, links) = (&a.segments, &a.boundary, &a.links);
        let groups = p.n_segments + p.n_boundary.div_ceil(SEG as u32);
        let mut partials = vec![f64::NAN; groups as usize];
        let dot = Some(&mut partials[..]);
        mirror::q1_nodes(p, &a.stencil, segs, bnd, links, &z, &x, &mut y, dot);
        let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, b) in y.iter().zip(&expected) {
            assert!((a - b).abs() <= 1e-12 * scale, "{name}: {a} vs {b}");
        }
        // The partials of `x · y` sum to the dot product of the host's apply.
        let want: f64 = x.iter().zip(&expected).map(|(a, b)| a * b).sum();
        let mag: f64 = x.iter().zip(&expected).map(|(a, b)| (a * b).abs()).sum();
        let got: f64 = partials.iter().sum();
        assert!(
            (got - want).abs() <= 1e-13 * mag,
            "{name}: x·y {got} vs {want}"
        );
    }
}

#[test]
fn scalar_kernels_compute_ratios_and_mark_done() {
    let prm = ScalParams {
        num: 0,
        den: 1,
        out: 2,
        roll: 1,
        done: 4,
        iters: 5,
        tol2: 6,
        bad: 7,
        ..Default::default()
    };
    let mut s = vec![6.0, 3.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
    mirror_krylov::scalar_ratio(&prm, &mut s);
    assert_eq!(&s[..5], &[6.0, 6.0, 2.0, -2.0, 0.0]);
    s[1] = 0.0;
    s[0] = 1.0;
    mirror_krylov::scalar_ratio(&prm, &mut s);
    assert_eq!((s[2], s[4]), (0.0, 2.0), "zero divisor: breakdown");
    assert_eq!(&s[7..], &[1.0, 0.0, 2.0], "recorded (num, den, out)");
    // CG: a negative p·Ap is a breakdown, a negative ratio otherwise is not.
    let positive = ScalParams { positive: 1, ..prm };
    for (flags, den, done) in [
        (prm, -2.0, 0.0),
        (positive, -2.0, 2.0),
        (positive, f64::NAN, 2.0),
    ] {
        let mut s = vec![1.0, den, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
        mirror_krylov::scalar_ratio(&flags, &mut s);
        assert_eq!(s[4], done, "den {den}, positive {}", flags.positive);
    }
    let mut s = vec![0.5, 0.0, 0.0, 0.0, 0.0, 3.0, 1.0];
    mirror_krylov::krylov_check(&prm, &mut s);
    assert_eq!((s[4], s[5]), (1.0, 4.0));
    mirror_krylov::krylov_check(&prm, &mut s);
    assert_eq!(s[5], 4.0, "done: no more counting");
}

/// Only a buffer beyond `max_buffer_size` is refused, with a typed error
/// (exit code 2) naming both sizes; vectors beyond one binding are not.
#[test]
fn only_buffers_beyond_the_largest_buffer_are_refused() {
    let Some(ctx) = crate::gpu::context_or_skip(crate::gpu::PrecisionChoice::Auto) else {
        return;
    };
    let max = ctx.limits.max_buffer_size / ctx.precision.bytes();
    assert!(max > ctx.max_binding_entries());
    assert!(ctx
        .check_vector_len(ctx.max_binding_entries() as usize + 1)
        .is_ok());
    assert!(ctx.check_vector_len(max as usize).is_ok());
    let e = ctx.check_vector_len(max as usize + 1).unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(e.to_string().contains(&format!("{}", max + 1)), "{e}");
}

/// The level-4 sphere of radius 1 (Q1).
fn sphere_setup(level: u32) -> crate::driver::setup::Setup {
    // Not held, so no multigrid (its coarsest factor needs a held body).
    let text = "[geometry]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\n\
                [material]\nyoung = 1000.0\npoisson = 0.3\n\
                [solver]\npreconditioner = \"jacobi\"\n";
    let case = crate::case::Case::from_str("sphere.toml", text).unwrap();
    crate::driver::setup::Setup::new(&case, Some(level)).unwrap()
}

/// Apply windows under a 32 KiB binding: the level-4 sphere splits into
/// several windows that tile the active nodes, start aligned, fit the
/// binding, and the mirror run window by window on the windows' slices
/// equals the host operator. A binding too small for one window's halo is a
/// typed refusal.
#[test]
fn apply_mirror_over_windows_equals_the_host_operator() {
    use super::windows::{apply_windows, BindingLimits, Lattice};
    use crate::backend::LinearOperator;
    let setup = sphere_setup(4);
    let op = &setup.op;
    let n = op.nrows();
    let (a2n, n2a, slots) = (
        &op.dofs.active_to_node,
        &op.dofs.node_to_active,
        op.cell_slots(),
    );
    let limits = BindingLimits {
        max_bytes: 2 * BindingLimits::smallest(),
        align: 256,
    };
    let lattice = Lattice {
        cells: op.grid.n.map(|c| c as u32),
        degree: 1,
    };
    let windows = apply_windows(a2n, lattice, 8, limits).unwrap();
    assert!(windows.len() >= 3, "{} windows", windows.len());
    let x: Vec<f64> = (0..n).map(|i| ((i * 31) % 17) as f64 - 8.0).collect();
    let mut y = vec![f64::NAN; n];
    let own_all = op.own_matrices().to_vec();
    let mut next = 0;
    for w in &windows {
        assert_eq!(w.nodes.start, next, "windows tile the nodes");
        next = w.nodes.end;
        let len = |r: &std::ops::Range<u32>| (r.end - r.start) as u64;
        assert!(24 * len(&w.x).max(len(&w.nodes)) <= limits.max_bytes);
        assert!(4 * len(&w.lattice).max(len(&w.cells)) <= limits.max_bytes);
        for start in [w.nodes.start, w.x.start, w.lattice.start, w.cells.start] {
            assert_eq!(start % 64, 0, "aligned: {w:?}");
        }
        let prm = ApplyParams {
            n_active: len(&w.nodes) as u32,
            ncx: op.grid.n[0] as u32,
            ncy: op.grid.n[1] as u32,
            ncz: op.grid.n[2] as u32,
            degree: 1,
            ne: op.dofs_per_cell() as u32,
            own_hi: op.own_cells().len() as u32,
            first: 1,
            x_base: w.x.start,
            lattice_base: w.lattice.start,
            cell_base: w.cells.start,
            ..Default::default()
        };
        let r = |r: &std::ops::Range<u32>, k: usize| k * r.start as usize..k * r.end as usize;
        mirror::apply(
            &prm,
            &a2n[r(&w.nodes, 1)],
            &n2a[r(&w.lattice, 1)],
            &slots[r(&w.cells, 1)],
            op.inside_matrix(),
            &own_all,
            &x[r(&w.x, 3)],
            &mut y[r(&w.nodes, 3)],
        );
    }
    assert_eq!(next as usize, op.dofs.num_active());
    let mut expected = vec![0.0; n];
    op.apply(&x, &mut expected);
    let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (a, b) in y.iter().zip(&expected) {
        assert!((a - b).abs() <= 1e-12 * scale, "{a} vs {b}");
    }
    let tiny = BindingLimits {
        max_bytes: 2048,
        ..limits
    };
    let e = apply_windows(a2n, lattice, 8, tiny).unwrap_err();
    assert_eq!(e.exit_code(), 2, "{e}");
}

/// Reductions over vector windows (whole reduction chunks, partials at their
/// group offset) give bitwise the unsplit result.
#[test]
fn windowed_reductions_equal_the_unsplit_ones_bitwise() {
    use super::windows::{vector_windows, BindingLimits, REDUCTION_CHUNK};
    let limits = BindingLimits {
        max_bytes: BindingLimits::smallest(),
        align: 256,
    };
    let w = limits.vector_window(8);
    assert_eq!(w as u64, REDUCTION_CHUNK);
    assert_eq!(limits.vector_window(4) as u64, 2 * REDUCTION_CHUNK);
    let n = 3 * w + 777;
    let x: Vec<f64> = (0..n)
        .map(|i| ((i * 7919) % 113) as f64 / 17.0 - 3.0)
        .collect();
    let y: Vec<f64> = (0..n).map(|i| ((i * 104_729) % 97) as f64 / 13.0).collect();
    let total = reduction_groups(n as u32);
    let whole = RedParams {
        n: n as u32,
        groups: total,
        comps: 2,
        total,
        ..Default::default()
    };
    let mut unsplit = vec![0.0; 2 * total as usize];
    mirror::dot2(&whole, &x, &y, &x, &mut unsplit);
    let mut split = vec![f64::NAN; 2 * total as usize];
    let windows: Vec<_> = vector_windows(n, w).collect();
    assert_eq!(windows.len(), 4);
    for r in windows {
        let prm = RedParams {
            n: (r.end - r.start) as u32,
            groups: reduction_groups((r.end - r.start) as u32),
            base: (r.start as u64 / REDUCTION_CHUNK) as u32,
            ..whole
        };
        mirror::dot2(&prm, &x[r.clone()], &y[r.clone()], &x[r], &mut split);
    }
    assert_eq!(split, unsplit);
}

/// `CGFEM_MAX_BINDING_BYTES` lowers the binding size, clamped to the
/// smallest windows accept and to the adapter's; a non-number is a typed
/// error naming the variable.
#[test]
fn the_binding_size_override_is_clamped_and_checked() {
    use super::context::binding_limits;
    use super::windows::BindingLimits;
    let limits = wgpu::Limits {
        max_storage_buffer_binding_size: 128 << 20,
        min_storage_buffer_offset_alignment: 64,
        ..Default::default()
    };
    let max = |v| binding_limits(&limits, v).unwrap().max_bytes;
    assert_eq!(max(None), 128 << 20);
    assert_eq!(max(Some("65536")), 65536);
    assert_eq!(max(Some(" 1 ")), BindingLimits::smallest());
    assert_eq!(max(Some("99999999999")), 128 << 20);
    assert_eq!(binding_limits(&limits, None).unwrap().align, 64);
    let e = binding_limits(&limits, Some("64k")).unwrap_err();
    assert!(e.to_string().contains("CGFEM_MAX_BINDING_BYTES"), "{e}");
}
