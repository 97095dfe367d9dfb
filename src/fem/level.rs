//! The operator of a case on one grid, `K + K_p (+ K_S)`, with its
//! pathological cells: what the set-up builds on the case's grid and what a
//! multigrid level rebuilds on a coarser one.

use crate::case::physics::StabilisationSpec;
use crate::case::Case;
use crate::cells::Cells;
use crate::discrete::dofs::DofMap;
use crate::element::ElementOrder;
use crate::fem::operator::{ElasticOperator, OperatorParams};
use crate::fem::problem::Problem;
use crate::grid::Grid;

/// Pathological cells: cut cells with `0 < A_c < a`, ascending.
pub fn pathological_cells(cells: &Cells, a: f64) -> Vec<usize> {
    cells
        .cut
        .iter()
        .zip(&cells.fraction)
        .filter(|(_, &f)| f > 0.0 && f < a)
        .map(|(&c, _)| c)
        .collect()
}

/// The operator `K + K_p (+ K_S)` of a case on one grid with its own cut-cell
/// rules: what [`crate::driver::setup::Setup`] builds on the case's grid and what a multigrid level
/// ([`crate::multigrid`]) rebuilds on a coarser one.
pub struct LevelOperator {
    pub op: ElasticOperator,
    /// The Dirichlet penalty `β = k1 E`.
    pub beta: f64,
    /// Pathological cells (Ω*) of this grid, ascending.
    pub omega_star: Vec<usize>,
    /// `k2 E / h²`: the weight of the S-term on this grid (0 when it is off).
    pub s_factor: f64,
}

impl LevelOperator {
    /// `K + K_p` on the unknowns `dofs` of `grid` classified as `cells`,
    /// plus `(k2 E / h²) M_c` on the pathological cells of the element's
    /// threshold.
    pub fn new(
        case: &Case,
        problem: &Problem,
        grid: &Grid,
        cells: &Cells,
        dofs: DofMap,
    ) -> LevelOperator {
        let k2 = case.spec.stabilisation.k2;
        LevelOperator::on_dofs(case, problem, grid, cells, dofs, k2)
    }

    /// [`LevelOperator::new`] with the S-term's weight `k2`; `0` for a
    /// multigrid level, which takes the S-term of the solve's level instead
    /// ([`crate::multigrid::galerkin_s`]).
    pub fn with_k2(
        case: &Case,
        problem: &Problem,
        grid: &Grid,
        cells: &Cells,
        order: ElementOrder,
        k2: f64,
    ) -> LevelOperator {
        let dofs = DofMap::new(grid, cells, order);
        LevelOperator::on_dofs(case, problem, grid, cells, dofs, k2)
    }

    /// [`LevelOperator::with_k2`] on the unknowns `dofs`.
    fn on_dofs(
        case: &Case,
        problem: &Problem,
        grid: &Grid,
        cells: &Cells,
        dofs: DofMap,
        k2: f64,
    ) -> LevelOperator {
        let params = OperatorParams {
            young: problem.young,
            poisson: problem.poisson,
            beta: case.spec.stabilisation.k1 * problem.young,
            dirichlet: &|tag, x| problem.dirichlet_mask(tag, x),
        };
        let st = StabilisationSpec {
            k2,
            ..case.spec.stabilisation.clone()
        };
        LevelOperator::with_params(grid, cells, dofs, &params, &st)
    }

    /// [`LevelOperator::new`] from the operator's parameters and the
    /// stabilisation settings (`k2`, `A`; `params.beta` is the penalty), on
    /// the unknowns of `dofs`.
    pub fn with_params(
        grid: &Grid,
        cells: &Cells,
        dofs: DofMap,
        params: &OperatorParams,
        st: &StabilisationSpec,
    ) -> LevelOperator {
        let mut op = ElasticOperator::with_dofs(grid, cells, dofs, params);
        let mut omega_star = pathological_cells(cells, st.threshold(op.dofs.order));
        // A split cell's pieces have no S-term: its recovered displacement
        // would mix them.
        omega_star.retain(|&c| op.dofs.split.cell(c).is_none());
        let s_factor = st.k2 * params.young / (grid.h * grid.h);
        if s_factor > 0.0 {
            for &c in &omega_star {
                op.add_cut_cell_mass(c, s_factor);
            }
        }
        LevelOperator {
            op,
            beta: params.beta,
            omega_star,
            s_factor,
        }
    }
}
