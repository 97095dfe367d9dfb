//! Symmetry planes (`symmetry = ["tag", …]` of a body): boundary parts that
//! are a plane of mirror symmetry of the whole problem. Such a part must be
//! flat, normal to a grid axis and lie on a plane of grid nodes; the normal
//! displacement is then held at zero at every node on that plane (strongly,
//! as plane strain holds `u_z`), and the part carries no other condition
//! (its tangential traction is zero).
//!
//! Held strongly on a node plane, the half (quarter, eighth) model's
//! equations are the full model's restricted to one side: a row of an
//! interior node is the full model's row, and a row of a node on the plane
//! is half of it, the other half being its mirror image. So the reduced
//! model gives the full model's displacements wherever the two share their
//! quadrature, which they do when the plane is a CSG cut on cell faces
//! (`crate::quadrature::saye`'s face-plane sweeps): `tests/symmetry.rs`
//! finds a quarter plate with a hole 8e-12 off the full one. What does not
//! see across the plane yet is patch recovery: the S-term's patches
//! (`k2 > 0`) at pathological cells beside the plane are one-sided, and
//! differ from the full model's (7.5e-3 on that plate at level 3).

use crate::cells::Cells;
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::fem::dofs::DofMap;
use crate::geometry::Geometry;
use crate::grid::Grid;

/// A symmetry plane `x_axis = coordinate`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SymmetryPlane {
    pub axis: usize,
    pub coordinate: f64,
}

/// Tolerance, in cells, of "on the plane".
const ON_PLANE: f64 = 1e-9;

/// The plane of boundary part `tag` of `solid` on `grid`: every boundary
/// point of the part on one plane normal to an axis, at a plane of nodes.
/// `Err(reason)` otherwise.
pub fn symmetry_plane(
    grid: &Grid,
    cells: &Cells,
    solid: &Geometry,
    tag: &str,
) -> std::result::Result<SymmetryPlane, String> {
    let id = solid
        .tag_id(tag)
        .ok_or_else(|| format!("no boundary part is tagged '{tag}'"))?;
    let points: Vec<[f64; 3]> = cells
        .surface
        .iter()
        .filter(|p| p.tag == id)
        .map(|p| p.x)
        .collect();
    let Some(first) = points.first() else {
        return Err(format!("part '{tag}' has no boundary point on the grid"));
    };
    let tol = ON_PLANE * grid.h;
    let axis = (0..3)
        .find(|&a| points.iter().all(|x| (x[a] - first[a]).abs() <= tol))
        .ok_or_else(|| format!("part '{tag}' is not a plane normal to x, y or z"))?;
    let coordinate = first[axis];
    let cells_from_origin = (coordinate - grid.origin[axis]) / grid.h;
    if (cells_from_origin - cells_from_origin.round()).abs() > ON_PLANE {
        return Err(format!(
            "part '{tag}' lies at {coordinate} along axis {axis}, {cells_from_origin:.6} cells \
             from the grid's origin: a symmetry plane must be a plane of grid nodes (set \
             grid.box_min or grid.offset so that it is)"
        ));
    }
    Ok(SymmetryPlane { axis, coordinate })
}

/// The dofs to hold for `plane`: the normal component at every active Q1
/// node on it.
pub fn held_dofs(grid: &Grid, dofs: &DofMap, plane: SymmetryPlane) -> Vec<usize> {
    let tol = ON_PLANE * grid.h;
    dofs.active_to_node
        .iter()
        .enumerate()
        .filter(|&(_, &n)| {
            let x = grid.node_position(ElementOrder::Q1, n as usize);
            (x[plane.axis] - plane.coordinate).abs() <= tol
        })
        .map(|(a, _)| 3 * a + plane.axis)
        .collect()
}

/// The symmetry planes of a body as a case-file error on `key`.
pub fn planes(
    file: &str,
    key: &str,
    grid: &Grid,
    cells: &Cells,
    solid: &Geometry,
    tags: &[String],
) -> Result<Vec<SymmetryPlane>> {
    tags.iter()
        .map(|t| {
            symmetry_plane(grid, cells, solid, t).map_err(|reason| Error::CaseFile {
                file: file.into(),
                key: key.into(),
                reason,
            })
        })
        .collect()
}
