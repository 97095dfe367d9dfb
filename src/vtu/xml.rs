//! The XML of `.vtu`, `.vtp` (point clouds, triangle surfaces) and `.pvd`
//! files: the element layout of a document ([`Document`]: XML text with the
//! DataArrays in between), streamed to a writer in each [`VtuEncoding`] —
//! the DataArray bodies inline (base64 with a `UInt64` byte-count header, or
//! ASCII) or in the appended section (`vtu/appended.rs`) — attribute
//! escaping and a small base64 encoder. Inputs are checked by the caller
//! (`vtu.rs`) before they get here.

use std::borrow::Cow;
use std::fmt::Write as _;
use std::io::{self, Write};

use rayon::prelude::*;

use super::appended::{self, Block};
use super::{DataArray, DataValues, VtuEncoding, VtuMesh};

/// The values of one DataArray, borrowed.
#[derive(Clone, Copy, Debug)]
pub(super) enum Values<'a> {
    F64(&'a [f64]),
    I64(&'a [i64]),
    I32(&'a [i32]),
    U8(&'a [u8]),
}

impl<'a> Values<'a> {
    fn of(values: &'a DataValues) -> Values<'a> {
        match values {
            DataValues::F64(v) => Values::F64(v),
            DataValues::I64(v) => Values::I64(v),
            DataValues::I32(v) => Values::I32(v),
            DataValues::U8(v) => Values::U8(v),
        }
    }

    /// The VTK type name.
    fn vtk_type(self) -> &'static str {
        match self {
            Values::F64(_) => "Float64",
            Values::I64(_) => "Int64",
            Values::I32(_) => "Int32",
            Values::U8(_) => "UInt8",
        }
    }

    /// The values' little-endian bytes: the values' own memory on a
    /// little-endian machine, a converted copy on another.
    pub(super) fn le_bytes(self) -> Cow<'a, [u8]> {
        if cfg!(target_endian = "little") {
            Cow::Borrowed(match self {
                Values::F64(v) => bytemuck::cast_slice(v),
                Values::I64(v) => bytemuck::cast_slice(v),
                Values::I32(v) => bytemuck::cast_slice(v),
                Values::U8(v) => v,
            })
        } else {
            Cow::Owned(match self {
                Values::F64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
                Values::I64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
                Values::I32(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
                Values::U8(v) => v.to_vec(),
            })
        }
    }

    /// The values as whitespace-separated text.
    fn ascii(self) -> String {
        fn join<T>(values: &[T], text: impl Fn(&T) -> String) -> String {
            values.iter().map(text).collect::<Vec<_>>().join(" ")
        }
        match self {
            Values::F64(v) => join(v, |x| format_f64(*x)),
            Values::I64(v) => join(v, i64::to_string),
            Values::I32(v) => join(v, i32::to_string),
            Values::U8(v) => join(v, u8::to_string),
        }
    }
}

/// One DataArray of a document.
#[derive(Clone, Copy, Debug)]
pub(super) struct Array<'a> {
    name: &'a str,
    components: usize,
    values: Values<'a>,
}

/// A piece of a document: XML text, or a DataArray.
#[derive(Debug)]
enum Item<'a> {
    Text(String),
    Array(Array<'a>),
}

/// A `.vtu` or `.vtp` document: the items inside its `kind` element.
#[derive(Debug)]
pub(super) struct Document<'a> {
    kind: &'static str,
    items: Vec<Item<'a>>,
}

impl<'a> Document<'a> {
    fn new(kind: &'static str) -> Self {
        Document {
            kind,
            items: Vec::new(),
        }
    }

    fn text(&mut self, text: impl Into<String>) {
        self.items.push(Item::Text(text.into()));
    }

    fn array(&mut self, name: &'a str, components: usize, values: Values<'a>) {
        self.items.push(Item::Array(Array {
            name,
            components,
            values,
        }));
    }

    fn data_section(&mut self, tag: &str, arrays: &'a [DataArray]) {
        self.text(format!("      <{tag}>\n"));
        for a in arrays {
            self.array(&a.name, a.components, Values::of(&a.values));
        }
        self.text(format!("      </{tag}>\n"));
    }

    fn points(&mut self, points: &'a [[f64; 3]]) {
        self.text("      <Points>\n");
        self.array("Points", 3, Values::F64(points.as_flattened()));
        self.text("      </Points>\n");
    }

    /// The document's DataArrays in order.
    fn arrays(&self) -> impl Iterator<Item = &Array<'a>> {
        self.items.iter().filter_map(|item| match item {
            Item::Array(a) => Some(a),
            Item::Text(_) => None,
        })
    }
}

/// The cells' nodes one after the other, the end of each cell's nodes, and
/// the cell types: the arrays that describe a mesh's cells.
pub(super) struct CellArrays {
    connectivity: Vec<i64>,
    offsets: Vec<i64>,
    types: Vec<u8>,
}

impl CellArrays {
    pub(super) fn new(mesh: &VtuMesh) -> CellArrays {
        let connectivity = (mesh.cells.par_iter())
            .flat_map_iter(|cell| cell.nodes().iter().map(|&n| n as i64))
            .collect();
        let offsets = (mesh.cells.iter())
            .scan(0i64, |end, cell| {
                *end += cell.nodes().len() as i64;
                Some(*end)
            })
            .collect();
        let types = mesh.cells.par_iter().map(|c| c.vtk_type()).collect();
        CellArrays {
            connectivity,
            offsets,
            types,
        }
    }
}

/// The `.vtu` document.
pub(super) fn unstructured_grid<'a>(
    mesh: &'a VtuMesh,
    cells: &'a CellArrays,
    point_data: &'a [DataArray],
    cell_data: &'a [DataArray],
) -> Document<'a> {
    let mut d = Document::new("UnstructuredGrid");
    d.text(format!(
        "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n",
        mesh.points.len(),
        mesh.cells.len()
    ));
    d.data_section("PointData", point_data);
    d.data_section("CellData", cell_data);
    d.points(&mesh.points);
    d.text("      <Cells>\n");
    d.array("connectivity", 1, Values::I64(&cells.connectivity));
    d.array("offsets", 1, Values::I64(&cells.offsets));
    d.array("types", 1, Values::U8(&cells.types));
    d.text("      </Cells>\n    </Piece>\n");
    d
}

/// The PolyData section holding a `.vtp` file's cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum PolySection {
    /// Vertices (point clouds).
    Verts,
    /// Polygons (triangle surfaces).
    Polys,
}

/// The `.vtp` document of `mesh`, its cells all in `section`.
pub(super) fn poly_data<'a>(
    mesh: &'a VtuMesh,
    cells: &'a CellArrays,
    section: PolySection,
    point_data: &'a [DataArray],
    cell_data: &'a [DataArray],
) -> Document<'a> {
    let (tag, verts, polys) = match section {
        PolySection::Verts => ("Verts", mesh.cells.len(), 0),
        PolySection::Polys => ("Polys", 0, mesh.cells.len()),
    };
    let mut d = Document::new("PolyData");
    d.text(format!(
        "    <Piece NumberOfPoints=\"{}\" NumberOfVerts=\"{verts}\" NumberOfLines=\"0\" \
         NumberOfStrips=\"0\" NumberOfPolys=\"{polys}\">\n",
        mesh.points.len()
    ));
    d.data_section("PointData", point_data);
    if !cell_data.is_empty() {
        d.data_section("CellData", cell_data);
    }
    d.points(&mesh.points);
    d.text(format!("      <{tag}>\n"));
    d.array("connectivity", 1, Values::I64(&cells.connectivity));
    d.array("offsets", 1, Values::I64(&cells.offsets));
    d.text(format!("      </{tag}>\n    </Piece>\n"));
    d
}

/// Streams `doc` to `w` in `encoding`. The appended encodings write every
/// DataArray as an empty element with its offset into the appended section,
/// and the section after the document's element; the compressed one
/// compresses every array first (in parallel blocks), since the offsets
/// come before the data.
pub(super) fn write(doc: &Document, encoding: VtuEncoding, w: &mut impl Write) -> io::Result<()> {
    let blocks: Vec<Block> = match encoding {
        VtuEncoding::Appended => doc.arrays().map(|a| Block::raw(a.values)).collect(),
        VtuEncoding::AppendedZlib => {
            let arrays: Vec<&Array> = doc.arrays().collect();
            arrays
                .par_iter()
                .map(|a| Block::zlib(a.values))
                .collect::<io::Result<_>>()?
        }
        VtuEncoding::Binary | VtuEncoding::Ascii => Vec::new(),
    };
    let compressor = match encoding {
        VtuEncoding::AppendedZlib => " compressor=\"vtkZLibDataCompressor\"",
        _ => "",
    };
    write!(
        w,
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"{}\" version=\"1.0\" \
         byte_order=\"LittleEndian\" header_type=\"UInt64\"{compressor}>\n  <{}>\n",
        doc.kind, doc.kind
    )?;
    let mut next = blocks.iter();
    let mut offset = 0;
    for item in &doc.items {
        match item {
            Item::Text(text) => w.write_all(text.as_bytes())?,
            Item::Array(a) => {
                let start = format!(
                    "        <DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\" format=",
                    a.values.vtk_type(),
                    escape(a.name),
                    a.components
                );
                w.write_all(start.as_bytes())?;
                match encoding {
                    VtuEncoding::Appended | VtuEncoding::AppendedZlib => {
                        writeln!(w, "\"appended\" offset=\"{offset}\"/>")?;
                        offset += next.next().map_or(0, Block::len);
                    }
                    VtuEncoding::Binary => {
                        let body = binary_body(a.values);
                        writeln!(w, "\"binary\">\n          {body}\n        </DataArray>")?;
                    }
                    VtuEncoding::Ascii => {
                        let body = a.values.ascii();
                        writeln!(w, "\"ascii\">\n          {body}\n        </DataArray>")?;
                    }
                }
            }
        }
    }
    writeln!(w, "  </{}>", doc.kind)?;
    if matches!(encoding, VtuEncoding::Appended | VtuEncoding::AppendedZlib) {
        appended::write_section(&blocks, w)?;
    }
    w.write_all(b"</VTKFile>\n")
}

/// The whole `.pvd` document for checked `(time, file)` entries.
pub(super) fn collection(entries: &[(f64, usize, &str)]) -> String {
    let mut s = String::from("<?xml version=\"1.0\"?>\n");
    s.push_str("<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n");
    s.push_str("  <Collection>\n");
    for (time, part, file) in entries {
        let _ = writeln!(
            s,
            "    <DataSet timestep=\"{}\" group=\"\" part=\"{part}\" file=\"{}\"/>",
            format_f64(*time),
            escape(file)
        );
    }
    s.push_str("  </Collection>\n</VTKFile>\n");
    s
}

/// The whole `.pvtu` document: the arrays' declarations (as in each piece)
/// and the pieces' files.
pub(super) fn parallel_grid(
    point_data: &[DataArray],
    cell_data: &[DataArray],
    pieces: &[&str],
) -> String {
    let mut s = String::from("<?xml version=\"1.0\"?>\n");
    s.push_str(
        "<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\">\n",
    );
    s.push_str("  <PUnstructuredGrid GhostLevel=\"0\">\n");
    let declare = |s: &mut String, tag: &str, arrays: &[DataArray]| {
        let _ = writeln!(s, "    <{tag}>");
        for a in arrays {
            let _ = writeln!(
                s,
                "      <PDataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\"/>",
                Values::of(&a.values).vtk_type(),
                escape(&a.name),
                a.components
            );
        }
        let _ = writeln!(s, "    </{tag}>");
    };
    declare(&mut s, "PPointData", point_data);
    declare(&mut s, "PCellData", cell_data);
    s.push_str("    <PPoints>\n      <PDataArray type=\"Float64\" NumberOfComponents=\"3\"/>\n    </PPoints>\n");
    for file in pieces {
        let _ = writeln!(s, "    <Piece Source=\"{}\"/>", escape(file));
    }
    s.push_str("  </PUnstructuredGrid>\n</VTKFile>\n");
    s
}

/// base64 of the `UInt64` little-endian byte count followed by the raw
/// little-endian bytes of every value.
fn binary_body(values: Values) -> String {
    let bytes = values.le_bytes();
    let mut raw = Vec::with_capacity(8 + bytes.len());
    raw.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
    raw.extend_from_slice(&bytes);
    base64_encode(&raw)
}

/// Shortest text that parses back to the same value, in a form C's `strtod`
/// reads (`nan`, `inf`, `-inf` for the non-finite values).
fn format_f64(x: f64) -> String {
    if x.is_nan() {
        "nan".to_string()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.to_string()
    } else {
        format!("{x:?}")
    }
}

/// Escapes text for a double-quoted XML attribute value.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            _ => out.push(c),
        }
    }
    out
}

const BASE64_ALPHABET: &[u8; 64] =
    b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Bytes per block of [`base64_encode`]: a multiple of 3, so that the blocks'
/// codes concatenate to the code of the whole.
const BASE64_BLOCK: usize = 3 << 16;

/// Standard base64 (RFC 4648, with `=` padding), encoded in parallel blocks
/// straight into the output.
fn base64_encode(bytes: &[u8]) -> String {
    let mut out = vec![0u8; base64_len(bytes.len())];
    out.par_chunks_mut(base64_len(BASE64_BLOCK))
        .zip(bytes.par_chunks(BASE64_BLOCK))
        .for_each(|(code, block)| base64_block(block, code));
    String::from_utf8(out).expect("base64 is ASCII")
}

/// The length of the base64 code of `n` bytes.
fn base64_len(n: usize) -> usize {
    n.div_ceil(3) * 4
}

/// Writes the base64 code of `bytes` into `out` (`base64_len(bytes.len())`
/// long), padded when the length of `bytes` is not a multiple of 3.
fn base64_block(bytes: &[u8], out: &mut [u8]) {
    for (chunk, code) in bytes.chunks(3).zip(out.chunks_mut(4)) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for (k, c) in code.iter_mut().enumerate() {
            *c = if k <= chunk.len() {
                BASE64_ALPHABET[(n >> (18 - 6 * k)) as usize & 63]
            } else {
                b'='
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (input, expected) in cases {
            assert_eq!(base64_encode(input.as_bytes()), expected, "{input:?}");
        }
        assert_eq!(base64_encode(&[0xfb, 0xff, 0xbf]), "+/+/");
    }

    #[test]
    fn base64_blocks_concatenate_to_the_code_of_the_whole() {
        for len in [BASE64_BLOCK, 2 * BASE64_BLOCK + 1, 3 * BASE64_BLOCK + 2] {
            let bytes: Vec<u8> = (0..len).map(|i| (i * 7 + i / 251) as u8).collect();
            let mut code = vec![0u8; base64_len(len)];
            base64_block(&bytes, &mut code);
            let whole = String::from_utf8(code).unwrap();
            assert_eq!(base64_encode(&bytes), whole, "{len} bytes");
        }
    }

    #[test]
    fn f64_text_round_trips_and_strtod_reads_non_finite() {
        for x in [0.1, -0.0, 1e-300, 5e-324, 1.7976931348623157e308, -2.5] {
            let back: f64 = format_f64(x).parse().unwrap();
            assert_eq!(back.to_bits(), x.to_bits(), "{x}");
        }
        assert_eq!(format_f64(f64::NAN), "nan");
        assert_eq!(format_f64(f64::NEG_INFINITY), "-inf");
        assert_eq!(format_f64(f64::INFINITY), "inf");
    }

    #[test]
    fn escape_replaces_markup_characters() {
        assert_eq!(escape(r#"a<b>&"c'"#), "a&lt;b&gt;&amp;&quot;c&apos;");
    }

    #[test]
    fn little_endian_bytes_are_the_values_in_order() {
        let v = [1.5f64, -0.0];
        let expected: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        assert_eq!(&*Values::F64(&v).le_bytes(), expected.as_slice());
        assert_eq!(&*Values::I32(&[-2]).le_bytes(), (-2i32).to_le_bytes());
    }
}
