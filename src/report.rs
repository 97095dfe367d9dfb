//! `report.json`: the machine-readable summary of a run (DESIGN §8). Keys are
//! stable and documented in the README; a key whose stage has not run yet is
//! absent or `null`, never a made-up value.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::cells::{CellKind, Cells};
use crate::element::ElementOrder;
use crate::geometry::Geometry;
use crate::grid::Grid;

/// Cell counts by class.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct CellCounts {
    pub inside: usize,
    pub cut: usize,
    pub outside: usize,
    /// Cut cells with volume fraction below the stabilisation threshold A;
    /// `null` until the stabilisation is configured.
    pub pathological: Option<usize>,
    /// Cut cells of negligible volume merged into a neighbour (counted in
    /// `outside`).
    pub merged: usize,
}

/// Measures of the domain by the cut-cell quadrature.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Domain {
    pub volume: f64,
    pub boundary_area: f64,
    pub boundary_area_by_tag: BTreeMap<String, f64>,
}

/// `stabilisation`: the parameters used.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Stabilisation {
    pub k1: f64,
    pub k2: f64,
    #[serde(rename = "A")]
    pub a: f64,
}

/// `krylov`: the linear solves.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Krylov {
    pub method: String,
    pub preconditioner: String,
    pub iterations_per_solve: Vec<usize>,
    pub total_iterations: usize,
    pub final_relative_residual: f64,
    /// Zero or negative Jacobi diagonal entries at round-off level (cut artefacts) floored by
    /// the preconditioner instead of failing ([`crate::solver::DIAGONAL_FLOOR`]).
    pub floored_diagonal_entries: usize,
}

/// `fixed_point`: the recovery loop.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FixedPoint {
    /// `"fgmres"` or `"picard"` (`[solver] outer`).
    pub method: String,
    pub iterations: usize,
    pub eps_history: Vec<f64>,
    pub converged: bool,
}

/// `condition`: κ of the operator on the active dofs (DESIGN §3.5).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Condition {
    pub kappa: f64,
    pub kappa_jacobi: f64,
    /// True where only a lower bound could be given (then `method` says why).
    pub kappa_is_lower_bound: bool,
    pub kappa_jacobi_is_lower_bound: bool,
    pub method: String,
}

/// The report of a run.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Report {
    pub case: String,
    pub file: String,
    /// `"ok"`, `"failed"` or `"interrupted"` (Ctrl-C), the last two with `failure`.
    pub status: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
    pub level: u32,
    pub element: ElementOrder,
    pub backend: String,
    pub adapter: Option<String>,
    pub precision: String,
    pub h: f64,
    pub grid_cells: [usize; 3],
    pub dofs: usize,
    pub cells: CellCounts,
    pub domain: Domain,
    /// What loading the STL found, when the solid is a mesh.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh: Option<crate::mesh::MeshDiagnostics>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stabilisation: Option<Stabilisation>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fixed_point: Option<FixedPoint>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub krylov: Option<Krylov>,
    /// Errors against the exact field, when the case gives one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<crate::fem::field::ErrorNorms>,
    /// The same norms for the nodal interpolant of the exact field (the
    /// best-approximation reference): absent without an exact field,
    /// `Some(None)` (`null`) where they would mean nothing, with the reason
    /// in `interpolant_error_note` ([`crate::fem::field::interpolant_error`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interpolant_error: Option<Option<crate::fem::field::ErrorNorms>>,
    /// Why `interpolant_error` is `null`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interpolant_error_note: Option<String>,
    /// Condition numbers of the operator (`run --condition`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub condition: Option<Condition>,
    /// Total reaction force `Σ w_q λ_q` per Dirichlet boundary tag.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub reactions: BTreeMap<String, [f64; 3]>,
    /// Seconds per phase.
    pub timings: BTreeMap<String, f64>,
}

impl Report {
    /// The geometric part of a report: grid, cells, dofs and domain measures.
    pub fn geometry(
        case: &str,
        file: &str,
        order: ElementOrder,
        geometry: &Geometry,
        grid: &Grid,
        cells: &Cells,
    ) -> Report {
        let outside = cells
            .kinds
            .iter()
            .filter(|k| **k == CellKind::Outside)
            .count();
        let mut by_tag: BTreeMap<String, f64> = geometry
            .tag_names()
            .iter()
            .map(|t| (t.clone(), 0.0))
            .collect();
        for p in &cells.surface {
            *by_tag.get_mut(geometry.tag_name(p.tag)).expect("known tag") += p.w;
        }
        let (_, active) = cells.active_nodes(grid, order);
        Report {
            case: case.into(),
            file: file.into(),
            status: "ok".into(),
            failure: None,
            level: grid.level,
            element: order,
            backend: "cpu".into(),
            adapter: None,
            precision: "f64".into(),
            h: grid.h,
            grid_cells: grid.n,
            dofs: 3 * active,
            cells: CellCounts {
                inside: cells.num_inside,
                cut: cells.cut.len(),
                outside,
                pathological: None,
                merged: cells.merged,
            },
            domain: Domain {
                volume: cells.volume(grid),
                boundary_area: cells.boundary_area(),
                boundary_area_by_tag: by_tag,
            },
            mesh: geometry.mesh().map(|m| m.diagnostics().clone()),
            stabilisation: None,
            fixed_point: None,
            krylov: None,
            error: None,
            interpolant_error: None,
            interpolant_error_note: None,
            condition: None,
            reactions: BTreeMap::new(),
            timings: BTreeMap::new(),
        }
    }
}

/// One body of a multi-body report: its grid, cells and domain.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct BodyReport {
    pub name: String,
    pub level: u32,
    pub h: f64,
    pub grid_cells: [usize; 3],
    pub dofs: usize,
    pub plane_strain: bool,
    pub cells: CellCounts,
    pub domain: Domain,
}

impl BodyReport {
    /// The body `name` on its grid and cells (Q1).
    pub fn new(
        name: &str,
        geometry: &Geometry,
        grid: &Grid,
        cells: &Cells,
        plane_strain: bool,
    ) -> BodyReport {
        let r = Report::geometry(name, "", ElementOrder::Q1, geometry, grid, cells);
        BodyReport {
            name: name.into(),
            level: r.level,
            h: r.h,
            grid_cells: r.grid_cells,
            dofs: r.dofs,
            plane_strain,
            cells: r.cells,
            domain: r.domain,
        }
    }
}

/// `newton` of a load step: its iterations and histories.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct NewtonHistory {
    /// Newton updates made.
    pub iterations: usize,
    /// `‖R_k‖ / ‖R_0‖`, from `k = 0`.
    pub residual_history: Vec<f64>,
    /// `|Δu_k · R_k| / |Δu_0 · R_0|` per linear solve.
    pub energy_history: Vec<f64>,
    /// Line-search step length per update.
    pub line_search: Vec<f64>,
    /// The estimated order `q` of the last iterations of the first pass, and `C` of
    /// `δ_n = C δ_{n−1}²`, from the corrections' energy norms
    /// (see [`crate::hyper::convergence`]); absent with fewer than three
    /// corrections above round-off.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub convergence_order: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quadratic_constant: Option<f64>,
}

/// One attempt at a load step (failed attempts are followed by a cut one).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct LoadStepRow {
    /// The load step (from 1) this attempt tried to reach.
    pub step: usize,
    pub load_factor: f64,
    pub converged: bool,
    /// Halvings of the nominal increment at this attempt.
    pub cuts: usize,
    pub newton: NewtonHistory,
    /// Krylov iterations per linear solve.
    pub krylov_iterations: Vec<usize>,
    /// The Newton passes of the fixed point on recovered terms (one without).
    pub passes: Vec<crate::hyper::newton::PassReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
}

/// `reactions {body, part, step, force}`: the resultant of a Dirichlet part
/// at a converged load step.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ReactionRow {
    pub body: String,
    /// The boundary part's tag.
    pub part: String,
    pub step: usize,
    /// The force the prescribed displacement exerts on the body.
    pub force: [f64; 3],
}

/// The report of a multi-body (large-deformation) run.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct BodiesReport {
    pub case: String,
    pub file: String,
    /// `"ok"`, `"failed"` or `"interrupted"`, the last two with `failure`.
    pub status: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
    /// `"cpu"`, or `"gpu"` when the inside-cell tangents ran on `adapter`.
    pub backend: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adapter: Option<String>,
    /// Unknowns of all bodies, and those held at zero (plane strain).
    pub dofs: usize,
    pub held_dofs: usize,
    pub bodies: Vec<BodyReport>,
    /// Nominal load steps, and the converged ones.
    pub steps: usize,
    pub converged_steps: usize,
    /// The last converged load factor.
    pub load_factor: f64,
    pub load_steps: Vec<LoadStepRow>,
    /// Per contact pair and converged load step.
    pub contact: Vec<crate::contact::ContactRow>,
    /// Per body, Dirichlet part and converged load step.
    pub reactions: Vec<ReactionRow>,
    /// Seconds per phase.
    pub timings: BTreeMap<String, f64>,
}
