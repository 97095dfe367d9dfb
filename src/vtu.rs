//! VTK XML output for ParaView: `.vtu` UnstructuredGrid files with point and
//! cell data, `.vtp` PolyData point clouds (contact points) and triangle
//! surfaces (the body's boundary), and `.pvd`
//! collections that string them into a time series.
//!
//! This file owns the public data model ([`VtuMesh`], [`VtuCell`],
//! [`DataArray`]), the checks run before anything is written, and the
//! writers. Node reordering from our lexicographic numbering lives in
//! `vtu/order.rs`; the XML itself is laid out and streamed in `vtu/xml.rs`,
//! the appended data section in `vtu/appended.rs`; [`read`] (`vtu/read.rs`)
//! reads the files back.
//!
//! Files are streamed with [`crate::output::write_atomic_with`] to a
//! temporary file renamed into place, so a reader never sees half a file,
//! and nothing is written at all when a check fails.
//!
//! Encodings ([`VtuEncoding`]), all bit-exact but ASCII, all little endian
//! with `UInt64` headers:
//! - `Appended` (the default): VTK's appended raw binary, every DataArray
//!   `format="appended"` with its `offset` into one `<AppendedData
//!   encoding="raw">` section after the XML, each array its byte count and
//!   its values. The values are written from memory as they are: the fastest,
//!   and the smallest uncompressed file. The file is not text.
//! - `AppendedZlib`: the same section with every array compressed by zlib in
//!   independent blocks (`compressor="vtkZLibDataCompressor"`), compressed in
//!   parallel before anything is written.
//! - `Binary`: inline base64 (`format="binary"`): each DataArray is the
//!   base64 of an 8-byte byte count followed by the values; a third larger
//!   than `Appended`, but the file is text.
//! - `Ascii`: the values as text (shortest decimal that parses back to the
//!   same `f64`; non-finite values as `nan`, `inf`, `-inf`), for small
//!   debugging outputs; note that VTK 9.3's ASCII reader reads `-inf` back as
//!   `+inf`, so use a binary encoding where infinities matter.

mod appended;
mod order;
mod read;
mod xml;

#[cfg(test)]
mod tests;

use std::collections::HashSet;
use std::path::Path;

use crate::error::{Error, Result};
use crate::output::{write_atomic, write_atomic_with};

pub use order::{hex27_vtk_order_from_lexicographic, hex8_vtk_order_from_lexicographic};
pub use read::read;

/// One cell with its node indices (into [`VtuMesh::points`]) in VTK's own
/// node order; [`hex8_vtk_order_from_lexicographic`] and
/// [`hex27_vtk_order_from_lexicographic`] convert our lexicographic numbering.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum VtuCell {
    /// `VTK_VERTEX` (1): a single point, for point clouds.
    Vertex(usize),
    /// `VTK_TRIANGLE` (5): 3 corners, counter-clockwise seen from the side
    /// the normal points to.
    Triangle([usize; 3]),
    /// `VTK_HEXAHEDRON` (12): 8 corners.
    Hexahedron([usize; 8]),
    /// `VTK_TRIQUADRATIC_HEXAHEDRON` (29): 8 corners, 12 edge midpoints,
    /// 6 face centres, the body centre (boxed, so that a cell of the other
    /// kinds, as a Q1 body's millions of hexahedra, stays 72 bytes).
    TriQuadraticHexahedron(Box<[usize; 27]>),
}

impl VtuCell {
    /// A hexahedron from node indices in lexicographic order `a + 2b + 4c`.
    pub fn hex8_from_lexicographic(lex: [usize; 8]) -> Self {
        VtuCell::Hexahedron(hex8_vtk_order_from_lexicographic(lex))
    }

    /// A triquadratic hexahedron from node indices in lexicographic order
    /// `a + 3b + 9c`.
    pub fn hex27_from_lexicographic(lex: [usize; 27]) -> Self {
        VtuCell::TriQuadraticHexahedron(Box::new(hex27_vtk_order_from_lexicographic(lex)))
    }

    /// The VTK cell type id.
    pub fn vtk_type(&self) -> u8 {
        match self {
            VtuCell::Vertex(_) => 1,
            VtuCell::Triangle(_) => 5,
            VtuCell::Hexahedron(_) => 12,
            VtuCell::TriQuadraticHexahedron(_) => 29,
        }
    }

    /// The node indices in VTK order.
    pub fn nodes(&self) -> &[usize] {
        match self {
            VtuCell::Vertex(n) => std::slice::from_ref(n),
            VtuCell::Triangle(n) => n,
            VtuCell::Hexahedron(n) => n,
            VtuCell::TriQuadraticHexahedron(n) => n.as_slice(),
        }
    }
}

/// Points and cells of an unstructured grid.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VtuMesh {
    /// Point coordinates; must all be finite.
    pub points: Vec<[f64; 3]>,
    /// Cells referring to `points` by index.
    pub cells: Vec<VtuCell>,
}

impl VtuMesh {
    /// A point cloud: one [`VtuCell::Vertex`] per point, so that ParaView
    /// shows the points without a glyph filter.
    pub fn point_cloud(points: Vec<[f64; 3]>) -> Self {
        let cells = (0..points.len()).map(VtuCell::Vertex).collect();
        VtuMesh { points, cells }
    }
}

/// The values of a data array, tuple after tuple, components interleaved.
#[derive(Debug, Clone, PartialEq)]
pub enum DataValues {
    /// Written as `Float64`.
    F64(Vec<f64>),
    /// Written as `Int64` (as the cells' `connectivity` and `offsets`).
    I64(Vec<i64>),
    /// Written as `Int32`.
    I32(Vec<i32>),
    /// Written as `UInt8` (classification flags and the like).
    U8(Vec<u8>),
}

impl DataValues {
    /// Number of values (tuples × components).
    pub fn len(&self) -> usize {
        match self {
            DataValues::F64(v) => v.len(),
            DataValues::I64(v) => v.len(),
            DataValues::I32(v) => v.len(),
            DataValues::U8(v) => v.len(),
        }
    }

    /// Whether there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A named point or cell data array. NaN and infinities are allowed.
#[derive(Debug, Clone, PartialEq)]
pub struct DataArray {
    /// Name shown in ParaView; any text (it is escaped in the XML).
    pub name: String,
    /// Components per tuple: 1 scalar, 3 vector, 9 tensor.
    pub components: usize,
    /// `components` values per point (or cell).
    pub values: DataValues,
}

impl DataArray {
    /// A scalar `Float64` array.
    pub fn scalars_f64(name: impl Into<String>, values: Vec<f64>) -> Self {
        Self::with(name, 1, DataValues::F64(values))
    }

    /// A scalar `Int32` array.
    pub fn scalars_i32(name: impl Into<String>, values: Vec<i32>) -> Self {
        Self::with(name, 1, DataValues::I32(values))
    }

    /// A scalar `UInt8` array.
    pub fn scalars_u8(name: impl Into<String>, values: Vec<u8>) -> Self {
        Self::with(name, 1, DataValues::U8(values))
    }

    /// A 3-component `Float64` vector array.
    pub fn vectors(name: impl Into<String>, values: &[[f64; 3]]) -> Self {
        let flat = values.iter().flatten().copied().collect();
        Self::with(name, 3, DataValues::F64(flat))
    }

    /// A symmetric tensor array from Voigt-ordered tensor components
    /// `(xx, yy, zz, yz, xz, xy)` (the crate's stress order; pass tensor
    /// shear components, not engineering shear strains). Written as a full
    /// 9-component row-major tensor `(xx, xy, xz, yx, yy, yz, zx, zy, zz)`,
    /// which ParaView recognises as a tensor (components `XX` … `ZZ`).
    pub fn sym_tensors(name: impl Into<String>, voigt: &[[f64; 6]]) -> Self {
        let flat = voigt.iter().flat_map(full_tensor).collect();
        Self::with(name, 9, DataValues::F64(flat))
    }

    fn with(name: impl Into<String>, components: usize, values: DataValues) -> Self {
        DataArray {
            name: name.into(),
            components,
            values,
        }
    }
}

/// Row-major 3×3 tensor from Voigt `(xx, yy, zz, yz, xz, xy)`.
fn full_tensor(v: &[f64; 6]) -> [f64; 9] {
    let [xx, yy, zz, yz, xz, xy] = *v;
    [xx, xy, xz, xy, yy, yz, xz, yz, zz]
}

/// How DataArray values are written (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VtuEncoding {
    /// Appended raw binary: the fastest, bit-exact; not text.
    #[default]
    Appended,
    /// Appended, each array zlib-compressed in independent blocks.
    AppendedZlib,
    /// Inline base64 with a `UInt64` byte-count header: bit-exact, text.
    Binary,
    /// Whitespace-separated text, for small debugging outputs (VTK 9.3
    /// reads `-inf` back as `+inf`; see the module doc).
    Ascii,
}

/// Writes `mesh` with its point and cell data to the `.vtu` file `path`.
///
/// Fails with [`Error::Io`] (and writes nothing) when a point is not finite,
/// a cell refers to a missing point, an array has a length other than
/// count × components or zero components, or two arrays of the same kind
/// share a name; and when the file cannot be written.
pub fn write_vtu(
    path: &Path,
    mesh: &VtuMesh,
    point_data: &[DataArray],
    cell_data: &[DataArray],
    encoding: VtuEncoding,
) -> Result<()> {
    let fail = |reason: String| Error::Io {
        path: path.display().to_string(),
        reason,
    };
    check_mesh(mesh).map_err(fail)?;
    check_arrays("point", point_data, mesh.points.len()).map_err(fail)?;
    check_arrays("cell", cell_data, mesh.cells.len()).map_err(fail)?;
    let cells = xml::CellArrays::new(mesh);
    let doc = xml::unstructured_grid(mesh, &cells, point_data, cell_data);
    write_atomic_with(path, |w| xml::write(&doc, encoding, w))
}

/// Writes the point cloud `points` with `point_data` as the PolyData file
/// `path` (`.vtp`, one vertex per point). Fails with [`Error::Io`] (and
/// writes nothing) on a non-finite coordinate or an array of the wrong
/// length, and when the file cannot be written.
pub fn write_vtp_points(
    path: &Path,
    points: &[[f64; 3]],
    point_data: &[DataArray],
    encoding: VtuEncoding,
) -> Result<()> {
    let fail = |reason: String| Error::Io {
        path: path.display().to_string(),
        reason,
    };
    let cloud = VtuMesh::point_cloud(points.to_vec());
    check_mesh(&cloud).map_err(fail)?;
    check_arrays("point", point_data, points.len()).map_err(fail)?;
    let cells = xml::CellArrays::new(&cloud);
    let doc = xml::poly_data(&cloud, &cells, xml::PolySection::Verts, point_data, &[]);
    write_atomic_with(path, |w| xml::write(&doc, encoding, w))
}

/// Writes the triangle surface `points`, `triangles` (indices into `points`)
/// with its point and cell (per triangle) data as the PolyData file `path`
/// (`.vtp`). Fails with [`Error::Io`] (and writes nothing) as
/// [`write_vtu`] does, and when the file cannot be written.
pub fn write_vtp_triangles(
    path: &Path,
    points: &[[f64; 3]],
    triangles: &[[usize; 3]],
    point_data: &[DataArray],
    cell_data: &[DataArray],
    encoding: VtuEncoding,
) -> Result<()> {
    let fail = |reason: String| Error::Io {
        path: path.display().to_string(),
        reason,
    };
    let mesh = VtuMesh {
        points: points.to_vec(),
        cells: triangles.iter().map(|&t| VtuCell::Triangle(t)).collect(),
    };
    check_mesh(&mesh).map_err(fail)?;
    check_arrays("point", point_data, mesh.points.len()).map_err(fail)?;
    check_arrays("cell", cell_data, mesh.cells.len()).map_err(fail)?;
    let cells = xml::CellArrays::new(&mesh);
    let doc = xml::poly_data(
        &mesh,
        &cells,
        xml::PolySection::Polys,
        point_data,
        cell_data,
    );
    write_atomic_with(path, |w| xml::write(&doc, encoding, w))
}

/// Writes the parallel unstructured grid `path` (`.pvtu`): the files
/// `pieces` (relative to its folder), each written by [`write_vtu`] with
/// arrays of the names, types and components of `point_data` and
/// `cell_data` (their values are not read), shown by ParaView as one data
/// set. Fails with [`Error::Io`] when a piece's name is not valid UTF-8 or
/// the file cannot be written.
pub fn write_pvtu<P: AsRef<Path>>(
    path: &Path,
    point_data: &[DataArray],
    cell_data: &[DataArray],
    pieces: &[P],
) -> Result<()> {
    let names: Vec<&str> = pieces
        .iter()
        .map(|p| {
            p.as_ref().to_str().ok_or_else(|| Error::Io {
                path: path.display().to_string(),
                reason: format!("piece {} is not valid UTF-8", p.as_ref().display()),
            })
        })
        .collect::<Result<_>>()?;
    write_atomic(
        path,
        xml::parallel_grid(point_data, cell_data, &names).as_bytes(),
    )
}

/// Writes the `.pvd` collection `path` listing `(time, file)` entries, each
/// file given relative to the `.pvd`'s folder (as ParaView resolves it).
///
/// Fails with [`Error::Io`] (and writes nothing) when a time is not finite or
/// a file name is not valid UTF-8; and when the file cannot be written.
pub fn write_pvd<P: AsRef<Path>>(path: &Path, entries: &[(f64, P)]) -> Result<()> {
    let parts: Vec<(f64, usize, &Path)> =
        entries.iter().map(|(t, f)| (*t, 0, f.as_ref())).collect();
    write_pvd_parts(path, &parts)
}

/// [`write_pvd`] with several parts per time step: `(time, part, file)`
/// entries, ParaView showing the files of one time with different `part`
/// numbers together (several bodies, say).
pub fn write_pvd_parts<P: AsRef<Path>>(path: &Path, entries: &[(f64, usize, P)]) -> Result<()> {
    let fail = |reason: String| Error::Io {
        path: path.display().to_string(),
        reason,
    };
    let mut checked = Vec::with_capacity(entries.len());
    for (i, (time, part, file)) in entries.iter().enumerate() {
        let (time, name) = check_pvd_entry(i, *time, file.as_ref()).map_err(fail)?;
        checked.push((time, *part, name));
    }
    write_atomic(path, xml::collection(&checked).as_bytes())
}

fn check_pvd_entry(i: usize, time: f64, file: &Path) -> std::result::Result<(f64, &str), String> {
    if !time.is_finite() {
        return Err(format!("collection entry {i}: time {time} is not finite"));
    }
    let name = file.to_str().ok_or_else(|| {
        format!(
            "collection entry {i}: file name {} is not valid UTF-8",
            file.display()
        )
    })?;
    Ok((time, name))
}

/// Points finite, cell nodes in range.
fn check_mesh(mesh: &VtuMesh) -> std::result::Result<(), String> {
    if let Some(i) = mesh
        .points
        .iter()
        .position(|p| !p.iter().all(|x| x.is_finite()))
    {
        return Err(format!(
            "point {i} has a non-finite coordinate {:?}",
            mesh.points[i]
        ));
    }
    let n = mesh.points.len();
    for (c, cell) in mesh.cells.iter().enumerate() {
        if let Some(&bad) = cell.nodes().iter().find(|&&k| k >= n) {
            return Err(format!(
                "cell {c} refers to point {bad}, but the mesh has {n} points"
            ));
        }
    }
    Ok(())
}

/// Every array has `count` tuples of at least one component; names unique.
fn check_arrays(kind: &str, arrays: &[DataArray], count: usize) -> std::result::Result<(), String> {
    let mut names = HashSet::new();
    for a in arrays {
        if !names.insert(a.name.as_str()) {
            return Err(format!("{kind} data '{}' is given twice", a.name));
        }
        let expected = count.checked_mul(a.components);
        if a.components == 0 || expected != Some(a.values.len()) {
            return Err(format!(
                "{kind} data '{}' has {} values, expected {count} {kind}s × {} components",
                a.name,
                a.values.len(),
                a.components
            ));
        }
    }
    Ok(())
}
