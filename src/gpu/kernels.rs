//! The WGSL kernels of `shaders/` as the host sees them: their sources (f64 as
//! written, f32 by swapping the `real` alias), the params structs shared with
//! WGSL, the compiled pipelines of a device, and the dispatch of one kernel.
//!
//! # Dispatch
//! Element-wise kernels run one invocation per entry in workgroups of
//! [`WG`]; more than `max_compute_workgroups_per_dimension` (65535) workgroups
//! go in 2D, `x·stride`-major: entry = `gid.x + gid.y · stride`.

use std::sync::OnceLock;

use bytemuck::{Pod, Zeroable};

use super::context::Precision;

/// Workgroup size of the element-wise and reduction kernels.
/// Keep in sync with `@workgroup_size(256)` and `WG` in the shaders.
pub const WG: u32 = 256;
/// Entries per thread of the first reduction pass (one workgroup reduces
/// `WG · PER` entries). Keep in sync with `PER` in dot.wgsl, dot2.wgsl.
pub const PER: u32 = 8;
/// Workgroup size of `apply`, `q1_cells`, `q1_nodes`. Keep in sync with
/// their shaders.
pub const APPLY_WG: u32 = 64;

/// Params of the element-wise kernels (`copy` … `bicgstab_update_p`): the
/// length, two slots of the device scalars, and the 2D row stride.
/// Keep in sync with `VecParams` in shaders/*.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VecParams {
    pub n: u32,
    pub ia: u32,
    pub ib: u32,
    pub stride: u32,
}

/// Params of `dot`, `dot2` (`n` entries of one window in `groups`
/// workgroups, writing partials `base + g` of each component, `total` apart)
/// and `reduce` (`n` partials per component, `comps` components into slots
/// `out..`). Keep in sync with `RedParams` in dot.wgsl, dot2.wgsl, reduce.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RedParams {
    pub n: u32,
    pub out: u32,
    pub groups: u32,
    pub comps: u32,
    pub base: u32,
    pub total: u32,
    pub pad0: u32,
    pub pad1: u32,
}

/// Params of `apply`: the window's active nodes, grid cells per axis, element
/// degree and dofs per cell, the own-matrix slots `[own_lo, own_hi)` of this
/// pass, `first` (1: the pass that overwrites `y` and adds the inside cells),
/// and the bases of the `x`, `node_to_active` and `slots` windows
/// ([`super::windows`]).
/// Keep in sync with `ApplyParams` in apply.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ApplyParams {
    pub n_active: u32,
    pub stride: u32,
    pub ncx: u32,
    pub ncy: u32,
    pub ncz: u32,
    pub degree: u32,
    pub ne: u32,
    pub own_lo: u32,
    pub own_hi: u32,
    pub first: u32,
    pub x_base: u32,
    pub lattice_base: u32,
    pub cell_base: u32,
    pub pad0: u32,
    pub pad1: u32,
    pub pad2: u32,
}

/// Params of `cg_update`: `n` entries in `groups` workgroups, the slots of
/// α and −α, `precond` (1: `z = d ∘ r`; 0: no preconditioner), and where its
/// partials go (`base`). With `terms > 0` the kernel takes α itself from
/// the `terms` partials of `p · Ap` at the buffer's start and ρ in slot
/// `rho` (and writes it to `ia`, `ib`); the slots `done`, `bad` and `broke`
/// are then those of [`ScalParams`] and the breakdown flag.
/// Keep in sync with `UpdateParams` in cg_update.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct UpdateParams {
    pub n: u32,
    pub groups: u32,
    pub ia: u32,
    pub ib: u32,
    pub precond: u32,
    pub terms: u32,
    pub rho: u32,
    pub done: u32,
    pub bad: u32,
    pub broke: u32,
    pub base: u32,
    pub pad0: u32,
}

/// Params of `cg_direction`: `n` entries in `groups` workgroups; the
/// `terms` pairs of partials `(r · r, r · z)` from `base`; the slots of
/// `‖r‖²` (written), ρ (read) and ρ' (written), β, and those of the check
/// ([`ScalParams`]) with the breakdown flag `broke`.
/// Keep in sync with `DirectionParams` in cg_direction.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DirectionParams {
    pub n: u32,
    pub groups: u32,
    pub terms: u32,
    pub base: u32,
    pub rr: u32,
    pub rho_old: u32,
    pub rho_new: u32,
    pub beta: u32,
    pub done: u32,
    pub iters: u32,
    pub tol2: u32,
    pub bad: u32,
    pub broke: u32,
    pub pad0: u32,
    pub pad1: u32,
    pub pad2: u32,
}

/// Params of `q1_cells` and `q1_nodes`: interior segments, boundary nodes,
/// cut cells, cut + rim cells, and the 2D row stride (in workgroups for
/// `q1_nodes`, invocations for `q1_cells`).
/// Keep in sync with `Q1Params` in q1_cells.wgsl, q1_nodes.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Q1Params {
    pub n_segments: u32,
    pub n_boundary: u32,
    pub n_cut: u32,
    pub n_cells: u32,
    pub stride: u32,
    pub pad0: u32,
    pub pad1: u32,
    pub pad2: u32,
}

/// Params of the gathers (`block_rows`, `prolong_add`, `restrict`,
/// `dense_matvec`, `gather_entries`, `scatter_entries`): `n` invocations,
/// the 2D row stride, and the fine and coarse lattices' nodes per axis (the
/// transfers only).
/// Keep in sync with `GatherParams` in those shaders.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GatherParams {
    pub n: u32,
    pub stride: u32,
    pub fx: u32,
    pub fy: u32,
    pub fz: u32,
    pub cx: u32,
    pub cy: u32,
    pub cz: u32,
}

/// Params of the one-invocation kernels `scalar_ratio`, `krylov_check`: slots
/// and the flags `roll`, `positive`, `product` and `early` (see the shaders).
/// Keep in sync with `ScalParams` in scalar_ratio.wgsl, krylov_check.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ScalParams {
    pub num: u32,
    pub den: u32,
    pub out: u32,
    pub roll: u32,
    pub done: u32,
    pub iters: u32,
    pub tol2: u32,
    pub positive: u32,
    pub bad: u32,
    pub product: u32,
    pub early: u32,
    pub pad2: u32,
}

/// The kernels, one per file of `shaders/`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    Copy,
    Scale,
    Axpy,
    Xpay,
    Axpy2,
    PointwiseMul,
    CgsUpdateUp,
    CgsUpdateQu,
    BicgstabUpdateP,
    CgUpdate,
    CgDirection,
    Dot,
    Dot2,
    Reduce,
    Apply,
    Q1Cells,
    Q1Nodes,
    Q1NodesDot,
    ScalarRatio,
    KrylovCheck,
    ChebyshevUpdate,
    BlockRows,
    ProlongAdd,
    Restrict,
    DenseMatvec,
    HyperTangent,
    GatherEntries,
    ScatterEntries,
}

impl Kernel {
    /// Every kernel, in a fixed order (the pipeline table's).
    pub const ALL: [Kernel; 28] = [
        Kernel::Copy,
        Kernel::Scale,
        Kernel::Axpy,
        Kernel::Xpay,
        Kernel::Axpy2,
        Kernel::PointwiseMul,
        Kernel::CgsUpdateUp,
        Kernel::CgsUpdateQu,
        Kernel::BicgstabUpdateP,
        Kernel::CgUpdate,
        Kernel::CgDirection,
        Kernel::Dot,
        Kernel::Dot2,
        Kernel::Reduce,
        Kernel::Apply,
        Kernel::Q1Cells,
        Kernel::Q1Nodes,
        Kernel::Q1NodesDot,
        Kernel::ScalarRatio,
        Kernel::KrylovCheck,
        Kernel::ChebyshevUpdate,
        Kernel::BlockRows,
        Kernel::ProlongAdd,
        Kernel::Restrict,
        Kernel::DenseMatvec,
        Kernel::HyperTangent,
        Kernel::GatherEntries,
        Kernel::ScatterEntries,
    ];

    /// The file stem in `shaders/` (= the CPU mirror's name).
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Copy => "copy",
            Kernel::Scale => "scale",
            Kernel::Axpy => "axpy",
            Kernel::Xpay => "xpay",
            Kernel::Axpy2 => "axpy2",
            Kernel::PointwiseMul => "pointwise_mul",
            Kernel::CgsUpdateUp => "cgs_update_up",
            Kernel::CgsUpdateQu => "cgs_update_qu",
            Kernel::BicgstabUpdateP => "bicgstab_update_p",
            Kernel::CgUpdate => "cg_update",
            Kernel::CgDirection => "cg_direction",
            Kernel::Dot => "dot",
            Kernel::Dot2 => "dot2",
            Kernel::Reduce => "reduce",
            Kernel::Apply => "apply",
            Kernel::Q1Cells => "q1_cells",
            Kernel::Q1Nodes | Kernel::Q1NodesDot => "q1_nodes",
            Kernel::ScalarRatio => "scalar_ratio",
            Kernel::KrylovCheck => "krylov_check",
            Kernel::ChebyshevUpdate => "chebyshev_update",
            Kernel::BlockRows => "block_rows",
            Kernel::ProlongAdd => "prolong_add",
            Kernel::Restrict => "restrict",
            Kernel::DenseMatvec => "dense_matvec",
            Kernel::HyperTangent => "hyper_tangent",
            Kernel::GatherEntries => "gather_entries",
            Kernel::ScatterEntries => "scatter_entries",
        }
    }

    /// Element-wise kernels whose binding 1 is the device scalars `scal`
    /// (bound whole; the vectors after it are bound as windows).
    pub fn scalars_first(self) -> bool {
        matches!(
            self,
            Kernel::Scale
                | Kernel::Axpy
                | Kernel::Xpay
                | Kernel::Axpy2
                | Kernel::CgsUpdateUp
                | Kernel::CgsUpdateQu
                | Kernel::BicgstabUpdateP
                | Kernel::ChebyshevUpdate
        )
    }

    /// The WGSL source as written (f64).
    pub fn source_f64(self) -> &'static str {
        match self {
            Kernel::Copy => include_str!("../../shaders/copy.wgsl"),
            Kernel::Scale => include_str!("../../shaders/scale.wgsl"),
            Kernel::Axpy => include_str!("../../shaders/axpy.wgsl"),
            Kernel::Xpay => include_str!("../../shaders/xpay.wgsl"),
            Kernel::Axpy2 => include_str!("../../shaders/axpy2.wgsl"),
            Kernel::PointwiseMul => include_str!("../../shaders/pointwise_mul.wgsl"),
            Kernel::CgsUpdateUp => include_str!("../../shaders/cgs_update_up.wgsl"),
            Kernel::CgsUpdateQu => include_str!("../../shaders/cgs_update_qu.wgsl"),
            Kernel::BicgstabUpdateP => include_str!("../../shaders/bicgstab_update_p.wgsl"),
            Kernel::CgUpdate => include_str!("../../shaders/cg_update.wgsl"),
            Kernel::CgDirection => include_str!("../../shaders/cg_direction.wgsl"),
            Kernel::Dot => include_str!("../../shaders/dot.wgsl"),
            Kernel::Dot2 => include_str!("../../shaders/dot2.wgsl"),
            Kernel::Reduce => include_str!("../../shaders/reduce.wgsl"),
            Kernel::Apply => include_str!("../../shaders/apply.wgsl"),
            Kernel::Q1Cells => include_str!("../../shaders/q1_cells.wgsl"),
            Kernel::Q1Nodes | Kernel::Q1NodesDot => include_str!("../../shaders/q1_nodes.wgsl"),
            Kernel::ScalarRatio => include_str!("../../shaders/scalar_ratio.wgsl"),
            Kernel::KrylovCheck => include_str!("../../shaders/krylov_check.wgsl"),
            Kernel::ChebyshevUpdate => include_str!("../../shaders/chebyshev_update.wgsl"),
            Kernel::BlockRows => include_str!("../../shaders/block_rows.wgsl"),
            Kernel::ProlongAdd => include_str!("../../shaders/prolong_add.wgsl"),
            Kernel::Restrict => include_str!("../../shaders/restrict.wgsl"),
            Kernel::DenseMatvec => include_str!("../../shaders/dense_matvec.wgsl"),
            Kernel::HyperTangent => include_str!("../../shaders/hyper_tangent.wgsl"),
            Kernel::GatherEntries => include_str!("../../shaders/gather_entries.wgsl"),
            Kernel::ScatterEntries => include_str!("../../shaders/scatter_entries.wgsl"),
        }
    }

    /// The WGSL source for `precision`, unrolled bodies generated
    /// ([`super::q1_terms::expand`]); `q1_nodes`' dot variant with its
    /// [`DOT_LINE`] swapped.
    pub fn source(self, precision: Precision) -> String {
        let mut src = super::q1_terms::expand(self.source_f64());
        if self == Kernel::Q1NodesDot {
            src = src.replacen(DOT_LINE, "const DOT: bool = true;", 1);
        }
        match precision {
            Precision::F64 => src,
            Precision::F32 => src.replacen(ALIAS_F64, "alias real = f32;", 1),
        }
    }
}

/// The line every shader declares its float type with.
pub const ALIAS_F64: &str = "alias real = f64;";

/// The line of `q1_nodes.wgsl` that [`Kernel::Q1NodesDot`] swaps for `true`
/// (the same kernel, also summing `x · y` per workgroup).
pub const DOT_LINE: &str = "const DOT: bool = false;";

/// Workgroup counts `(x, y)` and the row stride (in invocations) for `n`
/// invocations in workgroups of `wg`, at most `max_dim` per dimension.
pub fn grid_2d(n: u32, wg: u32, max_dim: u32) -> (u32, u32, u32) {
    let groups = n.div_ceil(wg).max(1);
    let x = groups.min(max_dim);
    let y = groups.div_ceil(x);
    (x, y, x * wg)
}

/// Number of first-pass workgroups (= partial sums) of a reduction over `n`.
pub fn reduction_groups(n: u32) -> u32 {
    n.div_ceil(WG * PER)
}

/// The pipelines of one device and precision, with their bind group layouts
/// (fetched once: `get_bind_group_layout` makes a new handle). Each kernel is
/// compiled on its first use, so a run pays only for the kernels it
/// dispatches.
pub struct Pipelines {
    device: wgpu::Device,
    precision: Precision,
    table: Vec<OnceLock<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>>,
}

impl Pipelines {
    /// An empty table for `precision` on `device`.
    pub fn new(device: &wgpu::Device, precision: Precision) -> Self {
        Pipelines {
            device: device.clone(),
            precision,
            table: Kernel::ALL.iter().map(|_| OnceLock::new()).collect(),
        }
    }

    fn compile(&self, kernel: Kernel) -> (wgpu::ComputePipeline, wgpu::BindGroupLayout) {
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(kernel.name()),
                source: wgpu::ShaderSource::Wgsl(kernel.source(self.precision).into()),
            });
        let p = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(kernel.name()),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            });
        let layout = p.get_bind_group_layout(0);
        (p, layout)
    }

    /// The pipeline of `kernel` and its bind group layout.
    pub fn get(&self, kernel: Kernel) -> (&wgpu::ComputePipeline, &wgpu::BindGroupLayout) {
        let i = Kernel::ALL.iter().position(|k| *k == kernel).unwrap();
        let (p, l) = self.table[i].get_or_init(|| self.compile(kernel));
        (p, l)
    }
}
