//! `cgfem-gpu geometry CASE`: what the program sees of a case's solid,
//! written without solving, so that a part and its boundary parts can be
//! checked in ParaView before a long run.
//!
//! Into the output folder go, per body, `cells.vtu` (the grid cells that meet
//! the body, as hexahedra, with `cell_class` 1 inside / 2 cut and
//! `volume_fraction`) and `boundary.vtp` (the boundary quadrature points with
//! their `tag` id, unit outward `normal` and `weight`; the ids index the
//! body's `boundary_tags` in the report), named `<body>.cells.vtu` and
//! `<body>.boundary.vtp` when the case has several bodies; and `report.json`
//! (the geometric part of a run's report: per body its grid, cell counts,
//! volume and area per boundary part, and for an STL part the mesh
//! diagnostics). Nothing is written when classifying fails.

use std::path::Path;

use serde::Serialize;

use crate::case::Case;
use crate::cells::CellKind;
use crate::cells::Cells;
use crate::driver::output::body_mesh;
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::output::write_atomic;
use crate::progress::Progress;
use crate::report::{BodyReport, Report};
use crate::vtu::{write_vtp_points, write_vtu, DataArray, VtuEncoding, VtuMesh};

/// `report.json` of the `geometry` command.
#[derive(Clone, Debug, Serialize)]
pub struct GeometryReport {
    #[serde(flatten)]
    pub report: Report,
    /// Per body, its tag names by id, as its `boundary.vtp`'s `tag`
    /// numbers them.
    pub boundary_tags: std::collections::BTreeMap<String, Vec<String>>,
}

/// Classifies every body of `case` at `level` (default: the case's) and
/// writes the files into `dir` (created if needed).
pub fn write_geometry(
    case: &Case,
    level: Option<u32>,
    dir: &Path,
    progress: &dyn Progress,
) -> Result<GeometryReport> {
    let grids = case.grids(level)?;
    let mut classified = Vec::with_capacity(grids.len());
    for (i, grid) in grids.into_iter().enumerate() {
        let solid = case.solid(i, &grid)?;
        let cells = case.classify_body(i, &grid, &solid, progress)?;
        classified.push((solid, grid, cells));
    }
    let mut report = GeometryReport {
        report: Report::new(case),
        boundary_tags: Default::default(),
    };
    std::fs::create_dir_all(dir).map_err(|e| Error::Io {
        path: dir.display().to_string(),
        reason: e.to_string(),
    })?;
    for (body, (solid, grid, cells)) in case.bodies.iter().zip(&classified) {
        let name = &body.spec.name;
        report.report.push_body(BodyReport::new(
            name,
            body.model,
            body.spec.element,
            solid,
            grid,
            cells,
            body.spec.plane_strain,
        ));
        report
            .boundary_tags
            .insert(name.clone(), solid.tag_names().to_vec());
        let prefix = match case.bodies.len() {
            1 => String::new(),
            _ => format!("{name}."),
        };
        write_body_files(dir, &prefix, grid, cells)?;
    }
    let json = serde_json::to_string_pretty(&report).map_err(|e| Error::Io {
        path: dir.join("report.json").display().to_string(),
        reason: e.to_string(),
    })?;
    write_atomic(&dir.join("report.json"), json.as_bytes())?;
    Ok(report)
}

/// Writes `<prefix>cells.vtu` and `<prefix>boundary.vtp` of one body.
fn write_body_files(dir: &Path, prefix: &str, grid: &Grid, cells: &Cells) -> Result<()> {
    let body: Vec<usize> = (0..grid.num_cells())
        .filter(|&c| cells.kinds[c] != CellKind::Outside)
        .collect();
    let mesh = body_mesh(grid, crate::element::ElementOrder::Q1, &body);
    let mut fraction = vec![1.0; body.len()];
    for (i, &c) in cells.cut.iter().enumerate() {
        if let Ok(k) = body.binary_search(&c) {
            fraction[k] = cells.fraction[i];
        }
    }
    let class: Vec<u8> = body.iter().map(|&c| cells.kinds[c] as u8).collect();
    let vtu = VtuMesh {
        points: mesh
            .nodes
            .iter()
            .map(|&n| grid.node_position(crate::element::ElementOrder::Q1, n))
            .collect(),
        cells: mesh.cells,
    };
    write_vtu(
        &dir.join(format!("{prefix}cells.vtu")),
        &vtu,
        &[],
        &[
            DataArray::scalars_u8("cell_class", class),
            DataArray::scalars_f64("volume_fraction", fraction),
        ],
        VtuEncoding::Binary,
    )?;
    let points: Vec<[f64; 3]> = cells.surface.iter().map(|p| p.x).collect();
    let normals: Vec<[f64; 3]> = cells.surface.iter().map(|p| p.n).collect();
    write_vtp_points(
        &dir.join(format!("{prefix}boundary.vtp")),
        &points,
        &[
            DataArray::scalars_i32(
                "tag",
                cells.surface.iter().map(|p| i32::from(p.tag)).collect(),
            ),
            DataArray::vectors("normal", &normals),
            DataArray::scalars_f64("weight", cells.surface.iter().map(|p| p.w).collect()),
        ],
        VtuEncoding::Binary,
    )?;
    Ok(())
}
