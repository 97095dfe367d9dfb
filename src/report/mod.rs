//! `report.json`: the machine-readable summary of a run, one
//! schema for both solution paths: the run's keys, then the bodies as rows
//! (`bodies`, [`BodyReport`]), then what the path measured (the linear fixed
//! point's `fixed_point`, `krylov` and `condition`; Newton's load steps and
//! contact rows, [`newton`]), and the reactions as rows. Keys are stable and
//! documented in the README; a key whose stage has not run yet is absent or
//! `null`, never a made-up value.

pub mod newton;

use std::collections::BTreeMap;

use serde::Serialize;

use crate::case::physics::SolverSpec;
use crate::cells::glued::{glued_nodes, nodes_box};
use crate::cells::{CellKind, Cells};
use crate::discrete::dofs::DofMap;
use crate::driver::fixed_point::FixedPointReport;
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
    /// Cut cells where a mesh with defects does not bound a solid, given the
    /// first-order repaired rule (counted in `cut`).
    pub repaired: usize,
    /// The box of the repaired cells, `[min, max]`, when there are some.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub repaired_box: Option<[[f64; 3]; 2]>,
    /// Grid vertices whose cells hold parts of the body that do not meet
    /// inside them (a slot, gap or hole narrower than about two cells): the vertex's one
    /// unknown glues those parts together ([`crate::cells::glued`]).
    pub glued_nodes: usize,
    /// The box of the glued vertices' cells, `[min, max]`, when there are
    /// some.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub glued_box: Option<[[f64; 3]; 2]>,
    /// Grid vertices given one set of unknowns per part of the body around
    /// them, so those parts move apart ([`crate::cells::split`]); they are
    /// not glued.
    pub split_nodes: usize,
    /// The box of the split vertices' cells, `[min, max]`, when there are
    /// some.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split_box: Option<[[f64; 3]; 2]>,
    /// The glued vertices, ascending.
    #[serde(skip)]
    glued: Vec<usize>,
}

impl CellCounts {
    /// Keeps the glued vertices that `keep` takes (a rank's own).
    pub fn keep_glued(&mut self, grid: &Grid, keep: impl Fn(usize) -> bool) {
        self.glued.retain(|&v| keep(v));
        self.glued_nodes = self.glued.len();
        self.glued_box = nodes_box(grid, &self.glued).map(|b| [b.lo, b.hi]);
    }

    /// Records the vertices that `dofs` copies: they are split, no longer
    /// glued.
    pub fn record_split(&mut self, grid: &Grid, dofs: &DofMap) {
        let mut split: Vec<usize> = dofs.copies().map(|(_, node)| node).collect();
        split.dedup();
        self.glued.retain(|v| split.binary_search(v).is_err());
        self.glued_nodes = self.glued.len();
        self.glued_box = nodes_box(grid, &self.glued).map(|b| [b.lo, b.hi]);
        self.split_nodes = split.len();
        self.split_box = nodes_box(grid, &split).map(|b| [b.lo, b.hi]);
    }
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

impl Krylov {
    /// The row of a linear run's solves: `spec`'s method and preconditioner
    /// (as the run took it), and the loop's counts.
    pub fn of(spec: &SolverSpec, fp: &FixedPointReport) -> Krylov {
        Krylov {
            method: spec.method.name().into(),
            preconditioner: format!("{:?}", spec.preconditioner).to_lowercase(),
            iterations_per_solve: fp.iterations_per_solve.clone(),
            total_iterations: fp.total_iterations,
            final_relative_residual: fp.final_relative_residual,
            floored_diagonal_entries: fp.floored_diagonal_entries,
        }
    }
}

impl FixedPoint {
    /// The row of a linear run's outer loop.
    pub fn of(spec: &SolverSpec, fp: &FixedPointReport) -> FixedPoint {
        FixedPoint {
            method: spec.outer.name().into(),
            iterations: fp.iterations,
            eps_history: fp.eps_history.clone(),
            converged: fp.converged,
        }
    }
}

/// `condition`: κ of the operator on the active dofs.
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
    /// `"linear"` or `"newton"` ([`crate::case::SolutionPath`]).
    pub path: String,
    /// Why the case runs Newton.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub path_reason: Option<String>,
    /// `"ok"`, `"failed"` or `"interrupted"` (Ctrl-C), the last two with `failure`.
    pub status: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
    /// `"cpu"`, or `"gpu"` when the solve (linear path) or the inside-cell
    /// tangents (Newton path) ran on `adapter`.
    pub backend: String,
    pub adapter: Option<String>,
    pub precision: String,
    /// Unknowns of all bodies, and those held at zero (plane strain).
    pub dofs: usize,
    pub held_dofs: usize,
    pub bodies: Vec<BodyReport>,
    pub stabilisation: Stabilisation,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fixed_point: Option<FixedPoint>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub krylov: Option<Krylov>,
    /// Condition numbers of the operator (`run --condition`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub condition: Option<Condition>,
    /// Newton path: the load steps.
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub load: Option<newton::LoadReport>,
    /// Per contact pair and converged load step.
    pub contact: Vec<crate::contact::ContactRow>,
    /// Per body, Dirichlet part and converged load step (the linear path
    /// is one step).
    pub reactions: Vec<newton::ReactionRow>,
    /// Seconds per phase.
    pub timings: BTreeMap<String, f64>,
    /// A run on several ranks: each rank's share.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub ranks: Vec<RankRow>,
}

/// One rank of a distributed run.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct RankRow {
    pub rank: usize,
    /// The rank's brick of cells, `[lo, hi)` by cell index.
    pub brick: [[usize; 3]; 2],
    /// Inside and cut cells of the brick.
    pub inside: usize,
    pub cut: usize,
    /// Unknowns owned, and held as ghosts (brought from their owners).
    pub owned_dofs: usize,
    pub ghost_dofs: usize,
    /// Bytes received in one ghost exchange (one operator apply).
    pub halo_bytes_per_apply: usize,
    pub setup_seconds: f64,
    pub solve_seconds: f64,
    /// Peak resident memory of the rank's process.
    pub peak_bytes: u64,
}

impl Report {
    /// A report of `case` before anything is solved: the bodies are added
    /// by the path that sets them up.
    pub fn new(case: &crate::case::Case) -> Report {
        let (path, path_reason) = match &case.path {
            crate::case::SolutionPath::Linear => ("linear", None),
            crate::case::SolutionPath::Newton(why) => ("newton", Some(why.clone())),
        };
        let st = &case.spec.stabilisation;
        Report {
            case: case.spec.name.clone().unwrap_or_else(|| "case".into()),
            file: case.file.clone(),
            path: path.into(),
            path_reason,
            status: "ok".into(),
            failure: None,
            backend: "cpu".into(),
            adapter: None,
            precision: "f64".into(),
            dofs: 0,
            held_dofs: 0,
            bodies: Vec::new(),
            stabilisation: Stabilisation {
                k1: st.k1,
                k2: st.k2,
                a: st.threshold(case.body().spec.element),
            },
            fixed_point: None,
            krylov: None,
            condition: None,
            load: None,
            contact: Vec::new(),
            reactions: Vec::new(),
            timings: BTreeMap::new(),
            ranks: Vec::new(),
        }
    }

    /// The load steps of a Newton run (none on the linear path).
    pub fn load_steps(&self) -> &[newton::LoadStepRow] {
        self.load.as_ref().map_or(&[], |l| &l.load_steps)
    }

    /// Adds a body's row (and its unknowns to `dofs`).
    pub fn push_body(&mut self, body: BodyReport) {
        self.dofs += body.dofs;
        self.bodies.push(body);
    }

    /// Marks the report failed (or interrupted) with `e`.
    pub fn fail(&mut self, e: &crate::Error) {
        self.status = match e {
            crate::Error::Interrupted { .. } => "interrupted",
            _ => "failed",
        }
        .into();
        self.failure = Some(e.to_string());
    }
}

/// One body of a report: its grid, cells and domain, and its errors against
/// the exact field where it has one.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct BodyReport {
    pub name: String,
    /// `"linear"`, `"neo_hookean"` or `"st_venant_kirchhoff"`.
    pub model: crate::case::Model,
    pub element: ElementOrder,
    pub level: u32,
    pub h: f64,
    pub grid_cells: [usize; 3],
    pub dofs: usize,
    pub plane_strain: bool,
    pub cells: CellCounts,
    pub domain: Domain,
    /// What loading the STL found, when the solid is a mesh or has one (the
    /// first `stl` node of its geometry; stderr notes each).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh: Option<crate::mesh::MeshDiagnostics>,
    /// Errors against the exact field, when the body has one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<crate::discrete::field::ErrorNorms>,
    /// The same norms for the nodal interpolant of the exact field (the
    /// best-approximation reference): absent without an exact field,
    /// `Some(None)` (`null`) where they would mean nothing, with the reason
    /// in `interpolant_error_note` ([`crate::discrete::field::solution_and_interpolant_errors`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interpolant_error: Option<Option<crate::discrete::field::ErrorNorms>>,
    /// Why `interpolant_error` is `null`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interpolant_error_note: Option<String>,
}

impl BodyReport {
    /// Body `name` of `model` and element `order` on its grid and cells:
    /// grid, cells, dofs and domain measures.
    pub fn new(
        name: &str,
        model: crate::case::Model,
        order: ElementOrder,
        geometry: &Geometry,
        grid: &Grid,
        cells: &Cells,
        plane_strain: bool,
    ) -> BodyReport {
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
        let glued = glued_nodes(grid, cells, geometry);
        BodyReport {
            name: name.into(),
            model,
            element: order,
            level: grid.level,
            h: grid.h,
            grid_cells: grid.n,
            dofs: 3 * active,
            plane_strain,
            cells: CellCounts {
                inside: cells.num_inside,
                cut: cells.cut.len(),
                outside,
                pathological: None,
                merged: cells.merged.len(),
                repaired: cells.repaired.len(),
                repaired_box: (!cells.repaired.is_empty()).then(|| {
                    let b = cells
                        .repaired
                        .iter()
                        .fold(grid.cell_box(cells.repaired[0]), |b, &c| {
                            b.union(&grid.cell_box(c))
                        });
                    [b.lo, b.hi]
                }),
                glued_nodes: glued.len(),
                glued_box: nodes_box(grid, &glued).map(|b| [b.lo, b.hi]),
                split_nodes: 0,
                split_box: None,
                glued,
            },
            domain: Domain {
                volume: cells.volume(grid),
                boundary_area: cells.boundary_area(),
                boundary_area_by_tag: by_tag,
            },
            mesh: geometry.meshes().first().map(|m| m.diagnostics().clone()),
            error: None,
            interpolant_error: None,
            interpolant_error_note: None,
        }
    }
}
