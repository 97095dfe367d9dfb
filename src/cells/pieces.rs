//! The connected pieces of a body at the grid's resolution, and whether each
//! piece is held.
//!
//! Two cells that meet the body and share a grid node share unknowns, so the
//! discrete body falls apart exactly along the components of the "shares a
//! node" relation between its cells (26 neighbours): those are its pieces
//! ([`Pieces`]). A piece that nothing holds has a rigid motion of zero
//! energy; the stabilisation's patches may hang it on another piece and hide
//! that. [`free_motions`] tells, per piece, which rigid motions the held
//! points (Dirichlet points with their held components, symmetry planes)
//! leave free, so a set-up can refuse such a body by naming the piece.

use nalgebra::{DMatrix, Matrix6, SymmetricEigen};

use super::split::{Split, SplitCell, PRIMARY};
use super::{CellKind, Cells};
use crate::element::ElementOrder;
use crate::error::Error;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::spatial::Aabb;

/// The piece of a cell that does not meet the body.
pub const NO_PIECE: u32 = u32::MAX;

/// The pieces of a body: each cell that meets it is labelled with its piece,
/// numbered by the piece's first cell in lattice order.
#[derive(Clone, Debug, PartialEq)]
pub struct Pieces {
    /// Piece of each grid cell ([`NO_PIECE`] outside the body).
    pub of_cell: Vec<u32>,
    /// Number of pieces.
    pub count: usize,
    /// The split cells ([`crate::cells::split`]), ascending, with the piece
    /// of each of their parts (`of_cell` holds the first's).
    pub split: Vec<(SplitCell, Vec<u32>)>,
}

/// What a piece is, for a message that lets the user find it.
#[derive(Clone, Debug, PartialEq)]
pub struct PieceSummary {
    /// Volume of the body in the piece's cells.
    pub volume: f64,
    /// Box of the piece's cells.
    pub cells_box: Aabb,
    /// Boundary tags on its cut cells' surface points, ascending.
    pub tags: Vec<u16>,
}

fn find(parent: &mut [u32], mut a: u32) -> u32 {
    while parent[a as usize] != a {
        let up = parent[parent[a as usize] as usize];
        parent[a as usize] = up;
        a = up;
    }
    a
}

impl Pieces {
    /// The pieces of the cells of `cells` that meet the body.
    pub fn new(grid: &Grid, cells: &Cells) -> Pieces {
        Pieces::with_split(grid, cells, &Split::default())
    }

    /// The pieces where the cells of `split` are split: union-find over the
    /// unknowns' nodes (grid vertices, then the copies), each cell or piece
    /// of a split cell joining its eight.
    pub fn with_split(grid: &Grid, cells: &Cells, split: &Split) -> Pieces {
        let vertices = grid.num_nodes(ElementOrder::Q1);
        let total = vertices + split.extra_nodes.len();
        let mut parent: Vec<u32> = (0..total as u32).collect();
        let mut local = [0usize; 8];
        let join = |parent: &mut Vec<u32>, nodes: &[usize]| {
            let r0 = find(parent, nodes[0] as u32);
            for &n in &nodes[1..] {
                let r = find(parent, n as u32);
                if r != r0 {
                    let (lo, hi) = (r.min(r0), r.max(r0));
                    parent[hi as usize] = lo;
                }
            }
        };
        let node_of = |local: &[usize; 8], copies: &[u32; 8]| -> [usize; 8] {
            std::array::from_fn(|l| match copies[l] {
                PRIMARY => local[l],
                copy => vertices + copy as usize,
            })
        };
        for c in (0..grid.num_cells()).filter(|&c| cells.kinds[c] != CellKind::Outside) {
            grid.cell_nodes(ElementOrder::Q1, c, &mut local);
            match split.cell(c) {
                None => join(&mut parent, &local),
                Some(s) => {
                    for copies in &s.pieces {
                        join(&mut parent, &node_of(&local, copies));
                    }
                }
            }
        }
        // Pieces numbered by their first cell in lattice order.
        let mut number = vec![NO_PIECE; total];
        let mut count = 0u32;
        let mut piece_of = |parent: &mut Vec<u32>, node: usize| {
            let root = find(parent, node as u32) as usize;
            if number[root] == NO_PIECE {
                number[root] = count;
                count += 1;
            }
            number[root]
        };
        let mut of_cell = vec![NO_PIECE; grid.num_cells()];
        let mut split_cells = Vec::new();
        for c in (0..grid.num_cells()).filter(|&c| cells.kinds[c] != CellKind::Outside) {
            grid.cell_nodes(ElementOrder::Q1, c, &mut local);
            match split.cell(c) {
                None => of_cell[c] = piece_of(&mut parent, local[0]),
                Some(s) => {
                    let per_piece: Vec<u32> = s
                        .pieces
                        .iter()
                        .map(|copies| piece_of(&mut parent, node_of(&local, copies)[0]))
                        .collect();
                    of_cell[c] = per_piece[0];
                    split_cells.push((s.clone(), per_piece));
                }
            }
        }
        Pieces {
            of_cell,
            count: count as usize,
            split: split_cells,
        }
    }

    /// The piece of a point `x` of `cell`: the cell's, or in a split cell
    /// that of the part `x` lies in.
    pub fn of_point(&self, cell: usize, x: [f64; 3]) -> u32 {
        match self.split.binary_search_by_key(&cell, |s| s.0.cell) {
            Ok(k) => self.split[k].1[self.split[k].0.piece_of(x)],
            Err(_) => self.of_cell[cell],
        }
    }

    /// Volume, box and boundary tags of every piece.
    pub fn summaries(&self, grid: &Grid, cells: &Cells) -> Vec<PieceSummary> {
        self.summaries_of(grid, cells, &|_| true)
    }

    /// [`Pieces::summaries`] of the cells that `counts` takes (a rank's
    /// brick; a piece with none of them has an empty box).
    pub fn summaries_of(
        &self,
        grid: &Grid,
        cells: &Cells,
        counts: &dyn Fn(usize) -> bool,
    ) -> Vec<PieceSummary> {
        let mut out = vec![
            PieceSummary {
                volume: 0.0,
                cells_box: Aabb::around(&[]),
                tags: Vec::new(),
            };
            self.count
        ];
        let cell_volume = grid.h.powi(3);
        for (c, &p) in self.of_cell.iter().enumerate() {
            if p == NO_PIECE || !counts(c) {
                continue;
            }
            let s = &mut out[p as usize];
            s.cells_box = s.cells_box.union(&grid.cell_box(c));
            if cells.kinds[c] == CellKind::Inside {
                s.volume += cell_volume;
            }
        }
        for (i, &c) in cells.cut.iter().enumerate().filter(|(_, &c)| counts(c)) {
            for q in cells.volume_points(i) {
                out[self.of_point(c, q.x) as usize].volume += q.w;
            }
            for q in cells.surface_points(i) {
                let s = &mut out[self.of_point(c, q.x) as usize];
                if let Err(at) = s.tags.binary_search(&q.tag) {
                    s.tags.insert(at, q.tag);
                }
            }
        }
        out
    }
}

/// A point where displacement components are held: `mask[a]` is 1 where
/// component `a` is held, 0 where it is free.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeldPoint {
    pub cell: usize,
    pub x: [f64; 3],
    pub w: f64,
    pub mask: [f64; 3],
}

/// A rigid motion that nothing holds: a translation (`rotation` zero) or a
/// rotation about `axis` through `point`, and the translation along it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FreeMotion {
    pub translation: [f64; 3],
    pub rotation: [f64; 3],
    pub point: [f64; 3],
}

impl std::fmt::Display for FreeMotion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let r = norm(self.rotation);
        let unit = |v: [f64; 3], s: f64| v.map(|c| if (c / s).abs() < 1e-9 { 0.0 } else { c / s });
        let fmt3 = |v: [f64; 3]| format!("({:.3}, {:.3}, {:.3})", v[0], v[1], v[2]);
        // The axis pointing along its largest component's positive direction.
        let big = (0..3).fold(0, |b, a| {
            if self.rotation[a].abs() > self.rotation[b].abs() {
                a
            } else {
                b
            }
        });
        let r = r.copysign(self.rotation[big]);
        if self.rotation == [0.0; 3] {
            let t = norm(self.translation);
            write!(f, "translation along {}", fmt3(unit(self.translation, t)))
        } else {
            let p = self.point;
            write!(
                f,
                "rotation about the axis {} through {}",
                fmt3(unit(self.rotation, r)),
                fmt3(p.map(|c| if c.abs() < 1e-12 { 0.0 } else { c }))
            )
        }
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Smallest eigenvalue of a piece's rigid-motion matrix, relative to its
/// largest, below which the motion counts as free. A clamp on a patch of
/// size a on a piece of size L leaves about (a/L)², so this is a patch a
/// hundred-thousandth of the piece.
const FREE_RATIO: f64 = 1e-10;

/// Per piece, the rigid motions that `held` leaves free (empty: held). The
/// rigid motions are spanned about the piece's box centre `c` and scaled by
/// its diagonal `L`: three translations `e_a`, three rotations
/// `e_a × (x − c) / L`; the piece is held when `M = Σ_q w_q Σ_a mask_a r_i,a
/// r_j,a` is positive definite ([`held_grams`], [`motions_from`]).
pub fn free_motions(
    pieces: &Pieces,
    summaries: &[PieceSummary],
    held: impl IntoIterator<Item = HeldPoint>,
) -> Vec<Vec<FreeMotion>> {
    let frames = piece_frames(summaries);
    motions_from(&held_grams(pieces, &frames, held), &frames)
}

/// Each piece's frame: the centre of its box and the box's diagonal.
pub fn piece_frames(summaries: &[PieceSummary]) -> Vec<([f64; 3], f64)> {
    summaries
        .iter()
        .map(|s| {
            let b = &s.cells_box;
            let c = [0, 1, 2].map(|a| 0.5 * (b.lo[a] + b.hi[a]));
            (c, norm([0, 1, 2].map(|a| b.hi[a] - b.lo[a])))
        })
        .collect()
}

/// Per piece, `Σ_q w_q Rᵀ M_q R` over the points `held` of the piece, `R`
/// the six rigid modes about the piece's frame and `M_q` the point's mask
/// (a sum over points: the ranks' add up).
pub fn held_grams(
    pieces: &Pieces,
    frames: &[([f64; 3], f64)],
    held: impl IntoIterator<Item = HeldPoint>,
) -> Vec<Matrix6<f64>> {
    let modes = |x: [f64; 3], (c, l): ([f64; 3], f64)| -> [[f64; 3]; 6] {
        let d = [0, 1, 2].map(|a| (x[a] - c[a]) / l);
        [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, -d[2], d[1]],
            [d[2], 0.0, -d[0]],
            [-d[1], d[0], 0.0],
        ]
    };
    let mut m = vec![Matrix6::<f64>::zeros(); pieces.count];
    for p in held {
        let piece = pieces.of_point(p.cell, p.x);
        if piece == NO_PIECE {
            continue;
        }
        let r = modes(p.x, frames[piece as usize]);
        let mp = &mut m[piece as usize];
        for i in 0..6 {
            for j in 0..6 {
                let dot: f64 = (0..3).map(|a| p.mask[a] * r[i][a] * r[j][a]).sum();
                mp[(i, j)] += p.w * dot;
            }
        }
    }
    m
}

/// The motions each piece's `grams` leave free (its null space, relative
/// to its largest eigenvalue), about its frame.
pub fn motions_from(grams: &[Matrix6<f64>], frames: &[([f64; 3], f64)]) -> Vec<Vec<FreeMotion>> {
    grams
        .iter()
        .zip(frames)
        .map(|(mp, &(c, l))| {
            let eig = SymmetricEigen::new(*mp);
            let largest = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
            let null: Vec<usize> = (0..6)
                .filter(|&k| largest <= 0.0 || eig.eigenvalues[k] <= FREE_RATIO * largest)
                .collect();
            let basis = DMatrix::from_fn(6, null.len(), |i, j| eig.eigenvectors[(i, null[j])]);
            canonical(&basis)
                .into_iter()
                .map(|v| motion([v[0], v[1], v[2]], [v[3] / l, v[4] / l, v[5] / l], c))
                .collect()
        })
        .collect()
}

/// A basis of the free motions spanned by the columns of `basis` (scaled
/// modes, orthonormal) that reads well: first the translations in it (no
/// rotation part), then rotations orthogonal to them. The eigenvectors of a
/// repeated zero eigenvalue mix the two arbitrarily.
fn canonical(basis: &DMatrix<f64>) -> Vec<[f64; 6]> {
    if basis.ncols() == 0 {
        return Vec::new();
    }
    // Right singular vectors of the rotation rows: combinations of the basis
    // ordered by how much they rotate; those that do not are translations.
    let rotation = basis.rows(3, 3).clone_owned();
    let square = rotation.transpose() * &rotation;
    let eig = SymmetricEigen::new(square);
    let mut order: Vec<usize> = (0..basis.ncols()).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let (mut translations, mut rotations) = (Vec::new(), Vec::new());
    for k in order {
        let v = basis * eig.eigenvectors.column(k);
        let mut out = [0.0; 6];
        for i in 0..6 {
            out[i] = v[i];
        }
        match eig.eigenvalues[k] <= 1e-12 {
            true => translations.push([out[0], out[1], out[2]]),
            false => rotations.push(out),
        }
    }
    // The translations as the coordinate axes where they are in the span:
    // the axes projected on it, orthogonalised in x, y, z order.
    let mut axes: Vec<[f64; 3]> = Vec::new();
    for a in 0..3 {
        let mut v = [0.0; 3];
        for t in &translations {
            v = [0, 1, 2].map(|i| v[i] + t[a] * t[i]);
        }
        for e in &axes {
            let d: f64 = (0..3).map(|i| v[i] * e[i]).sum();
            v = [0, 1, 2].map(|i| v[i] - d * e[i]);
        }
        if norm(v) > 1e-6 && axes.len() < translations.len() {
            let n = norm(v);
            axes.push(v.map(|c| c / n));
        }
    }
    axes.into_iter()
        .map(|t| [t[0], t[1], t[2], 0.0, 0.0, 0.0])
        .chain(rotations)
        .collect()
}

/// Who names an unheld piece: the case file, the key of the body's
/// Dirichlet conditions as the file writes it, and the body's name.
pub struct Naming<'a> {
    pub file: &'a str,
    pub key: &'a str,
    pub body: &'a str,
}

/// The pieces of a body, and whether each is held: `Some` error
/// ([`Error::CaseFile`], exit code 2) naming the first piece whose rigid
/// motions `held` leaves free, unless it carries one of the `exempt` tags (a
/// contact boundary, which may hold it).
pub fn held_pieces(
    grid: &Grid,
    cells: &Cells,
    split: &Split,
    geometry: &Geometry,
    held: impl IntoIterator<Item = HeldPoint>,
    exempt: &[u16],
    naming: &Naming,
) -> (Pieces, Option<Error>) {
    let pieces = Pieces::with_split(grid, cells, split);
    let summaries = pieces.summaries(grid, cells);
    let free = free_motions(&pieces, &summaries, held);
    let error = unheld_error(geometry, naming, &summaries, &free, exempt);
    (pieces, error)
}

/// The error naming the first piece whose motions `free` are not empty
/// (and that has no boundary part in `exempt`), if one is.
pub fn unheld_error(
    geometry: &Geometry,
    naming: &Naming,
    summaries: &[PieceSummary],
    free: &[Vec<FreeMotion>],
    exempt: &[u16],
) -> Option<Error> {
    for (p, (s, motions)) in summaries.iter().zip(free).enumerate() {
        if motions.is_empty() || s.tags.iter().any(|t| exempt.contains(t)) {
            continue;
        }
        let fmt3 = |v: [f64; 3]| format!("({:.4}, {:.4}, {:.4})", v[0], v[1], v[2]);
        let parts: Vec<&str> = s.tags.iter().map(|&t| geometry.tag_name(t)).collect();
        let motions: Vec<String> = match motions.len() {
            6 => vec!["every rigid motion (nothing holds it)".into()],
            _ => motions.iter().map(|m| m.to_string()).collect(),
        };
        return Some(Error::CaseFile {
            file: naming.file.into(),
            key: naming.key.into(),
            reason: format!(
                "body '{}': piece {} of {} (volume {:.4e}, cells {}..{}, boundary parts: {}) \
                 is not held, free in: {}; hold it with [dirichlet.<tag>] on one of its \
                 boundary parts, or remove it from the geometry",
                naming.body,
                p + 1,
                summaries.len(),
                s.volume,
                fmt3(s.cells_box.lo),
                fmt3(s.cells_box.hi),
                parts.join(", "),
                motions.join("; ")
            ),
        });
    }
    None
}

/// The rigid motion `u(x) = t + ω × (x − c)` as a translation or as a
/// rotation about the axis through the point nearest `c` where `u ∥ ω`.
fn motion(t: [f64; 3], w: [f64; 3], c: [f64; 3]) -> FreeMotion {
    let w2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    if w2 == 0.0 {
        return FreeMotion {
            translation: t,
            rotation: [0.0; 3],
            point: c,
        };
    }
    // x − c = ω × t / |ω|² puts the axis through x.
    let wxt = [
        w[1] * t[2] - w[2] * t[1],
        w[2] * t[0] - w[0] * t[2],
        w[0] * t[1] - w[1] * t[0],
    ];
    let along: f64 = (0..3).map(|a| t[a] * w[a]).sum::<f64>() / w2;
    FreeMotion {
        translation: w.map(|x| along * x),
        rotation: w,
        point: [0, 1, 2].map(|a| c[a] + wxt[a] / w2),
    }
}

#[cfg(test)]
mod tests;
