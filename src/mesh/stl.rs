//! Reading STL files, binary or ASCII, with the `stl_io` crate.
//!
//! The format is decided by the file itself, not by its first word: a file
//! is binary when its length is exactly `84 + 50 n` bytes with `n` the count
//! in its header (many binary exporters begin the 80-byte header with
//! `solid`, which fools a reader that looks at the first word only), ASCII
//! when it begins with `solid`, and neither otherwise (a truncated binary file
//! says how many bytes it lacks). An ASCII file may hold several solids
//! (`solid NAME … endsolid`); each is returned with its name, so that a case
//! can tag its boundary parts by solid.

use std::io::Cursor;
use std::path::Path;

use crate::error::{Error, Result};

/// One solid of an STL file.
#[derive(Clone, Debug, PartialEq)]
pub struct StlSolid {
    /// The name after `solid` in an ASCII file; empty in a binary one.
    pub name: String,
    /// Corners of each triangle, in file order.
    pub triangles: Vec<[[f64; 3]; 3]>,
}

/// Reads the solids of the STL file at `path`. Errors are [`Error::Io`]
/// naming the file and the reason.
pub fn read_stl(path: &Path) -> Result<Vec<StlSolid>> {
    let fail = |reason: String| Error::Io {
        path: path.display().to_string(),
        reason,
    };
    let bytes = std::fs::read(path).map_err(|e| fail(e.to_string()))?;
    let solids = parse_stl(&bytes).map_err(fail)?;
    if solids.iter().all(|s| s.triangles.is_empty()) {
        return Err(fail("the file holds no triangles".into()));
    }
    Ok(solids)
}

/// Writes `triangles` as a binary STL (single precision, as the format is).
pub fn write_binary_stl(path: &Path, triangles: &[[[f64; 3]; 3]]) -> Result<()> {
    let fail = |e: std::io::Error| Error::Io {
        path: path.display().to_string(),
        reason: e.to_string(),
    };
    let mesh: Vec<stl_io::Triangle> = triangles
        .iter()
        .map(|t| {
            let v = t.map(|p| stl_io::Vertex::new(p.map(|c| c as f32)));
            let n = crate::spatial::vec3::normalize(crate::spatial::vec3::cross(
                crate::spatial::vec3::sub(t[1], t[0]),
                crate::spatial::vec3::sub(t[2], t[0]),
            ));
            stl_io::Triangle {
                normal: stl_io::Normal::new(n.map(|c| c as f32)),
                vertices: v,
            }
        })
        .collect();
    let mut file = std::io::BufWriter::new(std::fs::File::create(path).map_err(fail)?);
    stl_io::write_stl(&mut file, mesh.iter()).map_err(fail)
}

/// [`read_stl`] on the bytes of a file; the error is the reason.
pub fn parse_stl(bytes: &[u8]) -> std::result::Result<Vec<StlSolid>, String> {
    if bytes.is_empty() {
        return Err("the file is empty".into());
    }
    if let Some(count) = binary_count(bytes) {
        let mut patched = bytes.to_vec();
        // The header is free text; blank it so that no reader takes it for ASCII.
        patched[..80].fill(b' ');
        let triangles = read_triangles(&patched)
            .map_err(|e| format!("binary STL with {count} triangles: {e}"))?;
        return Ok(vec![StlSolid {
            name: String::new(),
            triangles,
        }]);
    }
    let looks_ascii = bytes
        .iter()
        .skip_while(|b| b.is_ascii_whitespace())
        .take(5)
        .eq(b"solid".iter());
    let not_ascii = match (looks_ascii, std::str::from_utf8(bytes)) {
        (true, Ok(text)) => return ascii_solids(text),
        (true, Err(_)) => "begins with `solid` but is not text",
        (false, _) => "no `solid` at the start",
    };
    Err(if bytes.len() < 84 {
        format!(
            "not an STL file: {} bytes, too short for a binary STL (84 at least), and not ASCII ({not_ascii})",
            bytes.len()
        )
    } else {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
        format!(
            "not an STL file: not ASCII ({not_ascii}), and not binary: its header announces {n} triangles ({} bytes) but the file has {} bytes (truncated?)",
            84 + 50 * n,
            bytes.len()
        )
    })
}

/// The triangle count of a binary STL whose length matches its header.
fn binary_count(bytes: &[u8]) -> Option<u64> {
    if bytes.len() < 84 {
        return None;
    }
    let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
    (84 + 50 * n == bytes.len() as u64).then_some(n)
}

/// The `solid … endsolid` blocks of an ASCII file, each read by `stl_io`.
fn ascii_solids(text: &str) -> std::result::Result<Vec<StlSolid>, String> {
    let mut solids = Vec::new();
    let mut lines = text.lines().enumerate().peekable();
    while let Some((start, line)) = lines.next() {
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        let Some(name) = trimmed.strip_prefix("solid") else {
            return Err(format!(
                "line {}: expected `solid`, found `{trimmed}`",
                start + 1
            ));
        };
        let name = name.trim().to_string();
        // stl_io wants `solid ` with a name; give it a neutral one.
        let mut block = String::from("solid s\n");
        let mut closed = false;
        for (_, l) in lines.by_ref() {
            block.push_str(l);
            block.push('\n');
            if l.trim_start().starts_with("endsolid") {
                closed = true;
                break;
            }
        }
        if !closed {
            return Err(format!(
                "the solid `{name}` opened on line {} has no `endsolid`",
                start + 1
            ));
        }
        let triangles = read_triangles(block.as_bytes())
            .map_err(|e| format!("the solid `{name}` opened on line {}: {e}", start + 1))?;
        solids.push(StlSolid { name, triangles });
    }
    Ok(solids)
}

/// The triangles `stl_io` reads from `bytes`, checked to be finite.
fn read_triangles(bytes: &[u8]) -> std::result::Result<Vec<[[f64; 3]; 3]>, String> {
    let mut cursor = Cursor::new(bytes);
    let reader = stl_io::create_stl_reader(&mut cursor).map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    for (i, t) in reader.enumerate() {
        let t = t.map_err(|e| format!("triangle {}: {e}", i + 1))?;
        let corners = t.vertices.map(|v| v.0.map(f64::from));
        if corners.iter().flatten().any(|c| !c.is_finite()) {
            return Err(format!("triangle {} has a non-finite coordinate", i + 1));
        }
        out.push(corners);
    }
    Ok(out)
}
