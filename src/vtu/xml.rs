//! The XML text of `.vtu`, `.vtp` (point clouds, triangle surfaces) and `.pvd` files: element layout, DataArray
//! encoding (inline base64 with a `UInt64` byte-count header, or ASCII),
//! attribute escaping and a small base64 encoder. Inputs are checked by the
//! caller (`vtu.rs`) before they get here.

use std::fmt::Write;

use rayon::prelude::*;

use super::{DataArray, DataValues, VtuEncoding, VtuMesh};

/// The whole `.vtu` document.
pub(super) fn unstructured_grid(
    mesh: &VtuMesh,
    point_data: &[DataArray],
    cell_data: &[DataArray],
    encoding: VtuEncoding,
) -> String {
    let mut s = document_start("UnstructuredGrid");
    let _ = writeln!(
        s,
        "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
        mesh.points.len(),
        mesh.cells.len()
    );
    push_data_section(&mut s, "PointData", point_data, encoding);
    push_data_section(&mut s, "CellData", cell_data, encoding);
    push_points(&mut s, &mesh.points, encoding);
    push_cells(&mut s, mesh, encoding);
    s.push_str("    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
    s
}

/// The PolyData section holding a `.vtp` file's cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum PolySection {
    /// Vertices (point clouds).
    Verts,
    /// Polygons (triangle surfaces).
    Polys,
}

/// The whole `.vtp` document of `mesh`, its cells all in `section`.
pub(super) fn poly_data(
    mesh: &VtuMesh,
    section: PolySection,
    point_data: &[DataArray],
    cell_data: &[DataArray],
    encoding: VtuEncoding,
) -> String {
    let (tag, verts, polys) = match section {
        PolySection::Verts => ("Verts", mesh.cells.len(), 0),
        PolySection::Polys => ("Polys", 0, mesh.cells.len()),
    };
    let mut s = document_start("PolyData");
    let _ = writeln!(
        s,
        "    <Piece NumberOfPoints=\"{}\" NumberOfVerts=\"{verts}\" NumberOfLines=\"0\" \
         NumberOfStrips=\"0\" NumberOfPolys=\"{polys}\">",
        mesh.points.len()
    );
    push_data_section(&mut s, "PointData", point_data, encoding);
    if !cell_data.is_empty() {
        push_data_section(&mut s, "CellData", cell_data, encoding);
    }
    push_points(&mut s, &mesh.points, encoding);
    let (connectivity, offsets) = connectivity_and_offsets(mesh);
    let _ = writeln!(s, "      <{tag}>");
    push_i64_array(&mut s, "connectivity", &connectivity, encoding);
    push_i64_array(&mut s, "offsets", &offsets, encoding);
    let _ = writeln!(s, "      </{tag}>");
    s.push_str("    </Piece>\n  </PolyData>\n</VTKFile>\n");
    s
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

fn push_data_section(s: &mut String, tag: &str, arrays: &[DataArray], encoding: VtuEncoding) {
    let _ = writeln!(s, "      <{tag}>");
    for a in arrays {
        push_array(s, &a.name, a.components, &a.values, encoding);
    }
    let _ = writeln!(s, "      </{tag}>");
}

/// The XML declaration and the opening `VTKFile` and `kind` tags.
fn document_start(kind: &str) -> String {
    let mut s = String::from("<?xml version=\"1.0\"?>\n");
    let _ = writeln!(
        s,
        "<VTKFile type=\"{kind}\" version=\"1.0\" \
         byte_order=\"LittleEndian\" header_type=\"UInt64\">"
    );
    let _ = writeln!(s, "  <{kind}>");
    s
}

fn push_points(s: &mut String, points: &[[f64; 3]], encoding: VtuEncoding) {
    let coords = points.iter().flatten().copied().collect();
    s.push_str("      <Points>\n");
    push_array(s, "Points", 3, &DataValues::F64(coords), encoding);
    s.push_str("      </Points>\n");
}

/// The cells' nodes one after the other, and the end of each cell's nodes.
fn connectivity_and_offsets(mesh: &VtuMesh) -> (Vec<i64>, Vec<i64>) {
    let mut connectivity = Vec::new();
    let mut offsets = Vec::with_capacity(mesh.cells.len());
    for cell in &mesh.cells {
        connectivity.extend(cell.nodes().iter().map(|&n| n as i64));
        offsets.push(connectivity.len() as i64);
    }
    (connectivity, offsets)
}

fn push_cells(s: &mut String, mesh: &VtuMesh, encoding: VtuEncoding) {
    let (connectivity, offsets) = connectivity_and_offsets(mesh);
    let types: Vec<u8> = mesh.cells.iter().map(|c| c.vtk_type()).collect();
    s.push_str("      <Cells>\n");
    push_i64_array(s, "connectivity", &connectivity, encoding);
    push_i64_array(s, "offsets", &offsets, encoding);
    push_array(s, "types", 1, &DataValues::U8(types), encoding);
    s.push_str("      </Cells>\n");
}

fn push_i64_array(s: &mut String, name: &str, values: &[i64], encoding: VtuEncoding) {
    let body = match encoding {
        VtuEncoding::Binary => binary_body(values.len() * 8, values, |v| v.to_le_bytes()),
        VtuEncoding::Ascii => ascii_body(values, |v| v.to_string()),
    };
    push_element(s, name, "Int64", 1, encoding, &body);
}

fn push_array(
    s: &mut String,
    name: &str,
    components: usize,
    values: &DataValues,
    encoding: VtuEncoding,
) {
    let (vtk_type, body) = match (values, encoding) {
        (DataValues::F64(v), VtuEncoding::Binary) => {
            ("Float64", binary_body(v.len() * 8, v, |x| x.to_le_bytes()))
        }
        (DataValues::F64(v), VtuEncoding::Ascii) => ("Float64", ascii_body(v, |x| format_f64(*x))),
        (DataValues::I32(v), VtuEncoding::Binary) => {
            ("Int32", binary_body(v.len() * 4, v, |x| x.to_le_bytes()))
        }
        (DataValues::I32(v), VtuEncoding::Ascii) => ("Int32", ascii_body(v, |x| x.to_string())),
        (DataValues::U8(v), VtuEncoding::Binary) => ("UInt8", binary_body(v.len(), v, |x| [*x])),
        (DataValues::U8(v), VtuEncoding::Ascii) => ("UInt8", ascii_body(v, |x| x.to_string())),
    };
    push_element(s, name, vtk_type, components, encoding, &body);
}

fn push_element(
    s: &mut String,
    name: &str,
    vtk_type: &str,
    components: usize,
    encoding: VtuEncoding,
    body: &str,
) {
    let format = match encoding {
        VtuEncoding::Binary => "binary",
        VtuEncoding::Ascii => "ascii",
    };
    let _ = writeln!(
        s,
        "        <DataArray type=\"{vtk_type}\" Name=\"{}\" NumberOfComponents=\"{components}\" \
         format=\"{format}\">",
        escape(name)
    );
    let _ = writeln!(s, "          {body}");
    s.push_str("        </DataArray>\n");
}

/// base64 of the `UInt64` little-endian byte count followed by the raw
/// little-endian bytes of every value (`bytes` gives one value's bytes).
fn binary_body<T, const N: usize>(
    byte_count: usize,
    values: &[T],
    bytes: impl Fn(&T) -> [u8; N],
) -> String {
    let mut raw = Vec::with_capacity(8 + byte_count);
    raw.extend_from_slice(&(byte_count as u64).to_le_bytes());
    for v in values {
        raw.extend_from_slice(&bytes(v));
    }
    base64_encode(&raw)
}

fn ascii_body<T>(values: &[T], text: impl Fn(&T) -> String) -> String {
    values.iter().map(text).collect::<Vec<_>>().join(" ")
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
pub(super) fn base64_encode(bytes: &[u8]) -> String {
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
}
