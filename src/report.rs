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

/// The report of a run.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Report {
    pub case: String,
    pub file: String,
    pub status: String,
    pub level: u32,
    pub element: ElementOrder,
    pub h: f64,
    pub grid_cells: [usize; 3],
    pub dofs: usize,
    pub cells: CellCounts,
    pub domain: Domain,
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
            level: grid.level,
            element: order,
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
            timings: BTreeMap::new(),
        }
    }
}
