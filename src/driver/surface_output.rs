//! `surface.vtp`: the body's boundary as a triangle surface
//! ([`BoundaryMesh`]: marching tetrahedra on each CSG leaf, or a mesh solid's
//! own STL triangles) with the solution evaluated at its vertices, so that
//! ParaView draws the part itself rather than the staircase of grid cells of
//! `solution.vtu`.
//!
//! Point data, at each vertex `x` with host cell `K` (the active cell through
//! whose shape functions `N_a` the point is evaluated, see
//! [`crate::discrete::boundary_mesh`]):
//! - `displacement`: `u_h(x) = Σ_a N_a(ξ) u_a` over the Q1 or Q2 nodes of `K`,
//!   `ξ = (x − x_K) / h` ([`CellField::value_and_gradient`]);
//! - `stress`: the SPR-recovered stress `σ̂(x) = Σ_i N_i^lin(ξ) σ*_i(x)`, the
//!   CPE blend of the patch polynomials of `K`'s eight vertices (as
//!   `solution.vtu`), a symmetric tensor;
//! - `von_mises`: `√(½ Σ (σ_ii − σ_jj)² + 3 Σ σ_ij²)` of `stress`;
//! - with an exact field (`[exact]`): `exact_displacement` `u(x)` and `error`
//!   `|u_h(x) − u(x)|`.
//!
//! Cell data: `tag`, the boundary tag of each triangle as an `Int32` index
//! into the case's tag names (in the order the geometry defines them: see
//! [`crate::geometry::Geometry::tag_names`]).

use std::path::Path;

use rayon::prelude::*;

use super::output::von_mises;
use super::recovery::{recover_stress_around, vertex_nodes_of};
use super::setup::Setup;
use crate::discrete::boundary_mesh::BoundaryMesh;
use crate::discrete::field::CellField;
use crate::error::Result;
use crate::geometry::Geometry;
use crate::recovery::Recovered;
use crate::vtu::{write_vtp_triangles, DataArray, VtuEncoding};

/// Vertices per parallel task of [`SurfaceFields::new`].
const POINT_CHUNK: usize = 2048;

/// The fields of `surface.vtp` at the vertices of a [`BoundaryMesh`].
#[derive(Clone, Debug)]
pub struct SurfaceFields {
    /// `u_h` at each vertex.
    pub displacement: Vec<[f64; 3]>,
    /// `σ̂` at each vertex, Voigt order (xx, yy, zz, yz, xz, xy).
    pub stress: Vec<[f64; 6]>,
    /// Von Mises of `stress`.
    pub von_mises: Vec<f64>,
    /// The exact displacement at each vertex, when the case has one.
    pub exact: Option<Vec<[f64; 3]>>,
}

impl SurfaceFields {
    /// The fields of the solution `u` of `setup` at the vertices of `mesh`,
    /// with the stress recovered at the vertices of the host cells, taking
    /// the fits that `known` holds (a stress recovery of `u`: the volume
    /// output's, which holds them all, or the loop's last) from it.
    pub fn new(
        setup: &Setup,
        u: &[f64],
        mesh: &BoundaryMesh,
        known: Option<&Recovered<6>>,
    ) -> Result<SurfaceFields> {
        let (grid, dofs) = (&setup.grid, &setup.op.dofs);
        let mut hosts = mesh.host.clone();
        hosts.sort_unstable();
        hosts.dedup();
        let sigma = &recover_stress_around(setup, u, &vertex_nodes_of(setup, &hosts), known)?;
        // The vertices by host cell, so that each cell's nodal values and
        // stress blend are gathered once for all its vertices.
        let mut by_host: Vec<usize> = (0..mesh.points.len()).collect();
        by_host.sort_by_key(|&i| mesh.host[i]);
        let fields: Vec<Vec<([f64; 3], [f64; 6])>> = by_host
            .par_chunks(POINT_CHUNK)
            .map(|chunk| {
                let mut cell = None;
                let mut at = Vec::with_capacity(chunk.len());
                for &i in chunk {
                    let (x, host) = (mesh.points[i], mesh.host[i]);
                    if !matches!(&cell, Some((c, _, _)) if *c == host) {
                        let field = CellField::new(grid, dofs, u, host);
                        cell = Some((host, field, sigma.cell_blend(host)?));
                    }
                    let (_, field, blend) = cell.as_ref().expect("made above");
                    at.push((field.value_and_gradient(x).0, blend.eval(x)));
                }
                Ok(at)
            })
            .collect::<Result<_>>()?;
        let mut displacement = vec![[0.0; 3]; mesh.points.len()];
        let mut stress = vec![[0.0; 6]; mesh.points.len()];
        for (&i, (v, s)) in by_host.iter().zip(fields.into_iter().flatten()) {
            displacement[i] = v;
            stress[i] = s;
        }
        let von_mises = stress.par_iter().map(von_mises).collect();
        let exact = setup
            .problem
            .exact
            .as_ref()
            .map(|e| mesh.points.par_iter().map(|&x| e.eval(x)).collect());
        Ok(SurfaceFields {
            displacement,
            stress,
            von_mises,
            exact,
        })
    }

    /// `|u_h(x) − u(x)|` at each vertex, when the case has an exact field.
    pub fn error(&self) -> Option<Vec<f64>> {
        let exact = self.exact.as_ref()?;
        let mut out = Vec::with_capacity(exact.len());
        for (uh, ue) in self.displacement.iter().zip(exact) {
            let mut e2 = 0.0;
            for i in 0..3 {
                e2 += (uh[i] - ue[i]) * (uh[i] - ue[i]);
            }
            out.push(e2.sqrt());
        }
        Some(out)
    }
}

/// The boundary of `geometry` as triangles, and the fields of the solution
/// `u` of `setup` at its vertices (the stress fits that `known` holds taken
/// from it, see [`SurfaceFields::new`]).
pub fn surface_fields(
    setup: &Setup,
    geometry: &Geometry,
    u: &[f64],
    known: Option<&Recovered<6>>,
) -> Result<(BoundaryMesh, SurfaceFields)> {
    let mesh = BoundaryMesh::new(&setup.grid, &setup.cells.kinds, geometry);
    let fields = SurfaceFields::new(setup, u, &mesh, known)?;
    Ok((mesh, fields))
}

/// Writes the boundary `mesh` with its `fields` to the `.vtp` file `path` in
/// `encoding` (see the module doc).
pub fn write_surface(
    path: &Path,
    mesh: &BoundaryMesh,
    fields: &SurfaceFields,
    encoding: VtuEncoding,
) -> Result<()> {
    let mut point_data = vec![
        DataArray::vectors("displacement", &fields.displacement),
        DataArray::sym_tensors("stress", &fields.stress),
        DataArray::scalars_f64("von_mises", fields.von_mises.clone()),
    ];
    if let (Some(exact), Some(error)) = (&fields.exact, fields.error()) {
        point_data.push(DataArray::vectors("exact_displacement", exact));
        point_data.push(DataArray::scalars_f64("error", error));
    }
    write_tagged_triangles(path, mesh, &point_data, encoding)
}

/// Writes `mesh` with `point_data` and its triangles' `tag` as the `.vtp`
/// file `path` in `encoding`.
pub fn write_tagged_triangles(
    path: &Path,
    mesh: &BoundaryMesh,
    point_data: &[DataArray],
    encoding: VtuEncoding,
) -> Result<()> {
    let tags = mesh.tags.iter().map(|&t| i32::from(t)).collect();
    let cell_data = [DataArray::scalars_i32("tag", tags)];
    let triangles: Vec<[usize; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| v as usize))
        .collect();
    write_vtp_triangles(
        path,
        &mesh.points,
        &triangles,
        point_data,
        &cell_data,
        encoding,
    )
}
