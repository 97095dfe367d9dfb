//! The fast Q1 apply of [`super::operator::ElasticOperator`]: the interior
//! stencil along runs ([`super::stencil`]), the cut cells from their factored
//! forms in SIMD batches ([`super::q1_forms`]), and a gather for the
//! remaining active nodes, in parallel.
//!
//! # Plan
//! Active nodes split into *interior* nodes (all 8 surrounding cells inside),
//! grouped in [`Run`]s, and *boundary* nodes (touching a cut or outside cell, or
//! the grid's edge). Each boundary node gathers its rows from its non-outside
//! cells, `y_n = Σ_{c ∋ n} K_c[n, :] x_c`, read from the cells' products
//! `z_c = K_c x_c`: the cut cells', and those of the *rim* cells (the inside
//! cells with a boundary node); the plan links each boundary node to the
//! products of its 8 cells. Runs and boundary nodes are cut into chunks of
//! consecutive active indices; each chunk writes only its own slice of `y`,
//! so chunks run in parallel with no atomics.
//!
//! # Apply
//! 1. De-interleave `x` into the reused scratch `xs` (three component arrays)
//!    and, at the same time, compute `z_c = K_c x_c` (24 entries) for every
//!    cut cell `c` in slot order from its form, read front to back (at
//!    apply time, so terms added by `add_cut_cell_mass` after the plan was
//!    built are applied), and `z_c = h K_ref x_c` for every rim cell from
//!    the factored form of the whole cell ([`Q1Forms::inside`]), both in SIMD
//!    batches of cells gathered through the cells' stored active node indices.
//! 2. Per chunk: the stencil on its runs from `xs`; for its boundary nodes,
//!    the sum of `z_c[3l .. 3l+3]` over the cells around them (a link to no
//!    cell reads a zero triple at the end of `z`). Both write `y` in place,
//!    interleaved.
//!
//! Where the CPU has AVX2 and FMA (checked at run time) the chunk kernel is
//! compiled for them; elsewhere it is the portable build of the same code.

use std::ops::Range;

use rayon::prelude::*;

use super::operator::{INSIDE, OUTSIDE};
use super::q1_forms::Q1Forms;
use super::stencil::{prefetch, Run, Stencil, TILE};
use crate::grid::Grid;

/// Work per chunk, in interior-node equivalents.
const CHUNK_COST: usize = 1024;
/// A boundary node costs about this many interior nodes.
const BOUNDARY_COST: usize = 2;
/// How many boundary nodes ahead of its gather a node's cell products are
/// prefetched.
const PREFETCH_AHEAD: usize = 8;
/// A link to no cell product (an outside cell, or none).
const NONE: u32 = u32::MAX;

/// The operator data the apply reads (borrowed from the operator).
pub struct CellData<'a> {
    pub slot: &'a [u32],
    /// `h K_ref`, row-major 24 × 24.
    pub inside: &'a [f64],
    /// The cut cells' factored forms, in slot order.
    pub forms: &'a Q1Forms,
    /// The cell of each slot.
    pub own_cells: &'a [usize],
    pub node_to_active: &'a [u32],
}

/// Consecutive active nodes `lo..hi` with their runs and boundary nodes.
#[derive(Clone, Debug)]
struct Chunk {
    lo: usize,
    hi: usize,
    runs: Range<usize>,
    boundary: Range<usize>,
}

/// The precomputed plan of the Q1 apply.
#[derive(Clone, Debug)]
pub struct FastApply {
    stencil: Stencil,
    runs: Vec<Run>,
    /// Active indices of the boundary nodes, ascending.
    boundary: Vec<u32>,
    /// Per boundary node, per cell `cc` around it (cell `(i−1+ci, j−1+cj,
    /// k−1+ck)`, `cc = ci + 2 cj + 4 ck`): the offset in `z` of the node's
    /// triple `z_c[3l .. 3l+3]` (`l = 7 − cc`; cut cells in slot order, then
    /// rim cells), or of the zero triple after them for no cell.
    links: Vec<[u32; 8]>,
    /// The active indices of the 8 nodes (local order) of each cut cell, in
    /// slot order, and of each rim cell.
    cut_nodes: Vec<[u32; 8]>,
    rim_nodes: Vec<[u32; 8]>,
    /// The whole cell's factored form (the rim cells' products).
    inside: Q1Forms,
    chunks: Vec<Chunk>,
    num_active: usize,
    num_cut: usize,
    fma: bool,
}

impl FastApply {
    /// The plan for a Q1 operator on `grid`, `inside` the factored form of
    /// its whole cell.
    pub fn new(grid: &Grid, m: &CellData, active_to_node: &[u32], inside: Q1Forms) -> FastApply {
        let mut runs: Vec<Run> = Vec::new();
        let mut boundary = Vec::new();
        let nn = [grid.n[0] + 1, grid.n[1] + 1];
        let node = |i: usize, j: usize, k: usize| i + nn[0] * (j + nn[1] * k);
        let mut last_interior = usize::MAX;
        for (a, &nd) in active_to_node.iter().enumerate() {
            let nd = nd as usize;
            let [i, j, k] = [nd % nn[0], (nd / nn[0]) % nn[1], nd / (nn[0] * nn[1])];
            if !is_interior(grid, m.slot, [i, j, k]) {
                boundary.push(a as u32);
                continue;
            }
            match runs.last_mut() {
                Some(r) if last_interior.wrapping_add(1) == nd => r.len += 1,
                _ => {
                    let bases = std::array::from_fn(|r| {
                        let (dj, dk) = (r % 3, r / 3);
                        m.node_to_active[node(i - 1, j + dj - 1, k + dk - 1)]
                    });
                    let (start, len) = (a as u32, 1);
                    runs.push(Run { start, len, bases });
                }
            }
            last_interior = nd;
        }
        let chunks = chunks(&runs, &boundary, active_to_node.len());
        let (links, rim_cells) = links(grid, m, active_to_node, &boundary);
        let cell_nodes = |c: usize| -> [u32; 8] {
            let [nx, ny] = [grid.n[0], grid.n[1]];
            let corner = node(c % nx, (c / nx) % ny, c / (nx * ny));
            std::array::from_fn(|q| {
                let nq = corner + node(q & 1, (q >> 1) & 1, q >> 2);
                let a = m.node_to_active[nq];
                assert!(
                    (a as usize) < active_to_node.len(),
                    "cell {c}: inactive node"
                );
                a
            })
        };
        let cut_nodes = m.own_cells.iter().map(|&c| cell_nodes(c)).collect();
        let rim_nodes = rim_cells.iter().map(|&c| cell_nodes(c as usize)).collect();
        let z_zero = 24 * (m.own_cells.len() + rim_cells.len());
        let links = links
            .into_iter()
            .map(|cells| {
                std::array::from_fn(|cc| match cells[cc] {
                    NONE => z_zero as u32,
                    zi => 24 * zi + 3 * (7 - cc as u32),
                })
            })
            .collect();
        FastApply {
            stencil: Stencil::new(m.inside),
            runs,
            boundary,
            links,
            cut_nodes,
            rim_nodes,
            inside,
            chunks,
            num_active: active_to_node.len(),
            num_cut: m.own_cells.len(),
            fma: fma_available(),
        }
    }

    /// Bytes of plan data (stencil, runs, boundary list, links, cell
    /// nodes, the whole cell's form, chunks).
    pub fn bytes(&self) -> usize {
        self.stencil.bytes()
            + self.runs.len() * std::mem::size_of::<Run>()
            + self.boundary.len() * 4
            + self.links.len() * 32
            + (self.cut_nodes.len() + self.rim_nodes.len()) * 32
            + self.inside.bytes()
            + self.chunks.len() * std::mem::size_of::<Chunk>()
    }

    /// Number of interior nodes (those the stencil handles).
    pub fn num_interior(&self) -> usize {
        self.runs.iter().map(|r| r.len as usize).sum()
    }

    /// The interior stencil.
    pub fn stencil(&self) -> &Stencil {
        &self.stencil
    }

    /// The runs of interior nodes, ascending.
    pub fn runs(&self) -> &[Run] {
        &self.runs
    }

    /// The active indices of the boundary nodes, ascending.
    pub fn boundary(&self) -> &[u32] {
        &self.boundary
    }

    /// Per boundary node, the offsets in `z` of its 8 cells' triples (cut
    /// cells in slot order, then rim cells, 24 entries each; a link to no
    /// cell points at the zero triple after them).
    pub fn links(&self) -> &[[u32; 8]] {
        &self.links
    }

    /// The active indices of the 8 nodes (local order) of each cut cell,
    /// in slot order, then of each rim cell.
    pub fn cell_nodes(&self) -> impl Iterator<Item = &[u32; 8]> {
        self.cut_nodes.iter().chain(&self.rim_nodes)
    }

    /// Number of rim cells (inside cells with a boundary node).
    pub fn num_rim(&self) -> usize {
        self.rim_nodes.len()
    }

    /// Length of the scratch [`Self::apply`] needs: `xs`, the `z_c` and a
    /// zero triple.
    pub fn scratch_len(&self) -> usize {
        3 * self.stride() + 24 * (self.num_cut + self.rim_nodes.len()) + 3
    }

    fn stride(&self) -> usize {
        self.num_active + TILE
    }

    /// `y = A x`, with `scratch` of [`Self::scratch_len`] entries whose
    /// padding (past each component's `num_active` entries) is finite.
    pub fn apply(&self, m: &CellData, x: &[f64], y: &mut [f64], scratch: &mut [f64]) {
        let stride = self.stride();
        let (xs, z) = scratch.split_at_mut(3 * stride);
        let mut ctx = Context {
            plan: self,
            m,
            x,
            xs: &[],
            z: &[],
        };
        rayon::join(
            || deinterleave(x, xs, stride, self.num_active),
            || {
                let (zc, zr) = z.split_at_mut(24 * self.num_cut);
                let (zr, zero) = zr.split_at_mut(24 * self.rim_nodes.len());
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
    /// `K_c x_c` per cut cell, 24 entries each, in slot order.
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

    /// `z_c = K_c x_c` for every cut cell, in SIMD batches, in parallel.
    fn cut_cells(&self, z: &mut [f64]) {
        self.m.forms.apply(&self.plan.cut_nodes, self.x, z);
    }

    /// `z_c = h K_ref x_c` for every rim cell, in SIMD batches, in parallel.
    fn rim_cells(&self, z: &mut [f64]) {
        self.plan
            .inside
            .apply_uniform(&self.plan.rim_nodes, self.x, z);
    }

    #[inline(always)]
    fn chunk_body<const FMA: bool>(&self, c: &Chunk, y: &mut [f64]) {
        let plan = self.plan;
        let runs = &plan.runs[c.runs.clone()];
        plan.stencil
            .apply_runs::<FMA>(runs, self.xs, plan.stride(), y, c.lo);
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

/// Whether node `(i, j, k)` has all 8 surrounding cells inside.
fn is_interior(grid: &Grid, slot: &[u32], [i, j, k]: [usize; 3]) -> bool {
    let n = grid.n;
    if i == 0 || j == 0 || k == 0 || i >= n[0] || j >= n[1] || k >= n[2] {
        return false;
    }
    (0..8).all(|cc| {
        let c = [
            (i - 1 + (cc & 1)),
            (j - 1 + ((cc >> 1) & 1)),
            (k - 1 + (cc >> 2)),
        ];
        slot[grid.cell_index(c)] == INSIDE
    })
}

/// The links of the boundary nodes to their cells' products, and the rim
/// cells (see [`FastApply`]), numbered in order of first use.
fn links(
    grid: &Grid,
    m: &CellData,
    active_to_node: &[u32],
    boundary: &[u32],
) -> (Vec<[u32; 8]>, Vec<u32>) {
    let n = grid.n;
    let (mx, my) = (n[0] + 1, n[1] + 1);
    let num_cut = m.own_cells.len() as u32;
    let mut rim_index = vec![NONE; grid.num_cells()];
    let mut rim = Vec::new();
    let links = boundary
        .iter()
        .map(|&a| {
            let nd = active_to_node[a as usize] as usize;
            let ijk = [nd % mx, (nd / mx) % my, nd / (mx * my)];
            std::array::from_fn(|cc| {
                let d = [cc & 1, (cc >> 1) & 1, cc >> 2];
                let c: Option<Vec<usize>> = (0..3)
                    .map(|ax| (ijk[ax] + d[ax]).checked_sub(1).filter(|v| *v < n[ax]))
                    .collect();
                let Some(c) = c else { return NONE };
                let cell = grid.cell_index([c[0], c[1], c[2]]);
                match m.slot[cell] {
                    OUTSIDE => NONE,
                    INSIDE => {
                        if rim_index[cell] == NONE {
                            rim_index[cell] = num_cut + rim.len() as u32;
                            rim.push(cell as u32);
                        }
                        rim_index[cell]
                    }
                    s => s,
                }
            })
        })
        .collect();
    (links, rim)
}

/// Cuts the active nodes `0..num_active` into chunks of about [`CHUNK_COST`]
/// work, never splitting a run.
fn chunks(runs: &[Run], boundary: &[u32], num_active: usize) -> Vec<Chunk> {
    let mut out = Vec::new();
    let (mut r, mut b, mut cost) = (0, 0, 0);
    let mut open = Chunk {
        lo: 0,
        hi: 0,
        runs: 0..0,
        boundary: 0..0,
    };
    while r < runs.len() || b < boundary.len() {
        let next_run = runs.get(r).map_or(usize::MAX, |x| x.start as usize);
        let next_boundary = boundary.get(b).map_or(usize::MAX, |&x| x as usize);
        if next_run < next_boundary {
            open.hi = next_run + runs[r].len as usize;
            cost += runs[r].len as usize;
            r += 1;
        } else {
            open.hi = next_boundary + 1;
            cost += BOUNDARY_COST;
            b += 1;
        }
        if cost >= CHUNK_COST || open.hi == num_active {
            open.runs.end = r;
            open.boundary.end = b;
            let next = Chunk {
                lo: open.hi,
                hi: open.hi,
                runs: r..r,
                boundary: b..b,
            };
            out.push(std::mem::replace(&mut open, next));
            cost = 0;
        }
    }
    out
}

/// `xs[j stride + a] = x[3a + j]` for the first `n` nodes, in parallel.
fn deinterleave(x: &[f64], xs: &mut [f64], stride: usize, n: usize) {
    const B: usize = 4096;
    let (x0, rest) = xs.split_at_mut(stride);
    let (x1, x2) = rest.split_at_mut(stride);
    x0[..n]
        .par_chunks_mut(B)
        .zip(x1[..n].par_chunks_mut(B))
        .zip(x2[..n].par_chunks_mut(B))
        .zip(x.par_chunks(3 * B))
        .for_each(|(((a, b), c), xc)| {
            for (q, ((ai, bi), ci)) in a.iter_mut().zip(b.iter_mut()).zip(c.iter_mut()).enumerate()
            {
                *ai = xc[3 * q];
                *bi = xc[3 * q + 1];
                *ci = xc[3 * q + 2];
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
