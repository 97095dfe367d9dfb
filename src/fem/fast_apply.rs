//! The fast apply of [`super::operator::ElasticOperator`]: the interior
//! stencil along runs ([`super::stencil`] for Q1, [`super::q2_stencil`] for
//! Q2), the cut cells in SIMD batches (Q1 from their factored forms,
//! [`super::q1_forms`]; Q2 sum-factorised from their weights,
//! [`super::cut_apply`]), and a gather for the remaining active nodes, in
//! parallel.
//!
//! # Plan
//! Active nodes split into *interior* nodes (all their cells inside),
//! grouped in [`Run`]s, and *boundary* nodes (touching a cut or outside cell, or
//! the grid's edge). Each boundary node gathers its rows from its non-outside
//! cells, `y_n = Σ_{c ∋ n} K_c[n, :] x_c`, read from the cells' products
//! `z_c = K_c x_c`: the cut cells', and those of the *rim* cells (the inside
//! cells with a boundary node); the plan links each boundary node to the
//! products of its cells (up to 8). Runs and boundary nodes are cut into chunks of
//! consecutive active indices; each chunk writes only its own slice of `y`,
//! so chunks run in parallel with no atomics.
//!
//! # Apply
//! 1. De-interleave `x` into the reused scratch `xs` (three component arrays,
//!    for Q2 each split by the parity of the active index,
//!    [`super::q2_stencil::position`]) and, at the same time, compute
//!    `z_c = K_c x_c` (`ne` = 24 or 81 entries) for every cut cell `c` in slot
//!    order from its form or weights, read front to back (at apply time, so
//!    terms added by `add_cut_cell_mass` after the plan was built are
//!    applied), and `z_c = h K_ref x_c` for every rim cell (Q1: from the
//!    factored form of the whole cell, [`Q1Forms::inside`]; Q2: sum-factorised
//!    at the Gauss points, [`CutKernel::gauss`]), both in SIMD batches of
//!    cells gathered through the cells' stored active node indices.
//! 2. Per chunk: the stencil on its runs from `xs`; for its boundary nodes,
//!    the sum of `z_c[3l .. 3l+3]` over the cells around them (`l` the
//!    node's local index in `c`; a link to no cell reads a zero triple at
//!    the end of `z`). Both write `y` in place, interleaved.
//!
//! Where the CPU has AVX2 and FMA (checked at run time) the chunk kernel is
//! compiled for them; elsewhere it is the portable build of the same code.

use rayon::prelude::*;

use super::cut_apply::{CutKernel, Uniform};
use super::fast_plan::{chunks, is_interior, links, q1_runs, q2_runs, Chunk, NONE};
use super::moment_fit::{CutWeights, FitBasis};
use super::operator::CutData;
use super::q1_forms::Q1Forms;
use super::q2_stencil::{self, Q2Stencil};
use super::stencil::{prefetch, Run, Stencil, TILE};
use crate::element::ElementOrder;
use crate::grid::Grid;

/// How many boundary nodes ahead of its gather a node's cell products are
/// prefetched.
const PREFETCH_AHEAD: usize = 8;

/// The operator data the apply reads (borrowed from the operator).
pub(super) struct CellData<'a> {
    pub slot: &'a [u32],
    /// `h K_ref`, row-major `ne × ne`.
    pub inside: &'a [f64],
    /// The cut cells' forms or weights, in slot order.
    pub cut: &'a CutData,
    /// The cell of each slot.
    pub own_cells: &'a [usize],
    pub node_to_active: &'a [u32],
}

/// What differs between the orders: the interior stencil and its runs, and
/// the rim cells' products.
#[derive(Clone, Debug)]
enum Interior {
    Q1 {
        stencil: Box<Stencil>,
        runs: Vec<Run>,
        /// The whole cell's factored form.
        inside: Q1Forms,
    },
    Q2 {
        stencil: Box<Q2Stencil>,
        runs: Vec<q2_stencil::Run>,
        /// The kernel at the Gauss points and the whole cell's weights.
        kernel: CutKernel,
        weights: CutWeights,
    },
}

/// The precomputed plan of the fast apply.
#[derive(Clone, Debug)]
pub struct FastApply {
    interior: Interior,
    /// Active indices of the boundary nodes, ascending.
    boundary: Vec<u32>,
    /// Per boundary node, per cell around it (in the order of
    /// [`crate::discrete::dofs::node_cells`], then links to no cell): the offset in `z` of the
    /// node's triple `z_c[3l .. 3l+3]` (cut cells in slot order, then rim
    /// cells, `ne` entries each), or of the zero triple after them.
    links: Vec<[u32; 8]>,
    /// The active indices of the nodes (local order, `npc` each) of each cut
    /// cell in slot order, then of each rim cell.
    cell_nodes: Vec<u32>,
    chunks: Vec<Chunk>,
    num_active: usize,
    num_cut: usize,
    /// Dofs per cell.
    ne: usize,
    fma: bool,
}

impl FastApply {
    /// The plan for an operator of elements `order` on `grid`, with the
    /// fitting basis and Lamé parameters of its cells.
    pub(super) fn new(
        grid: &Grid,
        order: ElementOrder,
        m: &CellData,
        active_to_node: &[u32],
        basis: &FitBasis,
        lame: (f64, f64),
    ) -> FastApply {
        let mut boundary = Vec::new();
        let mut interior = Vec::new();
        let mut around = Vec::with_capacity(8);
        for (a, &nd) in active_to_node.iter().enumerate() {
            if is_interior(grid, order, m.slot, nd as usize, &mut around) {
                interior.push(a as u32);
            } else {
                boundary.push(a as u32);
            }
        }
        let interior = match order {
            ElementOrder::Q1 => Interior::Q1 {
                stencil: Box::new(Stencil::new(m.inside)),
                runs: q1_runs(grid, m, active_to_node, &interior),
                inside: Q1Forms::inside(basis, lame, grid.h),
            },
            ElementOrder::Q2 => {
                let (kernel, weights) = CutKernel::gauss(lame, grid.h);
                Interior::Q2 {
                    stencil: Box::new(Q2Stencil::new(m.inside)),
                    runs: q2_runs(grid, m, active_to_node, &interior),
                    kernel,
                    weights,
                }
            }
        };
        let extents: Vec<(usize, usize)> = match &interior {
            Interior::Q1 { runs, .. } => runs.iter().map(|r| (r.start, r.len)).collect(),
            Interior::Q2 { runs, .. } => runs.iter().map(|r| (r.start, r.len)).collect::<Vec<_>>(),
        }
        .into_iter()
        .map(|(s, l)| (s as usize, l as usize))
        .collect();
        let chunks = chunks(&extents, &boundary, active_to_node.len());
        let ne = 3 * order.nodes_per_cell();
        let (links, rim_cells) = links(grid, order, m, active_to_node, &boundary);
        let npc = order.nodes_per_cell();
        let mut cell_nodes = Vec::with_capacity(npc * (m.own_cells.len() + rim_cells.len()));
        let mut nodes = vec![0; npc];
        for c in m.own_cells.iter().chain(&rim_cells) {
            grid.cell_nodes(order, *c, &mut nodes);
            cell_nodes.extend(nodes.iter().map(|&n| {
                let a = m.node_to_active[n];
                assert!(
                    (a as usize) < active_to_node.len(),
                    "cell {c}: inactive node"
                );
                a
            }));
        }
        let z_zero = ne * (m.own_cells.len() + rim_cells.len());
        let links = links
            .into_iter()
            .map(|cells| {
                cells.map(|link| match link {
                    (NONE, _) => z_zero as u32,
                    (zi, l) => (ne * zi as usize + 3 * l as usize) as u32,
                })
            })
            .collect();
        FastApply {
            interior,
            boundary,
            links,
            cell_nodes,
            chunks,
            num_active: active_to_node.len(),
            num_cut: m.own_cells.len(),
            ne,
            fma: fma_available(),
        }
    }

    /// Bytes of plan data (stencil, runs, boundary list, links, cell
    /// nodes, the rim cells' form or weights, chunks).
    pub fn bytes(&self) -> usize {
        let interior = match &self.interior {
            Interior::Q1 {
                stencil,
                runs,
                inside,
            } => stencil.bytes() + std::mem::size_of_val(&runs[..]) + inside.bytes(),
            Interior::Q2 {
                stencil,
                runs,
                weights,
                ..
            } => stencil.bytes() + std::mem::size_of_val(&runs[..]) + 8 * weights.data.len(),
        };
        interior
            + self.boundary.len() * 4
            + self.links.len() * 32
            + self.cell_nodes.len() * 4
            + self.chunks.len() * std::mem::size_of::<Chunk>()
    }

    /// Number of interior nodes (those the stencil handles).
    pub fn num_interior(&self) -> usize {
        match &self.interior {
            Interior::Q1 { runs, .. } => runs.iter().map(|r| r.len as usize).sum(),
            Interior::Q2 { runs, .. } => runs.iter().map(|r| r.len as usize).sum(),
        }
    }

    /// The Q1 interior stencil, its runs (ascending) and the whole cell's
    /// factored form (the rim cells'), or `None` for Q2.
    pub fn q1(&self) -> Option<(&Stencil, &[Run], &Q1Forms)> {
        match &self.interior {
            Interior::Q1 {
                stencil,
                runs,
                inside,
            } => Some((&**stencil, runs, inside)),
            Interior::Q2 { .. } => None,
        }
    }

    /// The active indices of the boundary nodes, ascending.
    pub fn boundary(&self) -> &[u32] {
        &self.boundary
    }

    /// Per boundary node, the offsets in `z` of its cells' triples (cut
    /// cells in slot order, then rim cells, `ne` entries each; a link to no
    /// cell points at the zero triple after them).
    pub fn links(&self) -> &[[u32; 8]] {
        &self.links
    }

    /// The active indices of the nodes (local order) of each cut cell, in
    /// slot order, then of each rim cell, back to back.
    pub fn cell_nodes(&self) -> &[u32] {
        &self.cell_nodes
    }

    /// Number of rim cells (inside cells with a boundary node).
    pub fn num_rim(&self) -> usize {
        self.cell_nodes.len() / (self.ne / 3) - self.num_cut
    }

    /// Length of the scratch [`Self::apply`] needs: `xs`, the `z_c` and a
    /// zero triple.
    pub fn scratch_len(&self) -> usize {
        3 * self.layout().0 + self.ne * (self.num_cut + self.num_rim()) + 3
    }

    /// `(stride, half)`: the entries per component of `xs`, and per parity
    /// of the active index (Q2), each padded by [`TILE`].
    fn layout(&self) -> (usize, usize) {
        match self.interior {
            Interior::Q1 { .. } => (self.num_active + TILE, 0),
            Interior::Q2 { .. } => {
                let half = self.num_active.div_ceil(2) + q2_stencil::TILE;
                (2 * half, half)
            }
        }
    }

    /// `y = A x`, with `scratch` of [`Self::scratch_len`] entries.
    pub(super) fn apply(&self, m: &CellData, x: &[f64], y: &mut [f64], scratch: &mut [f64]) {
        let (stride, half) = self.layout();
        let (xs, z) = scratch.split_at_mut(3 * stride);
        let mut ctx = Context {
            plan: self,
            m,
            x,
            xs: &[],
            z: &[],
        };
        rayon::join(
            || deinterleave(x, xs, (stride, half), self.num_active),
            || {
                let (zc, zr) = z.split_at_mut(self.ne * self.num_cut);
                let (zr, zero) = zr.split_at_mut(self.ne * self.num_rim());
                zero.fill(0.0);
                rayon::join(|| ctx.cut_cells(zc), || ctx.rim_cells(zr));
            },
        );
        (ctx.xs, ctx.z) = (xs, z);
        let mut pieces = Vec::with_capacity(self.chunks.len());
        let mut rest = y;
        for c in &self.chunks {
            let (piece, tail) = rest.split_at_mut(3 * (c.hi - c.lo));
            pieces.push((c, piece));
            rest = tail;
        }
        pieces
            .into_par_iter()
            .for_each(|(c, piece)| ctx.chunk(c, piece));
    }
}

/// What every chunk of one apply reads.
struct Context<'a> {
    plan: &'a FastApply,
    m: &'a CellData<'a>,
    x: &'a [f64],
    /// `x` de-interleaved.
    xs: &'a [f64],
    /// `K_c x_c` per cut cell, then per rim cell, `ne` entries each.
    z: &'a [f64],
}

impl Context<'_> {
    /// One chunk, through the AVX2/FMA build where the CPU has it.
    fn chunk(&self, c: &Chunk, y: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if self.plan.fma {
            // SAFETY: `fma` is set only when the CPU reports AVX2 and FMA.
            unsafe { self.chunk_fma(c, y) };
            return;
        }
        self.chunk_body::<false>(c, y);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn chunk_fma(&self, c: &Chunk, y: &mut [f64]) {
        self.chunk_body::<true>(c, y);
    }

    /// The cells `first..` of the plan's cell list: their dofs from `x`.
    fn gather(&self, first: usize) -> impl Fn(usize, &mut [f64]) + Sync + '_ {
        let npc = self.plan.ne / 3;
        move |s, xe| {
            let nodes = &self.plan.cell_nodes[npc * (first + s)..npc * (first + s + 1)];
            for (xn, &a) in xe.chunks_exact_mut(3).zip(nodes) {
                xn.copy_from_slice(&self.x[3 * a as usize..3 * a as usize + 3]);
            }
        }
    }

    /// `z_c = K_c x_c` for every cut cell, in SIMD batches, in parallel.
    fn cut_cells(&self, z: &mut [f64]) {
        match self.m.cut {
            CutData::Forms(forms) => {
                let nodes: &[[u32; 8]] =
                    bytemuck::cast_slice(&self.plan.cell_nodes[..8 * self.plan.num_cut]);
                forms.apply(nodes, self.x, z);
            }
            CutData::Weights { weights, kernel } => kernel.apply(weights, self.gather(0), z),
        }
    }

    /// `z_c = h K_ref x_c` for every rim cell, in SIMD batches, in parallel.
    fn rim_cells(&self, z: &mut [f64]) {
        let plan = self.plan;
        match &plan.interior {
            Interior::Q1 { inside, .. } => {
                let nodes: &[[u32; 8]] = bytemuck::cast_slice(&plan.cell_nodes[8 * plan.num_cut..]);
                inside.apply_uniform(nodes, self.x, z);
            }
            Interior::Q2 {
                kernel, weights, ..
            } => kernel.apply(&Uniform(weights), self.gather(plan.num_cut), z),
        }
    }

    #[inline(always)]
    fn chunk_body<const FMA: bool>(&self, c: &Chunk, y: &mut [f64]) {
        let plan = self.plan;
        let (stride, half) = plan.layout();
        match &plan.interior {
            Interior::Q1 { stencil, runs, .. } => {
                stencil.apply_runs::<FMA>(&runs[c.runs.clone()], self.xs, stride, y, c.lo)
            }
            Interior::Q2 { stencil, runs, .. } => {
                stencil.apply_runs::<FMA>(&runs[c.runs.clone()], self.xs, (stride, half), y, c.lo)
            }
        }
        for b in c.boundary.clone() {
            if let Some(ahead) = plan.links.get(b + PREFETCH_AHEAD) {
                for &offset in ahead {
                    prefetch(&self.z[offset as usize..][..3]);
                }
            }
            let a = plan.boundary[b] as usize;
            let (mut o0, mut o1, mut o2) = (0.0, 0.0, 0.0);
            for &offset in &plan.links[b] {
                let zl = &self.z[offset as usize..offset as usize + 3];
                (o0, o1, o2) = (o0 + zl[0], o1 + zl[1], o2 + zl[2]);
            }
            y[3 * (a - c.lo)..3 * (a - c.lo) + 3].copy_from_slice(&[o0, o1, o2]);
        }
    }
}

/// `xs[j stride + pos(a)] = x[3a + j]` for the first `n` nodes, in parallel:
/// `pos(a) = a` (Q1, `half = 0`) or [`q2_stencil::position`]`(a, half)`.
fn deinterleave(x: &[f64], xs: &mut [f64], (stride, half): (usize, usize), n: usize) {
    const B: usize = 4096;
    // The regions written: per component, one or (split) two parities.
    let parities = if half == 0 { 1 } else { 2 };
    let mut regions: Vec<std::slice::ChunksMut<f64>> = Vec::with_capacity(6);
    for comp in xs.chunks_mut(stride).take(3) {
        let mut rest = comp;
        for p in 0..parities {
            let (len, skip) = if half == 0 {
                (n, stride)
            } else {
                ((n + 1 - p) / 2, half)
            };
            let (region, tail) = rest.split_at_mut(skip);
            regions.push(region[..len].chunks_mut(B));
            rest = tail;
        }
    }
    let blocks: Vec<Vec<&mut [f64]>> = (0..n.div_ceil(parities * B))
        .map(|_| {
            regions
                .iter_mut()
                .map(|r| r.next().unwrap_or_default())
                .collect()
        })
        .collect();
    blocks
        .into_par_iter()
        .zip(x.par_chunks(3 * parities * B))
        .for_each(|(mut block, xb)| {
            for (q, xq) in xb.chunks_exact(3).enumerate() {
                let (p, i) = (q % parities, q / parities);
                for (j, &v) in xq.iter().enumerate() {
                    block[parities * j + p][i] = v;
                }
            }
        });
}

/// Whether the CPU has AVX2 and FMA (the fast build of the chunk kernel).
pub(super) fn fma_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}
