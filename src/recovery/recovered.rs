//! The recovered field ([`Recovered`]): one patch polynomial per vertex node,
//! its look-ups and statistics, and the CPE blend of a cell's 8 vertex
//! polynomials ([`CellBlend`]).

use super::spr::{scaled, PatchInfo, RecoveryStats};
use super::Monomials;
use crate::element::{shape_values, ElementOrder};
use crate::error::{Error, Result};
use crate::grid::Grid;

/// The recovered field: one fitted polynomial per requested vertex node.
#[derive(Clone, Debug)]
pub struct Recovered<const NC: usize> {
    pub(super) grid: Grid,
    pub(super) basis: Monomials,
    /// Requested nodes, ascending and distinct.
    pub(super) nodes: Vec<usize>,
    /// Stacked coefficients, `NC · n_b` per node.
    pub(super) coeffs: Vec<f64>,
    pub(super) info: Vec<PatchInfo>,
}

impl<const NC: usize> Recovered<NC> {
    /// The polynomial basis of the patches.
    pub fn basis(&self) -> &Monomials {
        &self.basis
    }

    /// The recovered nodes, ascending.
    pub fn nodes(&self) -> &[usize] {
        &self.nodes
    }

    fn slot(&self, node: usize) -> Result<usize> {
        self.nodes
            .binary_search(&node)
            .map_err(|_| Error::Recovery {
                node,
                reason: "no patch was recovered for this node (it was not requested)".into(),
            })
    }

    /// The accepted patch of `node`, if it was requested.
    pub fn patch(&self, node: usize) -> Option<PatchInfo> {
        self.slot(node).ok().map(|s| self.info[s])
    }

    /// Stacked coefficients of `node`'s polynomial in the scaled basis
    /// (component `c`, term `j` at `c · n_b + j`).
    pub fn coefficients(&self, node: usize) -> Result<&[f64]> {
        let len = NC * self.basis.len();
        let s = self.slot(node)?;
        Ok(&self.coeffs[s * len..(s + 1) * len])
    }

    /// The accepted ring of each patch, in the order of [`Recovered::nodes`].
    pub fn rings(&self) -> Vec<usize> {
        self.info.iter().map(|i| i.ring).collect()
    }

    /// Counts of rings and samples over the patches.
    pub fn stats(&self) -> RecoveryStats {
        let max_ring = self.info.iter().map(|i| i.ring).max().unwrap_or(0);
        let mut per_ring = vec![0; max_ring];
        for i in &self.info {
            per_ring[i.ring - 1] += 1;
        }
        RecoveryStats {
            patches: self.info.len(),
            enlarged: self.info.iter().filter(|i| i.ring > 1).count(),
            per_ring,
            min_samples: self.info.iter().map(|i| i.samples).min().unwrap_or(0),
        }
    }

    /// `σ*_node(x)`, the patch polynomial of `node` at the physical point `x`
    /// (any point: the polynomial extends beyond its patch).
    pub fn eval_node_polynomial(&self, node: usize, x: [f64; 3]) -> Result<[f64; NC]> {
        let a = self.coefficients(node)?;
        let center = self.grid.node_position(ElementOrder::Q1, node);
        let mut phi = vec![0.0; self.basis.len()];
        Ok(polynomial_at(
            self.basis(),
            a,
            center,
            self.grid.h,
            x,
            &mut phi,
        ))
    }

    /// The CPE blend at the vertex `node` itself: there its own hat function
    /// is 1 and the others 0, so `σ̂ = σ*_node(x_node)`, the polynomial's
    /// constant term. Error [`Error::Recovery`] when `node` was not
    /// recovered.
    pub fn at_vertex(&self, node: usize) -> Result<[f64; NC]> {
        let a = self.coefficients(node)?;
        let nb = self.basis.len();
        Ok(std::array::from_fn(|c| a[c * nb]))
    }

    /// The CPE blend `σ̂(x) = Σ_i N_i^lin(x) σ*_i(x)` over the 8 vertices `i` of
    /// `cell`, for `x` in the cell's box (also outside Ω). Error
    /// [`Error::Recovery`] when a vertex of the cell was not recovered.
    ///
    /// # Panics
    /// When `cell` is not a cell of the grid.
    pub fn eval(&self, cell: usize, x: [f64; 3]) -> Result<[f64; NC]> {
        Ok(self.cell_blend(cell)?.eval(x))
    }

    /// [`Recovered::eval`] on `cell` with the cell's vertices looked up once
    /// and their polynomials moved to one origin, for callers that evaluate
    /// many points of one cell.
    ///
    /// # Panics
    /// When `cell` is not a cell of the grid.
    pub fn cell_blend(&self, cell: usize) -> Result<CellBlend<'_, NC>> {
        assert!(cell < self.grid.num_cells(), "cell {cell} out of range");
        let mut vertices = [0; 8];
        self.grid.cell_nodes(ElementOrder::Q1, cell, &mut vertices);
        let (h, nb) = (self.grid.h, self.basis.len());
        let lo = self.grid.cell_box(cell).lo;
        // σ*_i(x) = Σ_e a_e φ_e((x − x_i)/h) = Σ_e a_e φ_e(ξ + t_i), with
        // ξ = (x − lo)/h and t_i = (lo − x_i)/h.
        let mut coeffs = vec![0.0; 8 * NC * nb];
        for (b, &node) in coeffs.chunks_exact_mut(NC * nb).zip(&vertices) {
            let a = self.coefficients(node)?;
            let x = self.grid.node_position(ElementOrder::Q1, node);
            let t = [0, 1, 2].map(|k| (lo[k] - x[k]) / h);
            self.basis.for_each_shift(t, |e, f, w| {
                for c in 0..NC {
                    b[c * nb + f] += w * a[c * nb + e];
                }
            });
        }
        Ok(CellBlend {
            basis: &self.basis,
            h,
            lo,
            coeffs,
        })
    }
}

/// The CPE blend's weights at fixed points of a cell, the same in every
/// cell: `N_i^lin(ξ_r) φ_e(ξ_r − o_i)` for each vertex `i` (local offset
/// `o_i`), term `e` and point `r` (reference coordinates `ξ_r ∈ [0, 1]³`),
/// so that [`Recovered::blend_at_table`] needs neither the vertices'
/// polynomials moved to the cell nor the basis at each point.
pub struct BlendTable {
    terms: usize,
    points: usize,
    /// `[i][e][r]`: per vertex and term, the weights of all points.
    weights: Vec<f64>,
}

impl BlendTable {
    /// The table of `basis` at the reference points `points`.
    pub fn new(basis: &Monomials, points: &[[f64; 3]]) -> BlendTable {
        let (nb, np) = (basis.len(), points.len());
        let mut weights = vec![0.0; 8 * nb * np];
        let mut hat = [0.0; 8];
        let mut phi = vec![0.0; nb];
        for (r, xi) in points.iter().enumerate() {
            shape_values(ElementOrder::Q1, *xi, &mut hat);
            for (i, h) in hat.iter().enumerate() {
                let o = [i & 1, (i >> 1) & 1, i >> 2].map(|b| b as f64);
                basis.values([0, 1, 2].map(|k| xi[k] - o[k]), &mut phi);
                for (e, p) in phi.iter().enumerate() {
                    weights[(i * nb + e) * np + r] = h * p;
                }
            }
        }
        BlendTable {
            terms: nb,
            points: np,
            weights,
        }
    }
}

impl<const NC: usize> Recovered<NC> {
    /// The CPE blend `σ̂` of `cell` at the points of `table` (made with this
    /// field's basis), into `out` by component: `out[c · n_p + r]`. Error
    /// [`Error::Recovery`] when a vertex of the cell was not recovered.
    ///
    /// # Panics
    /// When `cell` is not a cell of the grid, or `table` is of another basis,
    /// or `out` does not hold `NC · n_p` values.
    pub fn blend_at_table(&self, cell: usize, table: &BlendTable, out: &mut [f64]) -> Result<()> {
        let (nb, np) = (self.basis.len(), table.points);
        assert_eq!(table.terms, nb, "a blend table of another basis");
        assert_eq!(out.len(), NC * np, "blend values of every point");
        let mut vertices = [0; 8];
        self.grid.cell_nodes(ElementOrder::Q1, cell, &mut vertices);
        out.fill(0.0);
        for (i, &node) in vertices.iter().enumerate() {
            let a = self.coefficients(node)?;
            for e in 0..nb {
                let w = &table.weights[(i * nb + e) * np..(i * nb + e + 1) * np];
                for (c, o) in out.chunks_exact_mut(np).enumerate() {
                    let ace = a[c * nb + e];
                    o.iter_mut().zip(w).for_each(|(o, w)| *o += ace * w);
                }
            }
        }
        Ok(())
    }
}

/// The CPE blend on one cell: its 8 vertices' polynomials in the cell's
/// scaled coordinates `ξ = (x − lo)/h` ([`Recovered::cell_blend`]).
pub struct CellBlend<'a, const NC: usize> {
    basis: &'a Monomials,
    h: f64,
    lo: [f64; 3],
    /// Vertex `i`'s stacked coefficients at `i·NC·n_b` (component `c`, term
    /// `j` at `c·n_b + j` within).
    coeffs: Vec<f64>,
}

impl<const NC: usize> CellBlend<'_, NC> {
    /// `σ̂(x) = Σ_i N_i^lin(x) σ*_i(x)` for `x` in the cell's box.
    pub fn eval(&self, x: [f64; 3]) -> [f64; NC] {
        let xi = scaled(self.lo, self.h, x);
        let mut hat = [0.0; 8];
        shape_values(ElementOrder::Q1, xi, &mut hat);
        let nb = self.basis.len();
        let mut small = [0.0; SMALL_BASIS];
        let mut large = Vec::new();
        let phi = if nb <= SMALL_BASIS {
            &mut small[..nb]
        } else {
            large.resize(nb, 0.0);
            &mut large[..]
        };
        self.basis.values(xi, phi);
        let mut out = [0.0; NC];
        for (b, &w) in self.coeffs.chunks_exact(NC * nb).zip(&hat) {
            for (o, bc) in out.iter_mut().zip(b.chunks_exact(nb)) {
                *o += w * bc.iter().zip(phi.iter()).map(|(a, p)| a * p).sum::<f64>();
            }
        }
        out
    }
}

/// The patch polynomial with stacked coefficients `a` (component `c`, term
/// `j` at `c · n_b + j`) of the vertex at `center` at the physical point `x`;
/// `phi` is scratch of the basis's length.
fn polynomial_at<const NC: usize>(
    basis: &Monomials,
    a: &[f64],
    center: [f64; 3],
    h: f64,
    x: [f64; 3],
    phi: &mut [f64],
) -> [f64; NC] {
    basis.values(scaled(center, h, x), phi);
    let nb = phi.len();
    std::array::from_fn(|c| (0..nb).map(|j| a[c * nb + j] * phi[j]).sum())
}

/// Basis sizes up to this (degree 3) are evaluated in a stack buffer.
const SMALL_BASIS: usize = 20;
