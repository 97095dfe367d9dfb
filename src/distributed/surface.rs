//! The boundary surface of a run on several ranks (`surface.vtp`): each
//! rank evaluates the fields at the surface points whose host cell lies in
//! its brick (the patches of their stress lie in its window), and rank 0
//! gathers them and writes the one-rank file. The surface is small beside
//! the volume (its points grow as the square of the grid's size), and one
//! file keeps triangles that cross bricks whole, such as an STL part's.

use super::RankSetup;
use crate::comm::agree;
use crate::comm::Comm;
use crate::discrete::boundary_mesh::{BoundaryMesh, RawSurface};
use crate::driver::output::von_mises;
use crate::driver::surface_output::SurfaceFields;
use crate::error::Result;
use crate::geometry::Geometry;

/// Numbers per point gathered: index, host cell, displacement, stress.
const WORDS: usize = 2 + 3 + 6;

/// The boundary of `geometry` with the fields of the rank's solution `u`
/// (its window's ghosts filled in) at its vertices, the same on every rank
/// and equal to the one-rank surface. Collective.
pub fn gather_surface(
    rs: &RankSetup,
    geometry: &Geometry,
    u: &[f64],
    comm: &dyn Comm,
) -> Result<(BoundaryMesh, SurfaceFields)> {
    let (setup, brick) = (&rs.setup, rs.bricks[comm.rank()]);
    let grid = &setup.grid;
    let raw = RawSurface::new(grid, geometry);
    let hosts = raw.hosts(grid, &setup.cells.kinds);
    let mine: Vec<usize> = (0..raw.points.len())
        .filter(|&v| hosts[v].is_some_and(|c| brick.contains(grid.cell_ijk(c))))
        .collect();
    let points = BoundaryMesh {
        points: mine.iter().map(|&v| raw.points[v]).collect(),
        host: mine
            .iter()
            .map(|&v| hosts[v].expect("kept above"))
            .collect(),
        triangles: Vec::new(),
        tags: Vec::new(),
    };
    let fields = agree(comm, SurfaceFields::new(setup, u, &points, None))?;
    let mut words = Vec::with_capacity(WORDS * mine.len());
    for (i, &v) in mine.iter().enumerate() {
        words.extend([v as f64, points.host[i] as f64]);
        words.extend(fields.displacement[i]);
        words.extend(fields.stress[i]);
    }
    let n = raw.points.len();
    let (mut host, mut displacement, mut stress) =
        (vec![None; n], vec![[0.0; 3]; n], vec![[0.0; 6]; n]);
    for w in comm
        .all_gather(&words)
        .iter()
        .flat_map(|r| r.chunks_exact(WORDS))
    {
        let v = w[0] as usize;
        host[v] = Some(w[1] as usize);
        displacement[v] = [w[2], w[3], w[4]];
        stress[v] = std::array::from_fn(|k| w[5 + k]);
    }
    let (mesh, sources) = raw.hosted(&host);
    let stress: Vec<[f64; 6]> = sources.iter().map(|&v| stress[v]).collect();
    let fields = SurfaceFields {
        displacement: sources.iter().map(|&v| displacement[v]).collect(),
        von_mises: stress.iter().map(von_mises).collect(),
        stress,
        exact: setup
            .problem
            .exact
            .as_ref()
            .map(|e| mesh.points.iter().map(|&x| e.eval(x)).collect()),
    };
    Ok((mesh, fields))
}
