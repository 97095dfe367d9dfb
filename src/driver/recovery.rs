//! Stress recovery for the fixed-point loop and the output: SPR
//! of degree p of the FE stress on the patches of Q1 vertex nodes, sampled at
//! [`sample_positions`], blended by CPE (both orders use the vertex patches of
//! the cell grid: Q1 fits {1, x, y, z} to the 2×2×2 Gauss points of the
//! patch's cells, Q2 the complete quadratic, 10 terms, to the 3×3×3 ones); the recovered traction `t̂ = σ̂ n` at the Dirichlet points, and the
//! reactions `λ_q = t̂_q − (β/h)(u_h(x_q) − g_q)`.

use std::sync::OnceLock;

use rayon::prelude::*;

use super::setup::Setup;
use crate::cells::CellKind;
use crate::discrete::field::{stress_voigt, value_and_gradient, CellField, ShapeTable};
use crate::element::{tensor_gauss_rule, ElementOrder};
use crate::error::Result;
use crate::fem::rhs::DirichletPoint;
use crate::recovery::{
    plan_fits, recover_around, recover_planned, FitPlans, InsideMoments, Monomials, PatchSamples,
    Recovered, Sample, SprOptions,
};

/// The Q1 vertex nodes of the cells holding Dirichlet points and of the cells
/// whose flux correction uses the recovered stress (the patches the traction
/// needs), ascending.
pub fn traction_patch_nodes(setup: &Setup) -> Vec<usize> {
    let mut cells: Vec<usize> = setup.dirichlet.iter().map(|p| p.cell).collect();
    cells.extend(setup.flux.recovered_cells().map(|i| setup.cells.cut[i]));
    cells.sort_unstable();
    cells.dedup();
    vertex_nodes_of(setup, &cells)
}

/// The Q1 vertex nodes of the given cells, ascending and distinct.
pub fn vertex_nodes_of(setup: &Setup, cells: &[usize]) -> Vec<usize> {
    let grid = &setup.grid;
    let mut v = [0usize; 8];
    // Few cells: sort their nodes; many: mark them on the lattice.
    if 8 * cells.len() < grid.num_nodes(ElementOrder::Q1) / 8 {
        let mut nodes = Vec::with_capacity(8 * cells.len());
        for &c in cells {
            grid.cell_nodes(ElementOrder::Q1, c, &mut v);
            nodes.extend_from_slice(&v);
        }
        nodes.sort_unstable();
        nodes.dedup();
        return nodes;
    }
    let mut marked = vec![false; grid.num_nodes(ElementOrder::Q1)];
    for &c in cells {
        grid.cell_nodes(ElementOrder::Q1, c, &mut v);
        v.iter().for_each(|&n| marked[n] = true);
    }
    (0..marked.len()).filter(|&n| marked[n]).collect()
}

/// The SPR sample points of a cell (stress and displacement recovery alike):
/// the Gauss points `rule` of an inside cell; in a cut cell its base rule's
/// points, at most [`crate::cells::MAX_FIT_POINTS`]
/// ([`crate::cells::Cells::fit_points`]).
pub fn sample_positions(
    setup: &Setup,
    cell: usize,
    rule: &[([f64; 3], f64)],
    out: &mut Vec<[f64; 3]>,
) {
    let grid = &setup.grid;
    match setup.cells.kinds[cell] {
        CellKind::Inside => {
            let lo = grid.cell_box(cell).lo;
            out.extend(
                rule.iter()
                    .map(|(xi, _)| [0, 1, 2].map(|a| lo[a] + grid.h * xi[a])),
            );
        }
        CellKind::Cut => {
            let i = setup
                .cells
                .cut_position(cell)
                .expect("a cut cell is in the cut list");
            out.extend(setup.cells.fit_points(i, crate::cells::MAX_FIT_POINTS));
        }
        CellKind::Outside => {}
    }
}

/// SPR of the stress of `u` on the patches of `nodes`, reusing the fits of
/// an earlier recovery on the same patches when `plans` holds them (see
/// [`crate::recovery::recover_planned`]).
pub fn recover_stress(
    setup: &Setup,
    u: &[f64],
    nodes: &[usize],
    plans: Option<&OnceLock<FitPlans>>,
) -> Result<Recovered<6>> {
    recover_planned(
        &setup.grid,
        &setup.cells.kinds,
        nodes,
        setup.op.dofs.order.degree(),
        &stress_samples(setup, u),
        &stress_options(setup),
        plans,
    )
}

/// Makes the fit plans of [`recover_stress`] on `nodes` in `plans`, from
/// the sample positions alone: a fit's patch, acceptance and factor do not
/// depend on the values, so the samples are taken as zero.
pub fn plan_stress(setup: &Setup, nodes: &[usize], plans: &OnceLock<FitPlans>) -> Result<()> {
    let rule = tensor_gauss_rule(setup.op.dofs.order.gauss_points_per_axis());
    let zero = |cell: usize, out: &mut Vec<Sample<6>>| {
        let mut xs = Vec::new();
        sample_positions(setup, cell, &rule, &mut xs);
        out.extend(xs.into_iter().map(|x| (x, [0.0; 6])));
    };
    plan_fits(
        &setup.grid,
        &setup.cells.kinds,
        nodes,
        setup.op.dofs.order.degree(),
        &zero,
        &stress_options(setup),
        plans,
    )
}

/// [`recover_stress`] on `nodes` without plans, taking the fits of the
/// nodes that `known` (a stress recovery of the same `u`) holds from it.
pub fn recover_stress_around(
    setup: &Setup,
    u: &[f64],
    nodes: &[usize],
    known: Option<&Recovered<6>>,
) -> Result<Recovered<6>> {
    recover_around(
        &setup.grid,
        &setup.cells.kinds,
        nodes,
        setup.op.dofs.order.degree(),
        &stress_samples(setup, u),
        &stress_options(setup),
        known,
    )
}

/// The stress of `u` at the [`sample_positions`] of a cell, and an inside
/// cell's moments as one product with its nodal values.
struct StressSamples<'a> {
    setup: &'a Setup,
    u: &'a [f64],
    rule: Vec<([f64; 3], f64)>,
    /// An inside cell's samples are the rule's points: their shape
    /// functions are the same in every inside cell.
    table: ShapeTable,
    inside: InsideMoments,
}

/// [`StressSamples`] of `u`.
fn stress_samples<'a>(setup: &'a Setup, u: &'a [f64]) -> StressSamples<'a> {
    let (lambda, mu) = (setup.problem.lambda, setup.problem.mu);
    let order = setup.op.dofs.order;
    let rule = tensor_gauss_rule(order.gauss_points_per_axis());
    let table = ShapeTable::new(order, &rule, setup.grid.h);
    let xi: Vec<[f64; 3]> = rule.iter().map(|(x, _)| *x).collect();
    // The stress of the unit nodal value `k = 3a + i` at point `q`.
    let unit = |q: usize, c: usize, k: usize| {
        let mut g = [[0.0; 3]; 3];
        g[k % 3] = table.gradients(q)[k / 3];
        stress_voigt(&g, lambda, mu)[c]
    };
    let cols = 3 * order.nodes_per_cell();
    let inside = InsideMoments::new(order.degree(), &xi, 6, cols, unit);
    StressSamples {
        setup,
        u,
        rule,
        table,
        inside,
    }
}

impl PatchSamples<6> for StressSamples<'_> {
    fn samples(&self, cell: usize, out: &mut Vec<Sample<6>>) {
        let (lambda, mu) = (self.setup.problem.lambda, self.setup.problem.mu);
        let mut xs = Vec::new();
        sample_positions(self.setup, cell, &self.rule, &mut xs);
        let field = CellField::new(&self.setup.grid, &self.setup.op.dofs, self.u, cell);
        let inside = self.setup.cells.kinds[cell] == CellKind::Inside;
        out.extend(xs.into_iter().enumerate().map(|(q, x)| {
            let (_, g) = match inside {
                true => field.at_tabulated(&self.table, q),
                false => field.value_and_gradient(x),
            };
            (x, stress_voigt(&g, lambda, mu))
        }));
    }

    fn moments(&self, cell: usize, basis: &Monomials, out: &mut [f64]) -> bool {
        inside_moments(self.setup, self.u, cell, &self.inside, basis, out)
    }
}

/// An inside cell's moments `M u_cell` ([`InsideMoments`]) of the field
/// `u`; `false` for any other cell.
pub(super) fn inside_moments(
    setup: &Setup,
    u: &[f64],
    cell: usize,
    inside: &InsideMoments,
    basis: &Monomials,
    out: &mut [f64],
) -> bool {
    if setup.cells.kinds[cell] != CellKind::Inside {
        return false;
    }
    let npc = setup.op.dofs.order.nodes_per_cell();
    let mut nodes = [0usize; 27];
    setup
        .op
        .dofs
        .cell_active_nodes(&setup.grid, cell, &mut nodes[..npc]);
    let mut values = [0.0; 81];
    for (v, &node) in values.chunks_exact_mut(3).zip(&nodes[..npc]) {
        v.copy_from_slice(&u[3 * node..3 * node + 3]);
    }
    inside.moments(basis, &values[..3 * npc], out)
}

/// The stress recovery's options: patches keep to their node's piece.
fn stress_options(setup: &Setup) -> SprOptions<'_> {
    SprOptions {
        pieces: Some(&setup.pieces.of_cell),
        ..SprOptions::default()
    }
}

/// `t̂ = M σ̂ n` at the Dirichlet points (`M` the mask of the held components),
/// the blend of each run of points in one cell prepared once.
pub fn recovered_tractions(
    points: &[DirichletPoint],
    sigma: &Recovered<6>,
) -> Result<Vec<[f64; 3]>> {
    let runs: Vec<&[DirichletPoint]> = points.chunk_by(|a, b| a.cell == b.cell).collect();
    let per_run: Vec<Vec<[f64; 3]>> = runs
        .par_iter()
        .map(|run| {
            let blend = sigma.cell_blend(run[0].cell)?;
            Ok(run
                .iter()
                .map(|p| {
                    let t = voigt_times(&blend.eval(p.x), p.n);
                    [0, 1, 2].map(|i| p.mask[i] * t[i])
                })
                .collect())
        })
        .collect::<Result<_>>()?;
    Ok(per_run.concat())
}

/// `σ n` for a Voigt stress (xx, yy, zz, yz, xz, xy).
pub fn voigt_times(s: &[f64; 6], n: [f64; 3]) -> [f64; 3] {
    [
        s[0] * n[0] + s[5] * n[1] + s[4] * n[2],
        s[5] * n[0] + s[1] * n[1] + s[3] * n[2],
        s[4] * n[0] + s[3] * n[1] + s[2] * n[2],
    ]
}

/// `λ_q = t̂_q − (β/h) M_q (u_h(x_q) − g_q)` at each Dirichlet point.
pub fn reactions(setup: &Setup, u: &[f64], t_hat: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let k = setup.beta / setup.grid.h;
    setup
        .dirichlet
        .iter()
        .zip(t_hat)
        .map(|(p, t)| {
            let (v, _) = value_and_gradient(&setup.grid, &setup.op.dofs, u, p.cell, p.x);
            [0, 1, 2].map(|i| t[i] - k * p.mask[i] * (v[i] - p.g[i]))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::case::Case;

    /// An inside cell's stress moments from its nodal values equal the
    /// moments of its stress samples, on the paper's sphere at level 3.
    #[test]
    fn inside_stress_moments_equal_the_moments_of_the_samples() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/sphere.toml");
        let case = Case::from_file(&path).unwrap();
        let setup = Setup::new(&case, Some(3)).unwrap();
        let u: Vec<f64> = (0..setup.op.dofs.ndofs())
            .map(|k| (0.37 * k as f64).sin())
            .collect();
        let samples = stress_samples(&setup, &u);
        let basis = Monomials::new(1);
        let (mut got, mut want) = (vec![0.0; 24], vec![0.0; 24]);
        let (mut buf, mut phi) = (Vec::new(), vec![0.0; 4]);
        let inside =
            (0..setup.grid.num_cells()).filter(|&c| setup.cells.kinds[c] == CellKind::Inside);
        let mut checked = 0;
        for cell in inside {
            assert!(samples.moments(cell, &basis, &mut got));
            buf.clear();
            samples.samples(cell, &mut buf);
            want.fill(0.0);
            let b = setup.grid.cell_box(cell);
            let centre = [0, 1, 2].map(|a| 0.5 * (b.lo[a] + b.hi[a]));
            for (x, v) in &buf {
                basis.values(
                    [0, 1, 2].map(|a| (x[a] - centre[a]) / setup.grid.h),
                    &mut phi,
                );
                for (j, p) in phi.iter().enumerate() {
                    for c in 0..6 {
                        want[j * 6 + c] += p * v[c];
                    }
                }
            }
            let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (a, b) in want.iter().zip(&got) {
                assert!((a - b).abs() <= 1e-12 * scale, "cell {cell}: {a} {b}");
            }
            checked += 1;
        }
        assert!(checked > 0);
        let cut = setup.cells.cut[0];
        assert!(!samples.moments(cut, &basis, &mut got));
    }
}
