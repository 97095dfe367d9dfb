//! The ParaView time series of a multi-body run: per converged load step `k`
//! and body `b`, `DIR/<b>_<k>.vtu` — the body's non-outside cells as
//! hexahedra on the reference positions of their nodes, with the point data
//! `displacement` (warp by it for the deformed shape) and `level_set` (φ of
//! the solid, negative inside: *Clip* by it cuts the cells to the body), and
//! the cell data
//! `von_mises` (of the Cauchy stress `σ = P Fᵀ / J` averaged over the cell's
//! quadrature points, weights `w_q`) and `cell_class` (0 inside, 1 cut, as
//! [`crate::cells::CellKind`]) — and `DIR/solution.pvd`, listing every file
//! so far with its load factor as time and its body index as part. Each
//! contact pair `i` adds `DIR/contact<i>_<k>.vtp`, its slave points in the
//! current configuration with the point data `gap` (`NaN` where no master
//! was found), `pressure` (`−λ_N`), `recovered_pressure` (`−T̂_N`),
//! `friction` (0 off, 1 stick, 2 slip) and
//! `normal`, as the part after the bodies'. Each body `b` also adds
//! `DIR/<b>_surface_<k>.vtp`, its boundary as triangles on the reference
//! positions ([`crate::discrete::boundary_mesh`]) with the point data
//! `displacement` and `von_mises` (of its host cell's mean Cauchy stress, as
//! in the `.vtu`) and the cell data `tag`, as the parts after the contact
//! pairs'.
//!
//! Which of these files are written, and in which encoding, is the series'
//! [`ParaView`]: the volume the bodies' `.vtu`, the surface the contact
//! points' and the bodies' surfaces' `.vtp`; `solution.pvd` once any file is
//! written.

use std::path::{Path, PathBuf};

use nalgebra::Matrix3;

use super::setup::BodySetup;
use crate::contact::ContactPoints;
use crate::discrete::boundary_mesh::BoundaryMesh;
use crate::discrete::field::value_and_gradient;
use crate::driver::output::{level_set, von_mises, ParaView};
use crate::driver::surface_output::write_tagged_triangles;
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::hyper::problem::HyperProblem;
use crate::hyper::residual::point_fields;
use crate::vtu::{
    write_pvd_parts, write_vtp_points, write_vtu, DataArray, VtuCell, VtuEncoding, VtuMesh,
};

/// The file name of body `name` at load step `step`.
pub fn body_file(name: &str, step: usize) -> String {
    format!("{name}_{step}.vtu")
}

/// The boundary surface of body `name` at load step `step`.
pub fn surface_file(name: &str, step: usize) -> String {
    format!("{name}_surface_{step}.vtp")
}

/// The file of contact pair `i` (from 0, in case order) at load step `step`.
pub fn contact_file(i: usize, step: usize) -> String {
    format!("contact{i}_{step}.vtp")
}

/// Voigt `(xx, yy, zz, yz, xz, xy)` of a symmetric tensor.
fn voigt(s: &Matrix3<f64>) -> [f64; 6] {
    [
        s[(0, 0)],
        s[(1, 1)],
        s[(2, 2)],
        s[(1, 2)],
        s[(0, 2)],
        s[(0, 1)],
    ]
}

/// Von Mises of the weighted mean Cauchy stress of each cell of `p` at `u`.
fn cell_von_mises(p: &HyperProblem, u: &[f64], path: &Path) -> Result<Vec<f64>> {
    let fields = point_fields(p, u).ok_or_else(|| Error::Io {
        path: path.display().to_string(),
        reason: "an element is inverted in the displacement to write".into(),
    })?;
    Ok(fields
        .iter()
        .enumerate()
        .map(|(k, points)| {
            let mut mean = Matrix3::zeros();
            let mut weight = 0.0;
            for ((f, pk), q) in points.iter().zip(p.points(k)) {
                mean += pk * f.transpose() * (q.w / f.determinant());
                weight += q.w;
            }
            if weight > 0.0 {
                von_mises(&voigt(&(mean / weight)))
            } else {
                0.0
            }
        })
        .collect())
}

/// Writes body `p` (set up as `body`) at displacement `u` to `path` in
/// `encoding`: its cells as `VTK_HEXAHEDRON` (Q1) or
/// `VTK_TRIQUADRATIC_HEXAHEDRON` (Q2) on its active nodes.
pub fn write_body(
    path: &Path,
    body: &BodySetup,
    p: &HyperProblem,
    u: &[f64],
    encoding: VtuEncoding,
) -> Result<()> {
    let points: Vec<[f64; 3]> = p
        .dofs
        .active_to_node
        .iter()
        .map(|&n| body.grid.node_position(p.order(), n as usize))
        .collect();
    let cells: Vec<VtuCell> = (0..p.cells.len())
        .map(|k| {
            let nodes = p.cell_nodes(k);
            let node = |i: usize| nodes[i] as usize;
            match p.order() {
                ElementOrder::Q1 => VtuCell::hex8_from_lexicographic(std::array::from_fn(node)),
                ElementOrder::Q2 => VtuCell::hex27_from_lexicographic(std::array::from_fn(node)),
            }
        })
        .collect();
    let displacement: Vec<[f64; 3]> = u.chunks_exact(3).map(|d| [d[0], d[1], d[2]]).collect();
    let class: Vec<u8> = p.cells.iter().map(|&c| body.cells.kinds[c] as u8).collect();
    let point_data = [
        DataArray::vectors("displacement", &displacement),
        level_set(&body.solid, &points),
    ];
    let cell_data = [
        DataArray::scalars_f64("von_mises", cell_von_mises(p, u, path)?),
        DataArray::scalars_u8("cell_class", class),
    ];
    let mesh = VtuMesh { points, cells };
    write_vtu(path, &mesh, &point_data, &cell_data, encoding)
}

/// Writes body `p`'s boundary `mesh` at displacement `u` to `path`:
/// `displacement` at the vertices, `von_mises` of the host cell's mean
/// Cauchy stress; in `encoding`.
fn write_body_surface(
    path: &Path,
    body: &BodySetup,
    p: &HyperProblem,
    mesh: &BoundaryMesh,
    u: &[f64],
    encoding: VtuEncoding,
) -> Result<()> {
    let cell_vm = cell_von_mises(p, u, path)?;
    let mut vm_of_cell = vec![0.0; body.grid.num_cells()];
    for (k, &c) in p.cells.iter().enumerate() {
        vm_of_cell[c] = cell_vm[k];
    }
    let displacement: Vec<[f64; 3]> = mesh
        .points
        .iter()
        .zip(&mesh.host)
        .map(|(&x, &c)| value_and_gradient(&body.grid, &p.dofs, u, c, x).0)
        .collect();
    let vm: Vec<f64> = mesh.host.iter().map(|&c| vm_of_cell[c]).collect();
    let point_data = [
        DataArray::vectors("displacement", &displacement),
        DataArray::scalars_f64("von_mises", vm),
    ];
    write_tagged_triangles(path, mesh, &point_data, encoding)
}

/// The series written so far: `(load factor, part, file)` per entry, and
/// the bodies' boundary meshes (built on the first surfaces written); which
/// files it writes, and how, is its [`ParaView`].
#[derive(Clone, Debug, Default)]
pub struct Series {
    entries: Vec<(f64, usize, PathBuf)>,
    surfaces: Vec<BoundaryMesh>,
    paraview: ParaView,
}

impl Series {
    /// An empty series that writes the files of `paraview`.
    pub fn new(paraview: ParaView) -> Series {
        Series {
            paraview,
            ..Series::default()
        }
    }

    /// The files written so far, in order, and `solution.pvd` when any.
    pub fn files(&self) -> Vec<String> {
        let mut files: Vec<String> = (self.entries.iter())
            .map(|(_, _, f)| f.display().to_string())
            .collect();
        if !files.is_empty() {
            files.push("solution.pvd".into());
        }
        files
    }

    /// Rewrites `dir/solution.pvd` when the series has any file.
    fn write_pvd(&self, dir: &Path) -> Result<()> {
        match self.entries.is_empty() {
            true => Ok(()),
            false => write_pvd_parts(&dir.join("solution.pvd"), &self.entries),
        }
    }

    /// Writes every body's file of converged step `step` at load factor `t`
    /// into `dir` and rewrites `dir/solution.pvd` (with the volume files).
    pub fn write_step(
        &mut self,
        dir: &Path,
        bodies: &[BodySetup],
        problems: &[HyperProblem],
        parts: &[&[f64]],
        step: usize,
        t: f64,
    ) -> Result<()> {
        if !self.paraview.files.volume() {
            return Ok(());
        }
        for (b, (body, p)) in bodies.iter().zip(problems).enumerate() {
            let file = PathBuf::from(body_file(&body.name, step));
            let encoding = self.paraview.encoding;
            write_body(&dir.join(&file), body, p, parts[b], encoding)?;
            self.entries.push((t, b, file));
        }
        self.write_pvd(dir)
    }

    /// Writes every contact pair's points of converged step `step` at load
    /// factor `t` into `dir` (`contact<i>_<step>.vtp`, parts after the
    /// bodies', `first_part` on) and rewrites `dir/solution.pvd` (with the
    /// surface files).
    pub fn write_contact(
        &mut self,
        dir: &Path,
        pairs: &[ContactPoints],
        first_part: usize,
        step: usize,
        t: f64,
    ) -> Result<()> {
        if !self.paraview.files.surface() {
            return Ok(());
        }
        for (i, c) in pairs.iter().enumerate() {
            let file = PathBuf::from(contact_file(i, step));
            let data = [
                DataArray::scalars_f64("gap", c.gap.clone()),
                DataArray::scalars_f64("pressure", c.pressure.clone()),
                DataArray::scalars_f64("recovered_pressure", c.recovered_pressure.clone()),
                DataArray::scalars_f64("friction", c.friction.clone()),
                DataArray::vectors("normal", &c.normal),
            ];
            write_vtp_points(&dir.join(&file), &c.x, &data, self.paraview.encoding)?;
            self.entries.push((t, first_part + i, file));
        }
        self.write_pvd(dir)
    }

    /// Writes every body's boundary surface of converged step `step` at load
    /// factor `t` into `dir` (`<b>_surface_<step>.vtp`, parts `first_part`
    /// on) and rewrites `dir/solution.pvd` (with the surface files).
    #[allow(clippy::too_many_arguments)]
    pub fn write_surfaces(
        &mut self,
        dir: &Path,
        bodies: &[BodySetup],
        problems: &[HyperProblem],
        parts: &[&[f64]],
        first_part: usize,
        step: usize,
        t: f64,
    ) -> Result<()> {
        if !self.paraview.files.surface() {
            return Ok(());
        }
        if self.surfaces.is_empty() {
            self.surfaces = bodies
                .iter()
                .map(|b| BoundaryMesh::new(&b.grid, &b.cells.kinds, &b.solid))
                .collect();
        }
        for (b, (body, p)) in bodies.iter().zip(problems).enumerate() {
            let file = PathBuf::from(surface_file(&body.name, step));
            let (mesh, encoding) = (&self.surfaces[b], self.paraview.encoding);
            write_body_surface(&dir.join(&file), body, p, mesh, parts[b], encoding)?;
            self.entries.push((t, first_part + b, file));
        }
        self.write_pvd(dir)
    }

    /// Number of files listed.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether nothing was written yet.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}
