//! Reading back the `.vtu` and `.vtp` files that this module writes, in
//! every [`super::VtuEncoding`]: [`read`] returns their DataArrays, values
//! bit for bit as written. It reads the layout our writers produce (one
//! piece, little endian, `UInt64` headers), not every VTK XML file; tests and
//! scripts use it to check what a run wrote.

use std::collections::HashMap;
use std::io::Read as _;
use std::path::Path;

use flate2::read::ZlibDecoder;

use super::{DataArray, DataValues};
use crate::error::{Error, Result};

/// Every DataArray of the `.vtu` or `.vtp` file `path`, in the file's order:
/// the point data, the cell data, `Points`, then the cells' arrays
/// (`connectivity` and `offsets` as `Int64`, and a `.vtu`'s `types` as
/// `UInt8`).
///
/// Fails with [`Error::Io`] when the file cannot be read or is not laid out
/// as this module writes it (a DataArray's header disagrees with its data, a
/// compressed block does not inflate, an unknown type or format).
pub fn read(path: &Path) -> Result<Vec<DataArray>> {
    let fail = |reason: String| Error::Io {
        path: path.display().to_string(),
        reason,
    };
    let bytes = std::fs::read(path).map_err(|e| fail(e.to_string()))?;
    read_bytes(&bytes).map_err(fail)
}

type Parsed<T> = std::result::Result<T, String>;

fn read_bytes(bytes: &[u8]) -> Parsed<Vec<DataArray>> {
    // The XML: everything before the appended section's `_` marker.
    let (xml, appended) = match find(bytes, b"<AppendedData") {
        Some(at) => {
            let marker = bytes[at..]
                .iter()
                .position(|&b| b == b'_')
                .map(|k| at + k)
                .ok_or("the appended section has no '_' marker")?;
            (&bytes[..marker], &bytes[marker + 1..])
        }
        None => (bytes, &bytes[..0]),
    };
    let xml = std::str::from_utf8(xml).map_err(|e| format!("the XML is not UTF-8: {e}"))?;
    let root = xml
        .split_once("<VTKFile")
        .map(|(_, rest)| attributes(rest.split('>').next().unwrap_or("")))
        .ok_or("no VTKFile element")?;
    if root.get("byte_order").is_some_and(|o| o != "LittleEndian") {
        return Err("only little-endian files are read".into());
    }
    if root.get("header_type").is_some_and(|h| h != "UInt64") {
        return Err("only UInt64 headers are read".into());
    }
    let zlib = match root.get("compressor").map(String::as_str) {
        None => false,
        Some("vtkZLibDataCompressor") => true,
        Some(other) => return Err(format!("unknown compressor {other}")),
    };
    let mut out = Vec::new();
    for piece in xml.split("<DataArray").skip(1) {
        let (tag, after) = piece
            .split_once('>')
            .ok_or("a DataArray tag is not closed")?;
        let attrs = attributes(tag);
        let get = |key: &str| {
            attrs
                .get(key)
                .map(String::as_str)
                .ok_or(format!("a DataArray has no {key}"))
        };
        let name = get("Name")?;
        let components = get("NumberOfComponents")?
            .parse()
            .map_err(|e| format!("'{name}': NumberOfComponents: {e}"))?;
        let body = || after.split("</DataArray>").next().unwrap_or("").trim();
        let ty = get("type")?;
        let values = match get("format")? {
            "ascii" => ascii_values(ty, body()),
            "binary" => base64_decode(body()).and_then(|raw| Ok(counted(&raw, 0)?.to_vec())),
            "appended" => {
                let offset: usize = get("offset")?
                    .parse()
                    .map_err(|e| format!("'{name}': offset: {e}"))?;
                if zlib {
                    inflate(appended, offset)
                } else {
                    counted(appended, offset).map(<[u8]>::to_vec)
                }
            }
            other => Err(format!("unknown format {other}")),
        }
        .and_then(|raw| le_values(ty, raw))
        .map_err(|e| format!("'{name}': {e}"))?;
        out.push(DataArray {
            name: name.to_string(),
            components,
            values,
        });
    }
    Ok(out)
}

/// The first position of `needle` in `haystack`.
fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

/// `n` bytes of `data` from `at`.
fn take(data: &[u8], at: usize, n: usize) -> Parsed<&[u8]> {
    at.checked_add(n)
        .and_then(|end| data.get(at..end))
        .ok_or_else(|| format!("{n} bytes at {at} run past the data ({} bytes)", data.len()))
}

/// The `UInt64` little-endian word at `at`.
fn word(data: &[u8], at: usize) -> Parsed<usize> {
    let w = take(data, at, 8)?;
    Ok(u64::from_le_bytes(w.try_into().expect("8 bytes")) as usize)
}

/// The bytes after the byte count at `at` (raw data).
fn counted(data: &[u8], at: usize) -> Parsed<&[u8]> {
    take(data, at + 8, word(data, at)?)
}

/// The bytes of the zlib-compressed array at `at`: its header, then its
/// blocks, each inflated to the header's uncompressed size.
fn inflate(data: &[u8], at: usize) -> Parsed<Vec<u8>> {
    let (blocks, size, last) = (word(data, at)?, word(data, at + 8)?, word(data, at + 16)?);
    let mut start = at + 24 + 8 * blocks;
    let mut out = Vec::new();
    for b in 0..blocks {
        let compressed = take(data, start, word(data, at + 24 + 8 * b)?)?;
        start += compressed.len();
        let expected = if b + 1 == blocks && last > 0 {
            last
        } else {
            size
        };
        let before = out.len();
        ZlibDecoder::new(compressed)
            .read_to_end(&mut out)
            .map_err(|e| format!("block {b}: {e}"))?;
        if out.len() - before != expected {
            return Err(format!(
                "block {b} inflates to {} bytes, its header says {expected}",
                out.len() - before
            ));
        }
    }
    Ok(out)
}

/// Values of VTK type `ty` from their little-endian bytes.
fn le_values(ty: &str, raw: Vec<u8>) -> Parsed<DataValues> {
    fn words<const N: usize, T>(raw: &[u8], f: impl Fn([u8; N]) -> T) -> Parsed<Vec<T>> {
        if !raw.len().is_multiple_of(N) {
            return Err(format!(
                "{} bytes is not a whole number of values",
                raw.len()
            ));
        }
        Ok(raw
            .chunks_exact(N)
            .map(|w| f(w.try_into().expect("N bytes")))
            .collect())
    }
    Ok(match ty {
        "Float64" => DataValues::F64(words(&raw, f64::from_le_bytes)?),
        "Int64" => DataValues::I64(words(&raw, i64::from_le_bytes)?),
        "Int32" => DataValues::I32(words(&raw, i32::from_le_bytes)?),
        "UInt8" => DataValues::U8(raw),
        other => return Err(format!("unknown type {other}")),
    })
}

/// Values of VTK type `ty` from whitespace-separated text, as their
/// little-endian bytes.
fn ascii_values(ty: &str, body: &str) -> Parsed<Vec<u8>> {
    fn parse<T: std::str::FromStr, const N: usize>(
        body: &str,
        bytes: impl Fn(T) -> [u8; N],
    ) -> Parsed<Vec<u8>> {
        let mut out = Vec::new();
        for w in body.split_whitespace() {
            let v = w
                .parse::<T>()
                .map_err(|_| format!("'{w}' is not a number"))?;
            out.extend_from_slice(&bytes(v));
        }
        Ok(out)
    }
    match ty {
        "Float64" => parse(body, f64::to_le_bytes),
        "Int64" => parse(body, i64::to_le_bytes),
        "Int32" => parse(body, i32::to_le_bytes),
        "UInt8" => parse(body, u8::to_le_bytes),
        other => Err(format!("unknown type {other}")),
    }
}

/// `key="value"` attributes of a start tag's inside, values unescaped.
fn attributes(tag: &str) -> HashMap<String, String> {
    let mut out = HashMap::new();
    let mut rest = tag;
    while let Some((key, after)) = rest.split_once("=\"") {
        let Some((value, after)) = after.split_once('"') else {
            break;
        };
        let key = key.rsplit(char::is_whitespace).next().unwrap_or(key);
        let value = value
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&apos;", "'")
            .replace("&amp;", "&");
        out.insert(key.to_string(), value);
        rest = after;
    }
    out
}

/// Standard base64 (with `=` padding).
fn base64_decode(text: &str) -> Parsed<Vec<u8>> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => Ok(c - b'A'),
        b'a'..=b'z' => Ok(c - b'a' + 26),
        b'0'..=b'9' => Ok(c - b'0' + 52),
        b'+' => Ok(62),
        b'/' => Ok(63),
        _ => Err(format!("'{}' is not base64", c as char)),
    };
    let digits = text
        .bytes()
        .filter(|&c| c != b'=')
        .map(value)
        .collect::<Parsed<Vec<u8>>>()?;
    let mut out = Vec::with_capacity(digits.len() * 3 / 4);
    for chunk in digits.chunks(4) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |n, (k, &d)| n | u32::from(d) << (18 - 6 * k));
        for k in 0..chunk.len().saturating_sub(1) {
            out.push((n >> (16 - 8 * k)) as u8);
        }
    }
    Ok(out)
}
