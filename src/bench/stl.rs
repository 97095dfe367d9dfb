//! STL rows of `cgfem-gpu bench`: a sphere tessellated into 131 072 facets
//! (`tessellated_sphere`, 7 subdivisions), written as a binary STL, then
//! - `stl_load`: reading, welding, cleaning, the hierarchy with its far
//!   fields and the solid check (`dofs` is the facet count);
//! - `classify` per level, for the analytic sphere (`backend` `analytic`) and
//!   the STL one (`stl`): the block classification and every cut cell's rule
//!   (`dofs` is the number of cut cells), with the peak resident memory.

use std::time::Instant;

use super::{reset_peak_resident, row, Row};
use crate::cells::Cells;
use crate::error::Result;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::mesh::stl::{read_stl, write_binary_stl};
use crate::mesh::{tessellated_sphere, MeshSolid};

/// Subdivisions of the benchmark sphere: `8 · 4^7 = 131 072` facets.
const SUBDIVISIONS: u32 = 7;

/// The rows at `levels` (Q1 cut rules), run on `threads` threads.
pub fn rows(levels: &[u32], threads: usize) -> Result<Vec<Row>> {
    let path = std::env::temp_dir().join(format!("cgfem-bench-sphere-{}.stl", std::process::id()));
    write_binary_stl(&path, &tessellated_sphere([0.0; 3], 1.0, SUBDIVISIONS))?;
    reset_peak_resident();
    let t = Instant::now();
    let loaded = read_stl(&path).map(|mut s| s.remove(0).triangles);
    let _ = std::fs::remove_file(&path);
    let triangles = loaded?;
    let mesh = MeshSolid::new(&triangles, &vec![0; triangles.len()]).expect("a sphere has area");
    let ambiguity = mesh.ambiguity();
    let seconds = t.elapsed().as_secs_f64();
    if ambiguity > 0.0 {
        return Err(crate::error::Error::Bench {
            what: "the STL sphere".into(),
            reason: format!("its winding number is ambiguous on {ambiguity} of its box"),
        });
    }
    let mut out = vec![row("stl_load", "stl", 0, triangles.len(), threads, seconds)];
    let stl = Geometry::from_mesh(mesh, vec!["surface".into()]);
    let analytic = Geometry::sphere([0.0; 3], 1.0)?;
    for &level in levels {
        for (name, g) in [("analytic", &analytic), ("stl", &stl)] {
            reset_peak_resident();
            let grid = Grid::new(&g.bounding_box(), level, [0.0; 3])?;
            let t = Instant::now();
            let cells = Cells::classify(&grid, g, 2)?;
            let seconds = t.elapsed().as_secs_f64();
            out.push(row(
                "classify",
                name,
                level,
                cells.cut.len(),
                threads,
                seconds,
            ));
        }
    }
    Ok(out)
}
