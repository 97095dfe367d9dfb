//! The discrete displacement field: values, gradients and stresses of `u_h` at
//! points of a cell, the nodal interpolant of a given field, and the error
//! norms against an exact field:
//! `‖e‖_E² = ∫_Ω ε(e) : σ(e)`, `‖e‖_L2² = ∫_Ω |e|²`, with `e = u − u_h`.
//!
//! The interpolant's error ([`solution_and_interpolant_errors`]) is a
//! reference only where the exact field is finite and of its own size at
//! every active node: active nodes can lie outside the body, where the formula
//! of the exact field need not mean anything (the Lamé field of a shell is
//! singular at its centre).

use rayon::prelude::*;

use super::dofs::DofMap;
use crate::cells::split::SplitCell;
use crate::cells::{CellKind, Cells};
use crate::element::{shape_gradients, shape_values, tensor_gauss_rule, ElementOrder};
use crate::exact::ExactSum;
use crate::expr::{VectorExpr, VectorTape};
use crate::grid::Grid;

/// `u_h(x)` and `∇u_h(x)` (`g[i][j] = ∂u_i/∂x_j`) at a point of `cell`.
pub fn value_and_gradient(
    grid: &Grid,
    dofs: &DofMap,
    u: &[f64],
    cell: usize,
    x: [f64; 3],
) -> ([f64; 3], [[f64; 3]; 3]) {
    CellField::new(grid, dofs, u, cell).value_and_gradient(x)
}

/// `u_h` on one cell: its nodal values and box gathered once, for callers
/// that evaluate many points of the cell ([`value_and_gradient`] is one
/// point). A split cell ([`crate::cells::split`]) gathers the values of
/// each of its pieces and evaluates a point with those of its piece.
pub struct CellField {
    order: ElementOrder,
    lo: [f64; 3],
    h: f64,
    nodes_per_cell: usize,
    values: [[f64; 3]; 27],
    /// A split cell and the nodal values of each of its pieces.
    pieces: Option<Box<PieceValues>>,
}

/// A split cell and the nodal values of each of its pieces.
type PieceValues = (SplitCell, Vec<[[f64; 3]; 27]>);

/// The values of `u` at the active nodes `nodes`.
fn gather(u: &[f64], nodes: &[usize]) -> [[f64; 3]; 27] {
    let mut values = [[0.0; 3]; 27];
    for (v, &node) in values.iter_mut().zip(nodes) {
        *v = [0, 1, 2].map(|i| u[3 * node + i]);
    }
    values
}

impl CellField {
    pub fn new(grid: &Grid, dofs: &DofMap, u: &[f64], cell: usize) -> CellField {
        let npc = dofs.order.nodes_per_cell();
        let mut nodes = [0usize; 27];
        dofs.cell_active_nodes(grid, cell, &mut nodes[..npc]);
        let pieces = dofs.split.cell(cell).map(|s| {
            let values = (0..s.pieces.len())
                .map(|p| {
                    dofs.piece_active_nodes(grid, s, p, &mut nodes[..npc]);
                    gather(u, &nodes[..npc])
                })
                .collect();
            Box::new((s.clone(), values))
        });
        CellField {
            order: dofs.order,
            lo: grid.cell_box(cell).lo,
            h: grid.h,
            nodes_per_cell: npc,
            values: gather(u, &nodes[..npc]),
            pieces,
        }
    }

    /// `u_h(x)` and `∇u_h(x)` at a point `x` of the cell.
    pub fn value_and_gradient(&self, x: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let xi = [0, 1, 2].map(|a| (x[a] - self.lo[a]) / self.h);
        let values = match &self.pieces {
            Some(p) => &p.1[p.0.piece_of(x)],
            None => &self.values,
        };
        self.at(values, &Shapes::at(self.order, xi, self.h))
    }

    /// `u_h(x)` at a point `x` of the cell (the shape functions' values
    /// only, not their gradients).
    pub fn value(&self, x: [f64; 3]) -> [f64; 3] {
        let xi = [0, 1, 2].map(|a| (x[a] - self.lo[a]) / self.h);
        let values = match &self.pieces {
            Some(p) => &p.1[p.0.piece_of(x)],
            None => &self.values,
        };
        let mut n = [0.0; 27];
        shape_values(self.order, xi, &mut n[..self.nodes_per_cell]);
        let mut out = [0.0; 3];
        for (na, va) in n[..self.nodes_per_cell].iter().zip(values) {
            for (o, v) in out.iter_mut().zip(va) {
                *o += na * v;
            }
        }
        out
    }

    /// `u_h` and `∇u_h` at point `q` of the rule that `table` tabulates,
    /// in this cell (not a split one: the rule's points are not known).
    pub fn at_tabulated(&self, table: &ShapeTable, q: usize) -> ([f64; 3], [[f64; 3]; 3]) {
        debug_assert!(self.pieces.is_none(), "a tabulated point of a split cell");
        self.at(&self.values, &table.0[q])
    }

    /// `u_h` and `∇u_h` from nodal `values` at the point whose shape
    /// functions are `s`.
    fn at(&self, values: &[[f64; 3]; 27], s: &Shapes) -> ([f64; 3], [[f64; 3]; 3]) {
        let mut val = [0.0; 3];
        let mut grad = [[0.0; 3]; 3];
        for a in 0..self.nodes_per_cell {
            for i in 0..3 {
                let ui = values[a][i];
                val[i] += s.n[a] * ui;
                for j in 0..3 {
                    grad[i][j] += s.dn[a][j] * ui;
                }
            }
        }
        (val, grad)
    }
}

/// The shape functions of an element order at the points of a rule
/// (reference coordinates in `[0, 1]³`) of every cell of size `h`, for
/// [`CellField::at_tabulated`].
pub struct ShapeTable(Vec<Shapes>);

impl ShapeTable {
    /// The shape functions' values at point `q` (`nodes_per_cell` of them
    /// and zeros after).
    pub fn values(&self, q: usize) -> &[f64; 27] {
        &self.0[q].n
    }

    /// The shape functions' physical gradients at point `q`.
    pub fn gradients(&self, q: usize) -> &[[f64; 3]; 27] {
        &self.0[q].dn
    }

    pub fn new(order: ElementOrder, rule: &[([f64; 3], f64)], h: f64) -> ShapeTable {
        ShapeTable(
            rule.iter()
                .map(|(xi, _)| Shapes::at(order, *xi, h))
                .collect(),
        )
    }
}

/// The shape functions at a point of a cell of size `h`: values and
/// gradients in physical coordinates (`∂N/∂ξ / h`), tabulated once per
/// quadrature point of a rule for all inside cells.
struct Shapes {
    n: [f64; 27],
    dn: [[f64; 3]; 27],
}

impl Shapes {
    fn at(order: ElementOrder, xi: [f64; 3], h: f64) -> Shapes {
        let npc = order.nodes_per_cell();
        let mut s = Shapes {
            n: [0.0; 27],
            dn: [[0.0; 3]; 27],
        };
        shape_values(order, xi, &mut s.n[..npc]);
        shape_gradients(order, xi, &mut s.dn[..npc]);
        for d in &mut s.dn[..npc] {
            *d = d.map(|v| v / h);
        }
        s
    }
}

/// Stress `σ = λ tr(ε) I + 2μ ε` of a displacement gradient, in Voigt order
/// (xx, yy, zz, yz, xz, xy).
pub fn stress_voigt(g: &[[f64; 3]; 3], lambda: f64, mu: f64) -> [f64; 6] {
    let tr = g[0][0] + g[1][1] + g[2][2];
    [
        lambda * tr + 2.0 * mu * g[0][0],
        lambda * tr + 2.0 * mu * g[1][1],
        lambda * tr + 2.0 * mu * g[2][2],
        mu * (g[1][2] + g[2][1]),
        mu * (g[0][2] + g[2][0]),
        mu * (g[0][1] + g[1][0]),
    ]
}

/// `ε(e) : σ(e)` for a displacement-gradient error `g`.
fn energy_density(g: &[[f64; 3]; 3], lambda: f64, mu: f64) -> f64 {
    let s = stress_voigt(g, lambda, mu);
    s[0] * g[0][0]
        + s[1] * g[1][1]
        + s[2] * g[2][2]
        + s[3] * (g[1][2] + g[2][1])
        + s[4] * (g[0][2] + g[2][0])
        + s[5] * (g[0][1] + g[1][0])
}

/// The nodal interpolant of `u` on the active nodes.
pub fn interpolate(grid: &Grid, dofs: &DofMap, u: &VectorExpr) -> Vec<f64> {
    let tape = u.tape();
    let mut out = vec![0.0; dofs.ndofs()];
    out.par_chunks_mut(3 * POINT_CHUNK)
        .enumerate()
        .for_each(|(k, o)| {
            let first = k * POINT_CHUNK;
            let xs: Vec<[f64; 3]> = (first..first + o.len() / 3)
                .map(|a| grid.node_position(dofs.order, dofs.active_to_node[a] as usize))
                .collect();
            let mut values = vec![[0.0; 3]; xs.len()];
            tape.values(&xs, &mut values);
            o.copy_from_slice(values.as_flattened());
        });
    out
}

/// Points per batched evaluation of an exact field where the points are not
/// gathered per cell.
const POINT_CHUNK: usize = 1024;

/// Errors of `u_h` against the exact field.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ErrorNorms {
    /// `‖u − u_h‖_E`.
    pub energy: f64,
    /// `‖u − u_h‖_E / ‖u‖_E`.
    pub energy_relative: f64,
    /// `‖u − u_h‖_L2`.
    pub l2: f64,
    /// `‖u − u_h‖_L2 / ‖u‖_L2`.
    pub l2_relative: f64,
}

/// Energy and L2 errors, integrated with one Gauss point per direction more
/// than the element's on inside cells and with the cut-cell rules on cut cells.
pub fn error_norms(
    grid: &Grid,
    cells: &Cells,
    dofs: &DofMap,
    u_h: &[f64],
    exact: &VectorExpr,
    lambda: f64,
    mu: f64,
) -> ErrorNorms {
    ErrorNorms::from_sums(&error_sums(
        grid,
        cells,
        dofs,
        u_h,
        exact,
        lambda,
        mu,
        &|_| true,
    ))
}

/// The sums under [`error_norms`]' roots over the cells `counts` takes:
/// `[‖u − u_h‖²_E, ‖u‖²_E, ‖u − u_h‖²_L2, ‖u‖²_L2]` (the sums of a rank's
/// cells, to be added over the ranks; [`ErrorNorms::from_sums`]).
#[allow(clippy::too_many_arguments)]
pub fn error_sums(
    grid: &Grid,
    cells: &Cells,
    dofs: &DofMap,
    u_h: &[f64],
    exact: &VectorExpr,
    lambda: f64,
    mu: f64,
    counts: &(dyn Fn(usize) -> bool + Sync),
) -> [ExactSum; 4] {
    let [e] = error_norms_of(grid, cells, dofs, [u_h], exact, lambda, mu, counts);
    e
}

impl ErrorNorms {
    /// The norms from their sums ([`error_sums`]).
    pub fn from_sums(sums: &[ExactSum; 4]) -> ErrorNorms {
        let s = sums.each_ref().map(ExactSum::value);
        // `NaN.max(0.0)` is 0 in Rust: keep a NaN a NaN (null in the report).
        let root = |v: f64| if v.is_nan() { v } else { v.max(0.0).sqrt() };
        ErrorNorms {
            energy: root(s[0]),
            energy_relative: root(s[0] / s[1]),
            l2: s[2].sqrt(),
            l2_relative: (s[2] / s[3]).sqrt(),
        }
    }
}

/// [`error_sums`] of `N` fields in one pass: the exact field and its
/// gradient are evaluated once per quadrature point for all of them.
#[allow(clippy::too_many_arguments)]
fn error_norms_of<const N: usize>(
    grid: &Grid,
    cells: &Cells,
    dofs: &DofMap,
    fields: [&[f64]; N],
    exact: &VectorExpr,
    lambda: f64,
    mu: f64,
    counts: &(dyn Fn(usize) -> bool + Sync),
) -> [[ExactSum; 4]; N] {
    let rule = tensor_gauss_rule(dofs.order.gauss_points_per_axis() + 1);
    let shapes = ShapeTable::new(dofs.order, &rule, grid.h).0;
    let tape = exact.tape();
    let vol = grid.h.powi(3);
    // Per field: [energy of e, energy of u, L2 of e, L2 of u], weighted.
    type Sums<const N: usize> = [[f64; 4]; N];
    let cell_fields = |cell: usize| fields.map(|u_h| CellField::new(grid, dofs, u_h, cell));
    // The sums at one point from the exact value `ue` and gradient `ge` and
    // the fields' value and gradient `fe(field)`.
    let point = |ue: [f64; 3], ge: [[f64; 3]; 3], w: f64, fe: &dyn Fn(usize) -> Exact| -> Sums<N> {
        let energy_u = w * energy_density(&ge, lambda, mu);
        let ul2: f64 = (0..3).map(|i| ue[i].powi(2)).sum();
        std::array::from_fn(|f| {
            let (v, g) = fe(f);
            let e: [[f64; 3]; 3] =
                std::array::from_fn(|i| std::array::from_fn(|j| ge[i][j] - g[i][j]));
            let el2: f64 = (0..3).map(|i| (ue[i] - v[i]).powi(2)).sum();
            [
                w * energy_density(&e, lambda, mu),
                energy_u,
                w * el2,
                w * ul2,
            ]
        })
    };
    let add = |a: Sums<N>, b: Sums<N>| -> Sums<N> {
        std::array::from_fn(|f| std::array::from_fn(|k| a[f][k] + b[f][k]))
    };
    // Each cell's sums are taken in order over its points, then added to
    // the totals exactly: the norms do not depend on the threads' split
    // of the cells, nor on the ranks'.
    type Totals<const N: usize> = [[ExactSum; 4]; N];
    let add_cell = |mut t: Totals<N>, cell: Sums<N>| -> Totals<N> {
        for (tf, cf) in t.iter_mut().zip(cell) {
            for (tk, ck) in tf.iter_mut().zip(cf) {
                tk.add(ck);
            }
        }
        t
    };
    let merge = |mut a: Totals<N>, b: Totals<N>| -> Totals<N> {
        for (af, bf) in a.iter_mut().zip(&b) {
            for (ak, bk) in af.iter_mut().zip(bf) {
                ak.merge(bk);
            }
        }
        a
    };
    let totals =
        || -> Totals<N> { std::array::from_fn(|_| std::array::from_fn(|_| ExactSum::new())) };
    let zero = [[0.0; 4]; N];
    let inside: Vec<usize> = (0..grid.num_cells())
        .filter(|&c| cells.kinds[c] == CellKind::Inside && counts(c))
        .collect();
    let inside = inside
        .par_chunks(NORM_GROUP)
        .map(|group| {
            let xs = grid.rule_points(group, &rule);
            let (ue, ge) = exact_at(&tape, &xs);
            let mut k = 0;
            group.iter().fold(totals(), |acc, &c| {
                let fields = cell_fields(c);
                let cell = rule.iter().zip(&shapes).fold(zero, |acc, ((_, w), s)| {
                    k += 1;
                    add(
                        acc,
                        point(ue[k - 1], ge[k - 1], w * vol, &|f| {
                            fields[f].at(&fields[f].values, s)
                        }),
                    )
                });
                add_cell(acc, cell)
            })
        })
        .reduce(totals, merge);
    let cut: Vec<usize> = (0..cells.cut.len())
        .filter(|&i| counts(cells.cut[i]))
        .collect();
    let cut = cut
        .par_chunks(NORM_GROUP)
        .map(|group| {
            let points = |i: usize| cells.volume_points(i).iter();
            let xs: Vec<[f64; 3]> = group.iter().flat_map(|&i| points(i).map(|q| q.x)).collect();
            let (ue, ge) = exact_at(&tape, &xs);
            let mut k = 0;
            group.iter().fold(totals(), |acc, &i| {
                let fields = cell_fields(cells.cut[i]);
                let cell = points(i).fold(zero, |acc, q| {
                    k += 1;
                    let fe = |f: usize| fields[f].value_and_gradient(q.x);
                    add(acc, point(ue[k - 1], ge[k - 1], q.w, &fe))
                });
                add_cell(acc, cell)
            })
        })
        .reduce(totals, merge);
    merge(inside, cut)
}

/// Cells whose quadrature points [`error_norms_of`] evaluates the exact field
/// at in one batched call.
const NORM_GROUP: usize = 16;

/// A value and a gradient of a vector field.
type Exact = ([f64; 3], [[f64; 3]; 3]);

/// The values and gradients of the compiled field `tape` at `xs`.
fn exact_at(tape: &VectorTape, xs: &[[f64; 3]]) -> (Vec<[f64; 3]>, Vec<[[f64; 3]; 3]>) {
    let mut values = vec![[0.0; 3]; xs.len()];
    let mut gradients = vec![[[0.0; 3]; 3]; xs.len()];
    tape.values_and_gradients(xs, &mut values, &mut gradients);
    (values, gradients)
}

/// A nodal value of the exact field more than this many times its largest
/// magnitude sampled on the body marks a singularity of the field near an
/// active node outside the body ([`solution_and_interpolant_errors`]). A
/// smooth field extended by at most one cell stays within a small factor of
/// its values on the body (a factor 4 for the Lamé shell, whole, centred,
/// inner radius 0.5, at h = 0.25, whose nodes nearest the centre lie at half
/// the inner radius); a node at `1e-3` of the inner radius from the centre
/// gives `1e6`.
pub const SINGULAR_RATIO: f64 = 1e6;

/// The error norms of `u_h` ([`error_norms`]) and of the nodal interpolant
/// of `exact`, in one pass; for the interpolant, why its norms would mean
/// nothing instead: a nodal value of `exact` that is not finite or exceeds
/// [`SINGULAR_RATIO`] times the largest `|u|` sampled on the body (the centres
/// of inside cells and the volume points of cut cells), or norms that are
/// not finite.
pub fn solution_and_interpolant_errors(
    grid: &Grid,
    cells: &Cells,
    dofs: &DofMap,
    u_h: &[f64],
    exact: &VectorExpr,
    lambda: f64,
    mu: f64,
) -> (ErrorNorms, Result<ErrorNorms, String>) {
    let ui = interpolate(grid, dofs, exact);
    if let Err(why) = singular_node(grid, cells, dofs, exact, &ui) {
        let solution = error_norms(grid, cells, dofs, u_h, exact, lambda, mu);
        return (solution, Err(why));
    }
    let sums = error_norms_of(grid, cells, dofs, [u_h, &ui], exact, lambda, mu, &|_| true);
    let [solution, e] = sums.each_ref().map(ErrorNorms::from_sums);
    let all = [e.energy, e.energy_relative, e.l2, e.l2_relative];
    if all.iter().any(|v| !v.is_finite()) {
        let why = format!(
            "the interpolant's error norms are not finite (energy {}, L2 {})",
            e.energy, e.l2
        );
        return (solution, Err(why));
    }
    (solution, Ok(e))
}

/// Why the interpolant `ui` of `exact` is no reference: the first active node
/// where it is not finite or exceeds [`SINGULAR_RATIO`] times the largest
/// `|u|` sampled on the body.
fn singular_node(
    grid: &Grid,
    cells: &Cells,
    dofs: &DofMap,
    exact: &VectorExpr,
    ui: &[f64],
) -> Result<(), String> {
    let norm = |v: &[f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let tape = exact.tape();
    let largest = |xs: &[[f64; 3]]| {
        let mut values = vec![[0.0; 3]; xs.len()];
        tape.values(xs, &mut values);
        values.iter().map(norm).fold(0.0, f64::max)
    };
    let inside: Vec<usize> = (0..grid.num_cells())
        .filter(|&c| cells.kinds[c] == CellKind::Inside)
        .collect();
    let inside = inside
        .par_chunks(POINT_CHUNK)
        .map(|group| {
            let centre = |c: &usize| {
                let b = grid.cell_box(*c);
                [0, 1, 2].map(|a| 0.5 * (b.lo[a] + b.hi[a]))
            };
            largest(&group.iter().map(centre).collect::<Vec<_>>())
        })
        .reduce(|| 0.0, f64::max);
    let cut: Vec<usize> = (0..cells.cut.len()).collect();
    let cut = cut
        .par_chunks(NORM_GROUP)
        .map(|group| {
            let points = |i: &usize| cells.volume_points(*i).iter().map(|q| q.x);
            largest(&group.iter().flat_map(points).collect::<Vec<_>>())
        })
        .reduce(|| 0.0, f64::max);
    let scale = inside.max(cut);
    for (a, v) in ui.chunks(3).enumerate() {
        let m = norm(&[v[0], v[1], v[2]]);
        let singular = !m.is_finite() || (scale > 0.0 && m > SINGULAR_RATIO * scale);
        if singular {
            let x = grid.node_position(dofs.order, dofs.active_to_node[a] as usize);
            return Err(format!(
                "the exact field is singular at the active node ({:.6}, {:.6}, {:.6}) \
                 outside the body (|u| = {m:e} there, at most {scale:e} on the body)",
                x[0], x[1], x[2]
            ));
        }
    }
    Ok(())
}
