//! `solution.vtu`: the cells of the body (inside and cut) as hexahedra on
//! their element nodes (Q1: `VTK_HEXAHEDRON` on the vertices; Q2:
//! `VTK_TRIQUADRATIC_HEXAHEDRON` on the 27 nodes, so ParaView interpolates
//! the quadratic field), with the displacement, the SPR-recovered stress (the
//! CPE blend `σ̂` at the node) and its von Mises value at the nodes (plus the
//! exact displacement when the case has one), the level set φ of the solid
//! at the nodes (`level_set`, negative inside: ParaView's *Clip* by this
//! scalar at 0, inverted, cuts the cut cells down to the body), and the cell
//! class and volume fraction per cell.
//!
//! It also owns which ParaView files a run writes ([`ParaView`]: `--output`
//! and `--compress`) and writes those of the linear run ([`write_paraview`]:
//! `solution.vtu`, `surface.vtp`, `solution.pvd` listing them).

use std::collections::HashMap;
use std::path::Path;
use std::str::FromStr;

use rayon::prelude::*;

use super::recovery::{recover_stress_around, vertex_nodes_of};
use super::setup::Setup;
use super::surface_output::{surface_fields, write_surface, SurfaceFields};
use crate::cells::split::PRIMARY;
use crate::cells::CellKind;
use crate::discrete::boundary_mesh::BoundaryMesh;
use crate::discrete::dofs::DofMap;
use crate::element::ElementOrder;
use crate::error::Result;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::output::Written;
use crate::recovery::Recovered;
use crate::vtu::{
    write_pvd_parts, write_vtu, DataArray, DataValues, VtuCell, VtuEncoding, VtuMesh,
};

/// Which of a run's ParaView files are written (`--output`): the cells
/// (`solution.vtu`; on the Newton path each body's `<body>_<step>.vtu`), the
/// surfaces (`surface.vtp`; on the Newton path the bodies' surfaces and the
/// contact points, `.vtp`), both, or none (the report only).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OutputFiles {
    Volume,
    Surface,
    #[default]
    All,
    None,
}

impl OutputFiles {
    /// Whether the cells' files are written.
    pub fn volume(self) -> bool {
        matches!(self, OutputFiles::Volume | OutputFiles::All)
    }

    /// Whether the surfaces' files are written.
    pub fn surface(self) -> bool {
        matches!(self, OutputFiles::Surface | OutputFiles::All)
    }
}

impl FromStr for OutputFiles {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "volume" => Ok(OutputFiles::Volume),
            "surface" => Ok(OutputFiles::Surface),
            "all" => Ok(OutputFiles::All),
            "none" => Ok(OutputFiles::None),
            other => Err(format!(
                "unknown output '{other}'; available: volume, surface, all, none"
            )),
        }
    }
}

/// A run's ParaView files: which, and their encoding (appended raw by
/// default; `--compress`: zlib).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ParaView {
    pub files: OutputFiles,
    pub encoding: VtuEncoding,
}

/// Von Mises stress of a Voigt stress (xx, yy, zz, yz, xz, xy).
pub fn von_mises(s: &[f64; 6]) -> f64 {
    let d = (s[0] - s[1]).powi(2) + (s[1] - s[2]).powi(2) + (s[2] - s[0]).powi(2);
    (0.5 * d + 3.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5])).sqrt()
}

/// The point data `level_set`: φ of `geometry` at `points` (negative inside).
pub(crate) fn level_set(geometry: &Geometry, points: &[[f64; 3]]) -> DataArray {
    DataArray::scalars_f64(
        "level_set",
        points.par_iter().map(|&x| geometry.phi(x)).collect(),
    )
}

/// The element nodes of the body cells, as VTU points: each node once (in
/// order of first appearance), with one cell holding it, and the cells on
/// those points.
pub(crate) struct BodyMesh {
    pub nodes: Vec<usize>,
    pub node_cell: Vec<usize>,
    pub cells: Vec<VtuCell>,
}

/// The [`BodyMesh`] of the cells `body` of `grid` for elements of `order`.
pub(crate) fn body_mesh(grid: &Grid, order: ElementOrder, body: &[usize]) -> BodyMesh {
    let npe = order.nodes_per_cell();
    // The point of each grid node, `usize::MAX` until it is met: one word per
    // grid node, as the dof map's own node table.
    let mut point_of = vec![usize::MAX; grid.num_nodes(order)];
    let (mut nodes, mut node_cell) = (Vec::new(), Vec::new());
    let mut local = vec![0usize; npe];
    let mut cells = Vec::with_capacity(body.len());
    for &c in body {
        grid.cell_nodes(order, c, &mut local);
        for n in local.iter_mut() {
            if point_of[*n] == usize::MAX {
                point_of[*n] = nodes.len();
                nodes.push(*n);
                node_cell.push(c);
            }
            *n = point_of[*n];
        }
        cells.push(match order {
            ElementOrder::Q1 => VtuCell::hex8_from_lexicographic(std::array::from_fn(|i| local[i])),
            ElementOrder::Q2 => {
                VtuCell::hex27_from_lexicographic(std::array::from_fn(|i| local[i]))
            }
        });
    }
    BodyMesh {
        nodes,
        node_cell,
        cells,
    }
}

/// The pieces of the split cells ([`crate::cells::split`]) in `mesh` (of the
/// Q1 cells `body`, with the active index of each point in `active`): the
/// copies become points of their own (their node's position and stress,
/// their own displacement), the first piece of a split cell takes the
/// cell's hexahedron and each further piece is a hexahedron appended after
/// the cells. Returns, per appended hexahedron, the position in `body` of
/// its cell. Each piece's hexahedron spans the whole cell, as the cell's
/// does: `level_set` clips both to the body, so where pieces share a cell
/// each shows both walls with its own displacement.
fn add_pieces(
    grid: &Grid,
    dofs: &DofMap,
    body: &[usize],
    mesh: &mut BodyMesh,
    active: &mut Vec<usize>,
) -> Vec<usize> {
    if dofs.split.is_empty() {
        return Vec::new();
    }
    let point_of: HashMap<usize, usize> = mesh
        .nodes
        .iter()
        .enumerate()
        .map(|(i, &n)| (n, i))
        .collect();
    let first_copy = mesh.nodes.len();
    for (a, node) in dofs.copies() {
        mesh.nodes.push(node);
        mesh.node_cell.push(mesh.node_cell[point_of[&node]]);
        active.push(a);
    }
    let mut appended = Vec::new();
    let mut local = [0usize; 8];
    for s in &dofs.split.cells {
        let k = body
            .binary_search(&s.cell)
            .expect("a split cell is a body cell");
        grid.cell_nodes(ElementOrder::Q1, s.cell, &mut local);
        for (p, copies) in s.pieces.iter().enumerate() {
            let points: [usize; 8] = std::array::from_fn(|i| match copies[i] {
                PRIMARY => point_of[&local[i]],
                copy => first_copy + copy as usize,
            });
            let hex = VtuCell::hex8_from_lexicographic(points);
            if p == 0 {
                mesh.cells[k] = hex;
            } else {
                mesh.cells.push(hex);
                appended.push(k);
            }
        }
    }
    appended
}

/// Nodes per parallel task of [`nodal_stress`].
const NODE_CHUNK: usize = 4096;

/// The recovered stress `sigma` at the points of `mesh` (at `points`): a
/// vertex's own value, else the blend of the point's cell, prepared once per
/// run of points in one cell.
fn nodal_stress(
    grid: &Grid,
    order: ElementOrder,
    mesh: &BodyMesh,
    points: &[[f64; 3]],
    sigma: &Recovered<6>,
) -> Result<Vec<[f64; 6]>> {
    let mut stress = vec![[0.0; 6]; mesh.nodes.len()];
    stress
        .par_chunks_mut(NODE_CHUNK)
        .enumerate()
        .try_for_each(|(t, out)| -> Result<()> {
            let mut blend = None;
            for (k, s) in out.iter_mut().enumerate() {
                let i = t * NODE_CHUNK + k;
                *s = match grid.vertex_of(order, mesh.nodes[i]) {
                    Some(v) => sigma.at_vertex(v)?,
                    None => {
                        let cell = mesh.node_cell[i];
                        if !matches!(&blend, Some((c, _)) if *c == cell) {
                            blend = Some((cell, sigma.cell_blend(cell)?));
                        }
                        blend.as_ref().expect("made above").1.eval(points[i])
                    }
                };
            }
            Ok(())
        })?;
    Ok(stress)
}

/// The contents of a `.vtu` file: the mesh and its point and cell data.
struct VtuFile {
    mesh: VtuMesh,
    point_data: Vec<DataArray>,
    cell_data: Vec<DataArray>,
}

impl VtuFile {
    fn write(&self, path: &Path, encoding: VtuEncoding) -> Result<()> {
        write_vtu(
            path,
            &self.mesh,
            &self.point_data,
            &self.cell_data,
            encoding,
        )
    }
}

/// Writes the solution `u` of `setup` (whose solid is `geometry`) to `path`
/// in inline base64, a text file; a run writes it through
/// [`write_paraview`] in the encoding of its [`ParaView`].
pub fn write_solution(setup: &Setup, geometry: &Geometry, u: &[f64], path: &Path) -> Result<()> {
    solution_file(setup, geometry, u, None, &|_| true)?
        .0
        .write(path, VtuEncoding::Binary)
}

/// `solution.vtu` of the solution `u` of `setup`, whose solid is `geometry`,
/// over the cells `counts` takes (all, or a rank's brick), and the stress
/// recovered at the vertices of those cells (taking the fits that `known`
/// holds from it).
fn solution_file(
    setup: &Setup,
    geometry: &Geometry,
    u: &[f64],
    known: Option<&Recovered<6>>,
    counts: &dyn Fn(usize) -> bool,
) -> Result<(VtuFile, Recovered<6>)> {
    let grid = &setup.grid;
    let dofs = &setup.op.dofs;
    let body: Vec<usize> = (0..grid.num_cells())
        .filter(|&c| setup.cells.kinds[c] != CellKind::Outside && counts(c))
        .collect();
    let mut mesh = body_mesh(grid, dofs.order, &body);
    // Every node of a body cell is active, so u there is a nodal value.
    let mut active: Vec<usize> = mesh
        .nodes
        .iter()
        .map(|&n| dofs.node_to_active[n] as usize)
        .collect();
    let pieces_of = add_pieces(grid, dofs, &body, &mut mesh, &mut active);
    let points: Vec<[f64; 3]> = mesh
        .nodes
        .iter()
        .map(|&n| grid.node_position(dofs.order, n))
        .collect();
    let displacement: Vec<[f64; 3]> = active
        .iter()
        .map(|&a| [u[3 * a], u[3 * a + 1], u[3 * a + 2]])
        .collect();
    let sigma = recover_stress_around(setup, u, &vertex_nodes_of(setup, &body), known)?;
    let stress = nodal_stress(grid, dofs.order, &mesh, &points, &sigma)?;
    let mises: Vec<f64> = stress.par_iter().map(von_mises).collect();
    let mut point_data = vec![
        DataArray::vectors("displacement", &displacement),
        DataArray::sym_tensors("stress", &stress),
        DataArray::scalars_f64("von_mises", mises),
        level_set(geometry, &points),
    ];
    if let Some(exact) = &setup.problem.exact {
        let tape = exact.tape();
        let mut ue = vec![[0.0; 3]; points.len()];
        ue.par_chunks_mut(1024)
            .zip(points.par_chunks(1024))
            .for_each(|(ue, xs)| tape.values(xs, ue));
        point_data.push(DataArray::vectors("exact_displacement", &ue));
    }
    let mut fraction = vec![1.0; body.len()];
    for (i, &c) in setup.cells.cut.iter().enumerate() {
        if let Ok(k) = body.binary_search(&c) {
            fraction[k] = setup.cells.fraction[i];
        }
    }
    // The further pieces of split cells repeat their cell's data.
    let repeated: Vec<f64> = pieces_of.iter().map(|&k| fraction[k]).collect();
    fraction.extend(repeated);
    let body: Vec<usize> = body
        .iter()
        .chain(pieces_of.iter().map(|&k| &body[k]))
        .copied()
        .collect();
    let class: Vec<u8> = body.iter().map(|&c| setup.cells.kinds[c] as u8).collect();
    let cell_data = vec![
        DataArray::scalars_u8("cell_class", class),
        DataArray::scalars_f64("volume_fraction", fraction),
    ];
    let mesh = VtuMesh {
        points,
        cells: mesh.cells,
    };
    let file = VtuFile {
        mesh,
        point_data,
        cell_data,
    };
    Ok((file, sigma))
}

/// Writes one rank's piece of the solution: `name`, the cells of `setup`
/// that `counts` takes (its brick), in `encoding`, through `written`.
/// Returns the piece's point and cell arrays without their values (what
/// the `.pvtu` declares).
pub fn write_piece(
    setup: &Setup,
    geometry: &Geometry,
    u: &[f64],
    counts: &dyn Fn(usize) -> bool,
    name: &str,
    encoding: VtuEncoding,
    written: &mut Written,
) -> Result<(Vec<DataArray>, Vec<DataArray>)> {
    let (file, _) = solution_file(setup, geometry, u, None, counts)?;
    written.write(name, |path| file.write(path, encoding))?;
    let declared = |arrays: &[DataArray]| -> Vec<DataArray> {
        arrays
            .iter()
            .map(|a| DataArray {
                name: a.name.clone(),
                components: a.components,
                values: match a.values {
                    DataValues::F64(_) => DataValues::F64(Vec::new()),
                    DataValues::I64(_) => DataValues::I64(Vec::new()),
                    DataValues::I32(_) => DataValues::I32(Vec::new()),
                    DataValues::U8(_) => DataValues::U8(Vec::new()),
                },
            })
            .collect()
    };
    Ok((declared(&file.point_data), declared(&file.cell_data)))
}

/// Writes the ParaView files of `paraview` for the solution `u` of `setup`
/// (whose solid is `geometry`, and whose stress `known` was recovered on
/// some patches already) through `written`: `solution.vtu`,
/// `surface.vtp`, and `solution.pvd` listing those written as the parts of
/// one time step. Everything that can fail to compute (the stress
/// recovery: [`crate::Error::Recovery`] on a grid too coarse for the body)
/// is computed before the first file is written, so that a failed output
/// leaves none of them. Returns the boundary surface and its fields when
/// they were computed: for `surface.vtp`, or when `want_surface`.
pub fn write_paraview(
    setup: &Setup,
    geometry: &Geometry,
    u: &[f64],
    known: Option<&Recovered<6>>,
    paraview: ParaView,
    want_surface: bool,
    written: &mut Written,
) -> Result<Option<(BoundaryMesh, SurfaceFields)>> {
    let (encoding, first) = (paraview.encoding, written.files.len());
    let volume = match paraview.files.volume() {
        true => Some(solution_file(setup, geometry, u, known, &|_| true)?),
        false => None,
    };
    // The surface's host cells are cells of the body: its stress is the
    // volume's, when that was recovered.
    let recovered = volume.as_ref().map(|(_, sigma)| sigma).or(known);
    let surface = match paraview.files.surface() || want_surface {
        true => Some(surface_fields(setup, geometry, u, recovered)?),
        false => None,
    };
    if let Some((file, _)) = &volume {
        written.write("solution.vtu", |path| file.write(path, encoding))?;
    }
    if let (true, Some((mesh, fields))) = (paraview.files.surface(), &surface) {
        written.write("surface.vtp", |path| {
            write_surface(path, mesh, fields, encoding)
        })?;
    }
    let parts: Vec<(f64, usize, String)> = (written.files[first..].iter().enumerate())
        .map(|(part, file)| (0.0, part, file.clone()))
        .collect();
    if !parts.is_empty() {
        written.write("solution.pvd", |path| write_pvd_parts(path, &parts))?;
    }
    Ok(surface)
}
