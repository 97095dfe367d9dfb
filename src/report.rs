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
}

/// `fixed_point`: the recovery loop.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FixedPoint {
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
    /// best-approximation reference).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interpolant_error: Option<crate::fem::field::ErrorNorms>,
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
            },
            domain: Domain {
                volume: cells.volume(grid),
                boundary_area: cells.boundary_area(),
                boundary_area_by_tag: by_tag,
            },
            stabilisation: None,
            fixed_point: None,
            krylov: None,
            error: None,
            interpolant_error: None,
            condition: None,
            reactions: BTreeMap::new(),
            timings: BTreeMap::new(),
        }
    }
}
