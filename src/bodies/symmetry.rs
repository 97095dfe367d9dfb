//! Symmetry planes (`symmetry = ["tag", …]` of a body): boundary parts that
//! are a plane of mirror symmetry of the whole problem. Such a part must be
//! flat, normal to a grid axis and lie on a face of the grid box; the normal
//! displacement is then held at zero at every node on that plane (strongly,
//! as plane strain holds `u_z`), the part carries no other condition (its
//! tangential traction is zero), and the S-term's patches continue across
//! it into the mirror image ([`crate::recovery::Mirror`]).
//!
//! Held strongly on a node plane, the half (quarter, eighth) model's
//! equations are the full model's restricted to one side: a row of an
//! interior node is the full model's row, and a row of a node on the plane
//! is half of it, the other half being its mirror image. So the reduced
//! model gives the full model's displacements wherever the two share their
//! quadrature, which they do when the plane is a CSG cut on cell faces
//! (`crate::quadrature::saye`'s face-plane sweeps), and wherever their
//! recovered terms are fitted to the same samples: the S-term's patches
//! continue across the planes into the mirror image. `tests/suite/fem/symmetry.rs`
//! finds a quarter plate with a hole equal to the full one to 8e-12 with the
//! S-term off and to 9e-15 with the default S-term at level 3: the full
//! model's cut cells sample mirror-image points on the two sides of each
//! plane ([`Cells::fit_points`]).

use crate::cells::Cells;
use crate::discrete::dofs::DofMap;
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::recovery::Mirror;

/// A symmetry plane `x_axis = coordinate`, a face of the grid box (`high`:
/// its high face), the boundary part tagged `tag`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SymmetryPlane {
    pub tag: u16,
    pub axis: usize,
    pub coordinate: f64,
    pub high: bool,
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
    let b = grid.bounding_box();
    let high = match [b.lo[axis], b.hi[axis]].map(|f| (coordinate - f).abs() <= tol) {
        [true, _] => false,
        [_, true] => true,
        _ => {
            return Err(format!(
                "part '{tag}' lies at {coordinate} along axis {axis}, inside the grid box \
                 [{}, {}]: a symmetry plane must be a face of the grid box (set grid.box_min \
                 or grid.box_max to it)",
                b.lo[axis], b.hi[axis]
            ))
        }
    };
    Ok(SymmetryPlane {
        tag: id,
        axis,
        coordinate,
        high,
    })
}

/// The faces of the grid box that are the symmetry planes `planes`.
pub fn mirror(planes: &[SymmetryPlane]) -> Mirror {
    let mut m = Mirror::none();
    for p in planes {
        m.faces[p.axis][p.high as usize] = true;
    }
    m
}

/// The dofs to hold for `plane`: the normal component at every active node
/// (of the dof map's element) on it.
pub fn held_dofs(grid: &Grid, dofs: &DofMap, plane: SymmetryPlane) -> Vec<usize> {
    let tol = ON_PLANE * grid.h;
    dofs.active_to_node
        .iter()
        .enumerate()
        .filter(|&(_, &n)| {
            let x = grid.node_position(dofs.order, n as usize);
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
