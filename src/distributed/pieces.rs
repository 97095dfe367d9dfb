//! The body's pieces across the ranks: each rank finds the pieces of its
//! window ([`crate::cells::pieces`]); a piece that reaches into another
//! rank's window meets that rank's piece in the cells the two windows
//! share. The ranks exchange the labels of those cells, gather the pairs,
//! and join them (union–find, the same on every rank), so every rank names
//! a piece as the whole grid does, up to renumbering: the label of a piece
//! is the rank order of its first (rank, local piece).

use crate::cells::pieces::{Pieces, NO_PIECE};
use crate::comm::Comm;
use crate::grid::{CellBox, Grid};

/// The cells of `b`, in index order.
fn cells_of<'g>(grid: &'g Grid, b: &CellBox) -> impl Iterator<Item = usize> + 'g {
    let b = *b;
    (b.lo[2]..b.hi[2]).flat_map(move |k| {
        (b.lo[1]..b.hi[1])
            .flat_map(move |j| (b.lo[0]..b.hi[0]).map(move |i| grid.cell_index([i, j, k])))
    })
}

/// The box of the cells two boxes share.
fn overlap(a: &CellBox, b: &CellBox) -> CellBox {
    CellBox {
        lo: [0, 1, 2].map(|i| a.lo[i].max(b.lo[i])),
        hi: [0, 1, 2].map(|i| a.hi[i].min(b.hi[i])),
    }
}

fn find(parent: &mut [usize], mut a: usize) -> usize {
    while parent[a] != a {
        parent[a] = parent[parent[a]];
        a = parent[a];
    }
    a
}

/// Relabels this rank's `pieces` (over its window `windows[rank]`) with the
/// labels the pieces have across all ranks. Collective.
pub fn join(comm: &dyn Comm, grid: &Grid, windows: &[CellBox], pieces: &mut Pieces) {
    let me = comm.rank();
    let shared: Vec<(usize, CellBox)> = (0..comm.size())
        .filter(|&q| q != me && windows[q].meets(&windows[me]))
        .map(|q| (q, overlap(&windows[me], &windows[q])))
        .collect();
    let label = |c: usize| match pieces.of_cell[c] {
        NO_PIECE => -1.0,
        p => p as f64,
    };
    let sends: Vec<(usize, Vec<f64>)> = shared
        .iter()
        .map(|(q, b)| (*q, cells_of(grid, b).map(label).collect()))
        .collect();
    let recvs: Vec<(usize, usize)> = shared.iter().map(|(q, b)| (*q, b.num_cells())).collect();
    let theirs = comm.exchange(&sends, &recvs);
    // Pairs (my piece, rank, its piece), once each.
    let mut pairs = Vec::new();
    for ((q, b), labels) in shared.iter().zip(&theirs) {
        for (c, &t) in cells_of(grid, b).zip(labels) {
            let mine = pieces.of_cell[c];
            if mine != NO_PIECE && t >= 0.0 {
                pairs.push([mine as usize, *q, t as usize]);
            }
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    let counts = comm.all_gather(&[pieces.count as f64]);
    let first: Vec<usize> = counts
        .iter()
        .scan(0, |acc, c| {
            let start = *acc;
            *acc += c[0] as usize;
            Some(start)
        })
        .collect();
    let total = first.last().copied().unwrap_or(0) + counts.last().map_or(0, |c| c[0] as usize);
    let flat: Vec<f64> = pairs.iter().flatten().map(|&v| v as f64).collect();
    let mut parent: Vec<usize> = (0..total).collect();
    for (r, theirs) in comm.all_gather(&flat).iter().enumerate() {
        for t in theirs.chunks_exact(3) {
            let a = find(&mut parent, first[r] + t[0] as usize);
            let b = find(&mut parent, first[t[1] as usize] + t[2] as usize);
            let (lo, hi) = (a.min(b), a.max(b));
            parent[hi] = lo;
        }
    }
    // Roots numbered in order of their first member.
    let roots: Vec<usize> = (0..total).map(|i| find(&mut parent, i)).collect();
    let mut number = vec![usize::MAX; total];
    let mut count = 0;
    for &root in &roots {
        if number[root] == usize::MAX {
            number[root] = count;
            count += 1;
        }
    }
    let relabel: Vec<u32> = (0..pieces.count)
        .map(|p| number[roots[first[me] + p]] as u32)
        .collect();
    for p in pieces.of_cell.iter_mut().filter(|p| **p != NO_PIECE) {
        *p = relabel[*p as usize];
    }
    pieces.count = count;
}

/// Ok when every piece of the body is held, as one rank checks it
/// ([`crate::cells::pieces::held_pieces`]); otherwise the same error on
/// every rank. Each piece's summary (volume, box, boundary parts) and the
/// Gram matrix of its Dirichlet points' rigid modes are summed over the
/// ranks' bricks (`counts`: this rank's cells). Collective.
pub fn check_held(
    comm: &dyn Comm,
    setup: &crate::driver::setup::Setup,
    counts: &dyn Fn(usize) -> bool,
    geometry: &crate::geometry::Geometry,
    naming: &crate::cells::pieces::Naming,
) -> crate::error::Result<()> {
    use crate::cells::pieces::{held_grams, motions_from, piece_frames, unheld_error, HeldPoint};
    let (pieces, grid, cells) = (&setup.pieces, &setup.grid, &setup.cells);
    let mut summaries = pieces.summaries_of(grid, cells, counts);
    let tags = geometry.tag_names().len();
    // Per piece: volume, then per tag whether it bounds the piece.
    let mut sums = vec![0.0; pieces.count * (1 + tags)];
    for (p, s) in summaries.iter().enumerate() {
        sums[p * (1 + tags)] = s.volume;
        for &t in &s.tags {
            sums[p * (1 + tags) + 1 + t as usize] = 1.0;
        }
    }
    comm.sum(&mut sums);
    let boxes: Vec<f64> = summaries
        .iter()
        .flat_map(|s| s.cells_box.lo.into_iter().chain(s.cells_box.hi))
        .collect();
    let all = comm.all_gather(&boxes);
    for (p, s) in summaries.iter_mut().enumerate() {
        let row = &sums[p * (1 + tags)..(p + 1) * (1 + tags)];
        s.volume = row[0];
        s.tags = (0..tags as u16)
            .filter(|&t| row[1 + t as usize] > 0.0)
            .collect();
        for theirs in &all {
            for a in 0..3 {
                s.cells_box.lo[a] = s.cells_box.lo[a].min(theirs[6 * p + a]);
                s.cells_box.hi[a] = s.cells_box.hi[a].max(theirs[6 * p + 3 + a]);
            }
        }
    }
    let frames = piece_frames(&summaries);
    let held = setup
        .dirichlet
        .iter()
        .filter(|p| counts(p.cell))
        .map(|p| HeldPoint {
            cell: p.cell,
            x: p.x,
            w: p.w,
            mask: p.mask,
        });
    let mut grams = held_grams(pieces, &frames, held);
    let mut flat: Vec<f64> = grams.iter().flat_map(|g| g.iter().copied()).collect();
    comm.sum(&mut flat);
    for (g, v) in grams.iter_mut().zip(flat.chunks_exact(36)) {
        g.iter_mut().zip(v).for_each(|(a, b)| *a = *b);
    }
    let free = motions_from(&grams, &frames);
    match unheld_error(geometry, naming, &summaries, &free, &[]) {
        Some(e) => Err(e),
        None => Ok(()),
    }
}
