//! Cells with a negligible volume fraction, merged into a neighbour.
//!
//! A cut cell whose part inside the body is below [`NEGLIGIBLE_FRACTION`] of
//! `h³` carries weights at the level of round-off: its element matrix can have
//! non-positive diagonal entries of a few ulps (measured: −2.2e-22 on a torus at
//! level 6, −1.6e-20 in the cut sweep), and a node that only such cells touch
//! has no stiffness at all when the S-term is off. Such a cell is taken out of
//! the active set and its quadrature points (volume and boundary) are handed to
//! the active face-neighbour sharing the largest area of body with it (its
//! *host*), which integrates them with its own shape functions extended by
//! polynomial continuation. The boundary data of the sliver (Dirichlet,
//! traction) are thus still imposed, next to where they belong.
//!
//! Every active cell that shares a face of positive body area with a merged
//! cell becomes a cut cell (an inside one with its full rule), so that its face
//! toward the merged cell is accounted for by the consistency correction of
//! [`crate::fem::flux_consistency`]: an inside cell integrates its faces exactly,
//! which is only right when the cell across is active.
//!
//! The threshold: the cut rules' weights carry absolute errors of about
//! `1e-16 h³`, so below a fraction of `1e-10` a cell's own matrix is accurate to
//! no better than about 1e-6 relative, and below `1e-14` its sign is not known.
//! Merging is consistent (the patch test holds to round-off whatever the
//! threshold), so the threshold trades only the sliver's own resolution, which
//! at `1e-10 h³` is nothing a solution can see.

use std::collections::HashMap;

use super::faces::{face_neighbour, face_rule};
use super::CellKind;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::quadrature::saye::{box_rule, BoxRule};

/// Volume fraction `|c ∩ Ω| / h³` below which a cut cell is merged.
pub const NEGLIGIBLE_FRACTION: f64 = 1e-10;

/// Merges the negligible cells of `entries` (cut-cell candidates with their
/// rules, ascending by cell) into their hosts; `kinds` is updated (merged cells
/// become outside, inside cells next to a merged one become cut). Returns the
/// merged cells, ascending.
pub(super) fn merge_negligible(
    grid: &Grid,
    g: &Geometry,
    q: usize,
    kinds: &mut [CellKind],
    entries: &mut Vec<(usize, BoxRule)>,
) -> Vec<usize> {
    let cell_volume = grid.h.powi(3);
    let negligible =
        |r: &BoxRule| r.volume.iter().map(|p| p.w).sum::<f64>() < NEGLIGIBLE_FRACTION * cell_volume;
    let (small, kept): (Vec<_>, Vec<_>) = entries.drain(..).partition(|(_, r)| negligible(r));
    *entries = kept;
    for (c, _) in &small {
        kinds[*c] = CellKind::Outside;
    }
    let mut index: HashMap<usize, usize> = entries
        .iter()
        .enumerate()
        .map(|(i, (c, _))| (*c, i))
        .collect();
    let mut merged = Vec::new();
    for (m, rule) in small {
        let mut best: Option<(usize, f64)> = None;
        for axis in 0..3 {
            for side in 0..2 {
                let Some(n) = face_neighbour(grid, m, axis, side) else {
                    continue;
                };
                if kinds[n] == CellKind::Outside {
                    continue;
                }
                let area: f64 = face_rule(g, grid, m, axis, side, q)
                    .iter()
                    .map(|p| p.w)
                    .sum();
                if area <= 0.0 {
                    continue;
                }
                let slot = entry_of(grid, g, q, kinds, entries, &mut index, n);
                if best.is_none_or(|(_, a)| area > a) {
                    best = Some((slot, area));
                }
            }
        }
        if let Some((slot, _)) = best {
            let host = &mut entries[slot].1;
            host.volume.extend(rule.volume);
            host.surface.extend(rule.surface);
            merged.push(m);
        }
    }
    entries.sort_unstable_by_key(|(c, _)| *c);
    merged.sort_unstable();
    merged
}

/// The position of cell `n`'s entry, making an inside cell a cut cell with
/// its full rule first.
fn entry_of(
    grid: &Grid,
    g: &Geometry,
    q: usize,
    kinds: &mut [CellKind],
    entries: &mut Vec<(usize, BoxRule)>,
    index: &mut HashMap<usize, usize>,
    n: usize,
) -> usize {
    if let Some(&i) = index.get(&n) {
        return i;
    }
    kinds[n] = CellKind::Cut;
    let mut rule = box_rule(g, &grid.cell_box(n), &[0, 1, 2], q);
    rule.surface.clear();
    entries.push((n, rule));
    index.insert(n, entries.len() - 1);
    entries.len() - 1
}
