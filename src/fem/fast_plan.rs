//! The construction of the fast apply's plan ([`super::fast_apply`]): which
//! active nodes are interior, their runs (Q1: [`super::stencil`], Q2:
//! [`super::q2_stencil`]), the boundary nodes' links to their cells'
//! products with the rim cells, and the chunks the apply runs in parallel.

use std::ops::Range;

use super::fast_apply::CellData;
use super::operator::{INSIDE, OUTSIDE};
use super::q2_stencil;
use super::stencil::Run;
use crate::discrete::dofs::node_cells;
use crate::element::ElementOrder;
use crate::grid::Grid;

/// Work per chunk, in interior-node equivalents.
const CHUNK_COST: usize = 1024;
/// A boundary node costs about this many interior nodes.
const BOUNDARY_COST: usize = 2;
/// A link to no cell product (an outside cell, or none).
pub(super) const NONE: u32 = u32::MAX;

/// Consecutive active nodes `lo..hi` with their runs and boundary nodes.
#[derive(Clone, Debug)]
pub(super) struct Chunk {
    pub lo: usize,
    pub hi: usize,
    pub runs: Range<usize>,
    pub boundary: Range<usize>,
}

/// Whether lattice node `node` is interior: off the grid's edge, with all its
/// cells inside.
pub(super) fn is_interior(
    grid: &Grid,
    order: ElementOrder,
    slot: &[u32],
    node: usize,
    around: &mut Vec<(usize, usize)>,
) -> bool {
    let m = grid.nodes_per_axis(order);
    let ijk = [node % m[0], (node / m[0]) % m[1], node / (m[0] * m[1])];
    if (0..3).any(|ax| ijk[ax] == 0 || ijk[ax] == m[ax] - 1) {
        return false;
    }
    node_cells(grid, order, node, around);
    around.iter().all(|&(c, _)| slot[c] == INSIDE)
}

/// The runs of consecutive grid nodes among the interior nodes `interior`
/// (active indices, ascending): `open(a, node)` starts a run at active
/// index `a`, grid node `node`; `len(run)` is the run's length, which each
/// following node of the run increments.
fn runs_of<R>(
    active_to_node: &[u32],
    interior: &[u32],
    mut open: impl FnMut(u32, usize) -> R,
    len: impl Fn(&mut R) -> &mut u32,
) -> Vec<R> {
    let mut runs: Vec<R> = Vec::new();
    let mut last = usize::MAX;
    for &a in interior {
        let nd = active_to_node[a as usize] as usize;
        match runs.last_mut() {
            Some(r) if last.wrapping_add(1) == nd => *len(r) += 1,
            _ => runs.push(open(a, nd)),
        }
        last = nd;
    }
    runs
}

/// The Q1 runs of the interior nodes `interior` (active indices, ascending).
pub(super) fn q1_runs(
    grid: &Grid,
    m: &CellData,
    active_to_node: &[u32],
    interior: &[u32],
) -> Vec<Run> {
    let nn = [grid.n[0] + 1, grid.n[1] + 1];
    let node = |i: usize, j: usize, k: usize| i + nn[0] * (j + nn[1] * k);
    let open = |a, nd: usize| {
        let [i, j, k] = [nd % nn[0], (nd / nn[0]) % nn[1], nd / (nn[0] * nn[1])];
        let bases = std::array::from_fn(|r| {
            let (dj, dk) = (r % 3, r / 3);
            m.node_to_active[node(i - 1, j + dj - 1, k + dk - 1)]
        });
        Run {
            start: a,
            len: 1,
            bases,
        }
    };
    runs_of(active_to_node, interior, open, |r| &mut r.len)
}

/// The Q2 runs of the interior nodes `interior` (active indices, ascending).
pub(super) fn q2_runs(
    grid: &Grid,
    m: &CellData,
    active_to_node: &[u32],
    interior: &[u32],
) -> Vec<q2_stencil::Run> {
    let nn = grid.nodes_per_axis(ElementOrder::Q2);
    let open = |a, nd: usize| {
        let [i, j, k] = [nd % nn[0], (nd / nn[0]) % nn[1], nd / (nn[0] * nn[1])];
        let bases = std::array::from_fn(|r| {
            let (jj, kk) = ((j + r % 5).wrapping_sub(2), (k + r / 5).wrapping_sub(2));
            if jj < nn[1] && kk < nn[2] {
                m.node_to_active[i + nn[0] * (jj + nn[1] * kk)]
            } else {
                u32::MAX
            }
        });
        q2_stencil::Run {
            start: a,
            len: 1,
            parity: (i % 2 + 2 * (j % 2) + 4 * (k % 2)) as u32,
            bases,
        }
    };
    runs_of(active_to_node, interior, open, |r| &mut r.len)
}

/// The links of the boundary nodes to their cells' products, as (product
/// index, local node) pairs in the order of [`node_cells`] (`NONE` past the
/// last), and the rim cells (see [`FastApply`]), numbered in order of first
/// use.
#[allow(clippy::type_complexity)]
pub(super) fn links(
    grid: &Grid,
    order: ElementOrder,
    m: &CellData,
    active_to_node: &[u32],
    boundary: &[u32],
) -> (Vec<[(u32, u32); 8]>, Vec<usize>) {
    let num_cut = m.own_cells.len() as u32;
    let mut rim_index = vec![NONE; grid.num_cells()];
    let mut rim = Vec::new();
    let mut around = Vec::with_capacity(8);
    let links = boundary
        .iter()
        .map(|&a| {
            node_cells(
                grid,
                order,
                active_to_node[a as usize] as usize,
                &mut around,
            );
            let mut out = [(NONE, NONE); 8];
            let mut k = 0;
            for &(cell, l) in &around {
                let zi = match m.slot[cell] {
                    OUTSIDE => continue,
                    INSIDE => {
                        if rim_index[cell] == NONE {
                            rim_index[cell] = num_cut + rim.len() as u32;
                            rim.push(cell);
                        }
                        rim_index[cell]
                    }
                    s => s,
                };
                out[k] = (zi, l as u32);
                k += 1;
            }
            out
        })
        .collect();
    (links, rim)
}

/// Cuts the active nodes `0..num_active` into chunks of about [`CHUNK_COST`]
/// work, never splitting a run (`runs`: start and length, ascending).
pub(super) fn chunks(runs: &[(usize, usize)], boundary: &[u32], num_active: usize) -> Vec<Chunk> {
    let mut out = Vec::new();
    let (mut r, mut b, mut cost) = (0, 0, 0);
    let mut open = Chunk {
        lo: 0,
        hi: 0,
        runs: 0..0,
        boundary: 0..0,
    };
    while r < runs.len() || b < boundary.len() {
        let next_run = runs.get(r).map_or(usize::MAX, |x| x.0);
        let next_boundary = boundary.get(b).map_or(usize::MAX, |&x| x as usize);
        if next_run < next_boundary {
            open.hi = next_run + runs[r].1;
            cost += runs[r].1;
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
