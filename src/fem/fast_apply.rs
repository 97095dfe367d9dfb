//! The fast Q1 apply of [`super::operator::ElasticOperator`]: the interior
//! stencil along runs ([`super::stencil`]), the cut cells from their factored
//! forms in SIMD batches ([`super::q1_forms`]), and a gather for the
//! remaining active nodes, in parallel.
//!
//! # Plan
//! Active nodes split into *interior* nodes (all 8 surrounding cells inside),
//! grouped in [`Run`]s, and *boundary* nodes (touching a cut or outside cell, or
//! the grid's edge). Each boundary node gathers its rows from its non-outside
//! cells, `y_n = Σ_{c ∋ n} K_c[n, :] x_c`. Runs and boundary nodes are cut into
//! chunks of consecutive active indices; each chunk writes only its own slice
//! of `y`, so chunks run in parallel with no atomics.
//!
//! # Apply
//! 1. De-interleave `x` into the reused scratch `xs` (three component arrays)
//!    and, at the same time, compute `z_c = K_c x_c` (24 entries) for every
//!    cut cell `c` in slot order from its form, read front to back (at
//!    apply time, so terms added by `add_cut_cell_mass` after the plan was
//!    built are applied).
//! 2. Per chunk: the stencil on its runs from `xs`; for its boundary nodes,
//!    `z_c[3l .. 3l+3]` of each cut cell and `h K_ref[3l .. 3l+3, :] x_c` of
//!    each inside cell around them. Both write `y` in place, interleaved.
//!
//! Where the CPU has AVX2 and FMA (checked at run time) the chunk kernel is
//! compiled for them; elsewhere it is the portable build of the same code.

use std::ops::Range;

use rayon::prelude::*;

use super::operator::{INSIDE, OUTSIDE};
use super::q1_forms::Q1Forms;
use super::stencil::{madd, Run, Stencil, TILE};
use crate::grid::Grid;

/// Work per chunk, in interior-node equivalents.
const CHUNK_COST: usize = 1024;
/// A boundary node costs about this many interior nodes.
const BOUNDARY_COST: usize = 4;

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
    chunks: Vec<Chunk>,
    /// Cells per axis.
    n: [usize; 3],
    num_active: usize,
    num_cut: usize,
    fma: bool,
}

impl FastApply {
    /// The plan for a Q1 operator on `grid`.
    pub fn new(grid: &Grid, m: &CellData, active_to_node: &[u32]) -> FastApply {
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
        FastApply {
            stencil: Stencil::new(m.inside),
            runs,
            boundary,
            chunks,
            n: grid.n,
            num_active: active_to_node.len(),
            num_cut: m.own_cells.len(),
            fma: fma_available(),
        }
    }

    /// Bytes of plan data (stencil, runs, boundary list, chunks).
    pub fn bytes(&self) -> usize {
        self.stencil.bytes()
            + self.runs.len() * std::mem::size_of::<Run>()
            + self.boundary.len() * 4
            + self.chunks.len() * std::mem::size_of::<Chunk>()
    }

    /// Number of interior nodes (those the stencil handles).
    pub fn num_interior(&self) -> usize {
        self.runs.iter().map(|r| r.len as usize).sum()
    }

    /// Length of the scratch [`Self::apply`] needs: `xs` and the `z_c`.
    pub fn scratch_len(&self) -> usize {
        3 * self.stride() + 24 * self.num_cut
    }

    fn stride(&self) -> usize {
        self.num_active + TILE
    }

    /// `y = A x`, with `scratch` of [`Self::scratch_len`] entries whose
    /// padding (past each component's `num_active` entries) is finite.
    pub fn apply(
        &self,
        m: &CellData,
        active_to_node: &[u32],
        x: &[f64],
        y: &mut [f64],
        scratch: &mut [f64],
    ) {
        let stride = self.stride();
        let (xs, z) = scratch.split_at_mut(3 * stride);
        let mut ctx = Context {
            plan: self,
            m,
            active_to_node,
            x,
            xs: &[],
            z: &[],
        };
        rayon::join(
            || deinterleave(x, xs, stride, self.num_active),
            || ctx.cut_cells(z),
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
    active_to_node: &'a [u32],
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
        let [nx, ny, _] = self.plan.n;
        let gather = |s: usize, xe: &mut [f64]| {
            let c = self.m.own_cells[s];
            xe.copy_from_slice(&self.cell_x([c % nx, (c / nx) % ny, c / (nx * ny)]));
        };
        self.m.forms.apply(gather, z);
    }

    /// The 24 dofs of cell `ijk`'s nodes, in local order.
    #[inline(always)]
    fn cell_x(&self, [i, j, k]: [usize; 3]) -> [f64; 24] {
        let [nx, ny, _] = self.plan.n;
        let (mx, my) = (nx + 1, ny + 1);
        let corner = i + mx * (j + my * k);
        let mut xe = [0.0; 24];
        for q in 0..8 {
            let nq = corner + (q & 1) + mx * (((q >> 1) & 1) + my * (q >> 2));
            let aq = self.m.node_to_active[nq] as usize;
            xe[3 * q..3 * q + 3].copy_from_slice(&self.x[3 * aq..3 * aq + 3]);
        }
        xe
    }

    #[inline(always)]
    fn chunk_body<const FMA: bool>(&self, c: &Chunk, y: &mut [f64]) {
        let plan = self.plan;
        let runs = &plan.runs[c.runs.clone()];
        plan.stencil
            .apply_runs::<FMA>(runs, self.xs, plan.stride(), y, c.lo);
        for &a in &plan.boundary[c.boundary.clone()] {
            let a = a as usize;
            let out = self.gather::<FMA>(a);
            y[3 * (a - c.lo)..3 * (a - c.lo) + 3].copy_from_slice(&out);
        }
    }

    /// Rows of boundary node `a`: `Σ_{c ∋ n} K_c[3l+i, :] x_c` over its
    /// non-outside cells `c`, `l` the node's local index in `c` (for a cut
    /// cell, entries of `z_c`).
    #[inline(always)]
    fn gather<const FMA: bool>(&self, a: usize) -> [f64; 3] {
        let [nx, ny, nz] = self.plan.n;
        let (mx, my) = (nx + 1, ny + 1);
        let nd = self.active_to_node[a] as usize;
        let [i, j, k] = [nd % mx, (nd / mx) % my, nd / (mx * my)];
        let mut out = [0.0; 3];
        for cc in 0..8 {
            let [ci, cj, ck] = [cc & 1, (cc >> 1) & 1, cc >> 2];
            // Cell (i−1+ci, j−1+cj, k−1+ck), where it exists.
            let (Some(ia), Some(ja), Some(ka)) = (
                (i + ci).checked_sub(1).filter(|v| *v < nx),
                (j + cj).checked_sub(1).filter(|v| *v < ny),
                (k + ck).checked_sub(1).filter(|v| *v < nz),
            ) else {
                continue;
            };
            let l = 7 - cc;
            let part = match self.m.slot[ia + nx * (ja + ny * ka)] {
                OUTSIDE => continue,
                INSIDE => {
                    let rows = &self.m.inside[3 * l * 24..(3 * l + 3) * 24];
                    rows_dot::<FMA>(rows, &self.cell_x([ia, ja, ka]))
                }
                s => {
                    let zl = &self.z[24 * s as usize + 3 * l..];
                    [zl[0], zl[1], zl[2]]
                }
            };
            for (o, p) in out.iter_mut().zip(part) {
                *o += p;
            }
        }
        out
    }
}

/// `(R x)_r` for the three rows `R` (row-major 3 × 24): four partial sums per
/// row, so that the products vectorise and the additions do not form one
/// long dependency chain.
#[inline(always)]
fn rows_dot<const FMA: bool>(rows: &[f64], x: &[f64; 24]) -> [f64; 3] {
    let mut acc = [[0.0; 4]; 3];
    for (a, row) in acc.iter_mut().zip(rows.chunks_exact(24)) {
        for q in (0..24).step_by(4) {
            for lane in 0..4 {
                a[lane] = madd::<FMA>(row[q + lane], x[q + lane], a[lane]);
            }
        }
    }
    acc.map(|a| (a[0] + a[1]) + (a[2] + a[3]))
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
