//! A strict reader of NRRD images (`.nrrd`, one file with the header and
//! the data; or a detached header `.nhdr` whose `data file` names one raw
//! or gzip file beside it): three dimensions; samples `int8`, `uint8`, `int16`, `uint16`,
//! `int32`, `uint32`, `float` or `double`; `raw`, `gzip` or `ascii`
//! encoding; placed by `space directions` (or `spacings`) and `space
//! origin`. Anything else is refused with the reason: a list of data
//! files, skips, unknown fields, a size that does not match the data.

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};

/// A 3D image as read: the samples (x fastest) and the placement the
/// header gives, if any.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub size: [usize; 3],
    pub values: Vec<f64>,
    /// The distance between samples along each axis.
    pub spacing: Option<[f64; 3]>,
    /// The unit direction of each axis (from `space directions`).
    pub axes: Option<[[f64; 3]; 3]>,
    /// The position of the first sample.
    pub origin: Option<[f64; 3]>,
}

/// Fields that describe the image but do not change how it is read.
const INFORMATIVE: &[&str] = &[
    "content",
    "kinds",
    "labels",
    "units",
    "space units",
    "centers",
    "centerings",
    "thicknesses",
    "axis mins",
    "axismins",
    "axis maxs",
    "axismaxs",
    "min",
    "max",
    "old min",
    "oldmin",
    "old max",
    "oldmax",
    "measurement frame",
    "space",
    "space dimension",
    "sample units",
    "sampleunits",
    "number",
];

/// The sample types: (names, bytes, signed integer, float).
fn sample_type(name: &str) -> Option<(usize, Kind)> {
    Some(match name {
        "signed char" | "int8" | "int8_t" => (1, Kind::Int),
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => (1, Kind::Uint),
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            (2, Kind::Int)
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => {
            (2, Kind::Uint)
        }
        "int" | "signed int" | "int32" | "int32_t" => (4, Kind::Int),
        "uint" | "unsigned int" | "uint32" | "uint32_t" => (4, Kind::Uint),
        "float" => (4, Kind::Float),
        "double" => (8, Kind::Float),
        _ => return None,
    })
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Int,
    Uint,
    Float,
}

/// Reads the NRRD file at `path`.
pub fn read_nrrd(path: &Path) -> Result<Image> {
    let bytes = std::fs::read(path).map_err(|e| Error::Io {
        path: path.display().to_string(),
        reason: format!("cannot read the image: {e}"),
    })?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let detached = |name: &str| {
        std::fs::read(dir.join(name)).map_err(|e| {
            format!(
                "cannot read the data file {}: {e}",
                dir.join(name).display()
            )
        })
    };
    parse_nrrd_with(&bytes, &detached).map_err(|reason| Error::Image {
        path: path.display().to_string(),
        reason,
    })
}

/// Parses the bytes of a NRRD file with its data in it; the error is the
/// reason.
pub fn parse_nrrd(bytes: &[u8]) -> std::result::Result<Image, String> {
    parse_nrrd_with(bytes, &|_| {
        Err("detached data ('data file') needs the header's folder: read the file".into())
    })
}

/// Parses a NRRD header and its data: after the header, or in the file
/// `data file` names, read by `detached`.
fn parse_nrrd_with(
    bytes: &[u8],
    detached: &dyn Fn(&str) -> std::result::Result<Vec<u8>, String>,
) -> std::result::Result<Image, String> {
    if !bytes.starts_with(b"NRRD000") || bytes.len() < 8 || !(b'1'..=b'5').contains(&bytes[7]) {
        return Err("not a NRRD file (the first line must be NRRD0001 to NRRD0005)".into());
    }
    // The header ends at the first empty line.
    let mut pos = 0;
    let mut lines = Vec::new();
    loop {
        let Some(end) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err("the header does not end (no empty line before the data)".into());
        };
        let line = std::str::from_utf8(&bytes[pos..pos + end])
            .map_err(|_| format!("header line {} is not text", lines.len() + 1))?
            .trim_end_matches('\r');
        pos += end + 1;
        if line.is_empty() {
            break;
        }
        lines.push(line.to_string());
    }
    let data = &bytes[pos..];
    let mut fields: Vec<(String, String)> = Vec::new();
    for line in &lines[1..] {
        if line.starts_with('#') || line.contains(":=") {
            continue;
        }
        let Some((key, value)) = line.split_once(": ") else {
            return Err(format!("header line '{line}' is not 'field: value'"));
        };
        let key = key.trim().to_ascii_lowercase();
        if fields.iter().any(|(k, _)| *k == key) {
            return Err(format!("the field '{key}' is given twice"));
        }
        fields.push((key, value.trim().to_string()));
    }
    let get = |k: &str| fields.iter().find(|(f, _)| f == k).map(|(_, v)| v.as_str());
    for (k, _) in &fields {
        let known = [
            "type",
            "dimension",
            "sizes",
            "encoding",
            "endian",
            "space directions",
            "spacings",
            "space origin",
            "byte skip",
            "byteskip",
            "line skip",
            "lineskip",
            "data file",
            "datafile",
        ];
        if !known.contains(&k.as_str()) && !INFORMATIVE.contains(&k.as_str()) {
            return Err(format!("unknown field '{k}'"));
        }
    }
    let external;
    let data = match get("data file").or(get("datafile")) {
        Some(name) if name.contains(char::is_whitespace) || name == "LIST" => {
            return Err(format!(
                "'data file: {name}': only one data file is read (no list or pattern)"
            ))
        }
        Some(name) => {
            if !data.is_empty() {
                return Err(format!("'data file: {name}' and data after the header"));
            }
            external = detached(name)?;
            &external[..]
        }
        None => data,
    };
    for skip in ["byte skip", "byteskip", "line skip", "lineskip"] {
        if let Some(v) = get(skip) {
            if v != "0" {
                return Err(format!("'{skip}: {v}' is not supported (only 0)"));
            }
        }
    }
    let need = |k: &str| get(k).ok_or_else(|| format!("the header has no '{k}' field"));
    let type_name = need("type")?;
    let (width, kind) =
        sample_type(type_name).ok_or_else(|| format!("unsupported sample type '{type_name}'"))?;
    let dim = need("dimension")?;
    if dim != "3" {
        return Err(format!("dimension {dim}: only 3D images are read"));
    }
    let sizes: Vec<usize> = need("sizes")?
        .split_whitespace()
        .map(|s| s.parse::<usize>().ok().filter(|&n| n > 0))
        .collect::<Option<Vec<_>>>()
        .filter(|s| s.len() == 3)
        .ok_or_else(|| {
            format!(
                "'sizes: {}' must be 3 positive integers",
                get("sizes").unwrap_or("")
            )
        })?;
    let size = [sizes[0], sizes[1], sizes[2]];
    let count = size[0]
        .checked_mul(size[1])
        .and_then(|n| n.checked_mul(size[2]))
        .filter(|n| n.checked_mul(8).is_some())
        .ok_or_else(|| format!("sizes {size:?} are too large"))?;
    let big_endian = match get("endian") {
        Some("little") => false,
        Some("big") => true,
        Some(e) => return Err(format!("unknown endian '{e}' (little or big)")),
        None if width > 1 && !matches!(get("encoding"), Some("ascii" | "text" | "txt")) => {
            return Err(format!(
                "the header has no 'endian' field, needed for '{type_name}'"
            ))
        }
        None => false,
    };
    let values = match need("encoding")? {
        "raw" => decode(data, count, width, kind, big_endian)?,
        "gzip" | "gz" => {
            // Every member of the stream (trailing bytes are not gzip: refused).
            let expected = count * width;
            let mut out = Vec::new();
            flate2::read::MultiGzDecoder::new(data)
                .take(expected as u64 + 1)
                .read_to_end(&mut out)
                .map_err(|e| format!("the gzip data does not decompress: {e}"))?;
            decode(&out, count, width, kind, big_endian)?
        }
        "ascii" | "text" | "txt" => {
            let text = std::str::from_utf8(data).map_err(|_| "the ascii data is not text")?;
            let v: Vec<f64> = text
                .split_whitespace()
                .map(|t| {
                    t.parse::<f64>()
                        .map_err(|_| format!("'{t}' is not a number"))
                })
                .collect::<std::result::Result<_, _>>()?;
            if v.len() != count {
                return Err(format!("{} values for sizes {size:?} ({count})", v.len()));
            }
            v
        }
        e => return Err(format!("unsupported encoding '{e}' (raw, gzip or ascii)")),
    };
    if let Some(v) = values.iter().find(|v| !v.is_finite()) {
        return Err(format!("the data holds {v}, which is not finite"));
    }
    let (spacing, axes) = match (get("space directions"), get("spacings")) {
        (Some(_), Some(_)) => return Err("'space directions' and 'spacings' are both given".into()),
        (Some(d), None) => {
            let vs = vectors(d).map_err(|r| format!("'space directions: {d}': {r}"))?;
            if vs.len() != 3 {
                return Err(format!("'space directions: {d}' needs 3 vectors"));
            }
            let mut spacing = [0.0; 3];
            let mut axes = [[0.0; 3]; 3];
            for a in 0..3 {
                let n = vs[a].iter().map(|c| c * c).sum::<f64>().sqrt();
                if !(n > 0.0 && n.is_finite()) {
                    return Err(format!("'space directions: {d}': axis {a} has length {n}"));
                }
                spacing[a] = n;
                axes[a] = vs[a].map(|c| c / n);
            }
            (Some(spacing), Some(axes))
        }
        (None, Some(s)) => {
            let v: Vec<f64> = s
                .split_whitespace()
                .map(|t| t.parse::<f64>().ok().filter(|x| x.is_finite() && *x > 0.0))
                .collect::<Option<_>>()
                .filter(|v: &Vec<f64>| v.len() == 3)
                .ok_or_else(|| format!("'spacings: {s}' must be 3 positive numbers"))?;
            (Some([v[0], v[1], v[2]]), None)
        }
        (None, None) => (None, None),
    };
    let origin = match get("space origin") {
        Some(o) => {
            let vs = vectors(o).map_err(|r| format!("'space origin: {o}': {r}"))?;
            if vs.len() != 1 {
                return Err(format!("'space origin: {o}' needs one vector"));
            }
            Some(vs[0])
        }
        None => None,
    };
    Ok(Image {
        size,
        values,
        spacing,
        axes,
        origin,
    })
}

/// The samples of `data`, exactly `count` of `width` bytes.
fn decode(
    data: &[u8],
    count: usize,
    width: usize,
    kind: Kind,
    big: bool,
) -> std::result::Result<Vec<f64>, String> {
    if data.len() != count * width {
        return Err(format!(
            "the data holds {} bytes, the sizes and type need {}",
            data.len(),
            count * width
        ));
    }
    Ok(data
        .chunks_exact(width)
        .map(|c| {
            let mut b = [0u8; 8];
            b[..width].copy_from_slice(c);
            if big {
                b[..width].reverse();
            }
            match (kind, width) {
                (Kind::Uint, 1) => b[0] as f64,
                (Kind::Int, 1) => b[0] as i8 as f64,
                (Kind::Uint, 2) => u16::from_le_bytes([b[0], b[1]]) as f64,
                (Kind::Int, 2) => i16::from_le_bytes([b[0], b[1]]) as f64,
                (Kind::Uint, 4) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                (Kind::Int, 4) => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                (Kind::Float, 4) => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                _ => f64::from_le_bytes(b),
            }
        })
        .collect())
}

/// Vectors written `(a,b,c) (d,e,f)`.
fn vectors(s: &str) -> std::result::Result<Vec<[f64; 3]>, String> {
    let mut out = Vec::new();
    let mut rest = s.trim();
    while !rest.is_empty() {
        if rest.starts_with("none") {
            return Err("an axis without a direction ('none') is not supported".into());
        }
        let inner = rest
            .strip_prefix('(')
            .and_then(|r| r.split_once(')'))
            .ok_or("vectors are written (x,y,z)")?;
        let v: Vec<f64> = inner
            .0
            .split(',')
            .map(|t| t.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect::<Option<_>>()
            .filter(|v: &Vec<f64>| v.len() == 3)
            .ok_or("each vector needs 3 finite numbers")?;
        out.push([v[0], v[1], v[2]]);
        rest = inner.1.trim_start();
    }
    Ok(out)
}
