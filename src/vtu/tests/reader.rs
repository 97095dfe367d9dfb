//! A minimal reader for the writer's own output, for the tests, written
//! apart from the module's public reader: a tag-balance check for
//! well-formedness, attribute parsing, DataArray extraction and decoding
//! (inline base64 with the `UInt64` byte-count header checked, ASCII, or the
//! appended section, raw or zlib-compressed blocks inflated with flate2)
//! into bit-comparable values.

use std::collections::HashMap;
use std::io::Read as _;

/// A file as written: its XML (with an appended section's bytes cut out,
/// its `_` marker kept) and the appended section's bytes.
pub(super) struct File {
    pub(super) xml: String,
    appended: Vec<u8>,
}

/// Splits a written file into its XML and its appended bytes; panics
/// unless the XML is UTF-8 and the section is `_`, the data, a newline, two
/// spaces, and `</AppendedData>`.
pub(super) fn parse(bytes: &[u8]) -> File {
    let open = b"<AppendedData encoding=\"raw\">\n   _";
    let close = b"\n  </AppendedData>\n</VTKFile>\n";
    let Some(at) = bytes.windows(open.len()).position(|w| w == open) else {
        let xml = String::from_utf8(bytes.to_vec()).expect("a file without appended data is text");
        return File {
            xml,
            appended: Vec::new(),
        };
    };
    let start = at + open.len();
    assert!(bytes.ends_with(close), "the appended section is not closed");
    let end = bytes.len() - close.len();
    let mut xml = String::from_utf8(bytes[..start].to_vec()).expect("the XML is text");
    xml.push_str(std::str::from_utf8(&bytes[end..]).unwrap());
    File {
        xml,
        appended: bytes[start..end].to_vec(),
    }
}

/// Panics unless every tag is closed in order, there is one root element,
/// no tag or attribute value holds a raw `<`, and text holds no raw `<`.
pub(super) fn assert_well_formed(text: &str) {
    let mut stack: Vec<String> = Vec::new();
    let mut roots = 0;
    let mut rest = text;
    while let Some(open) = rest.find('<') {
        let (inside, after) = split_tag(&rest[open + 1..]);
        rest = after;
        if let Some(pi) = inside.strip_prefix('?') {
            assert!(
                pi.ends_with('?') && stack.is_empty() && roots == 0,
                "<{inside}>"
            );
        } else if let Some(name) = inside.strip_prefix('/') {
            assert_eq!(
                stack.pop().as_deref(),
                Some(name.trim()),
                "unbalanced </{name}>"
            );
        } else {
            roots += usize::from(stack.is_empty());
            let name = inside
                .split_whitespace()
                .next()
                .unwrap()
                .trim_end_matches('/');
            if !inside.ends_with('/') {
                stack.push(name.to_string());
            }
        }
    }
    assert!(stack.is_empty(), "unclosed {stack:?}");
    assert_eq!(roots, 1);
}

/// Splits `s` (just after a `<`) at the tag's closing `>`, outside quotes.
pub(super) fn split_tag(s: &str) -> (&str, &str) {
    let mut quoted = false;
    for (i, c) in s.char_indices() {
        match c {
            '"' => quoted = !quoted,
            '<' => panic!("raw '<' inside a tag: {}", &s[..i]),
            '>' if !quoted => return (&s[..i], &s[i + 1..]),
            _ => {}
        }
    }
    panic!("tag never closed: {s}");
}

/// `key="value"` attributes of a start tag's inside, values unescaped.
pub(super) fn attributes(tag: &str) -> HashMap<String, String> {
    let mut out = HashMap::new();
    let mut rest = tag.split_once(char::is_whitespace).map_or("", |(_, r)| r);
    while let Some((key, after)) = rest.split_once("=\"") {
        let (value, after) = after.split_once('"').unwrap();
        out.insert(key.trim().to_string(), unescape(value));
        rest = after;
    }
    out
}

fn unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

/// Values read back from one DataArray.
#[derive(Debug, PartialEq)]
pub(super) enum Read {
    F64(Vec<u64>),
    I64(Vec<i64>),
    I32(Vec<i32>),
    U8(Vec<u8>),
}

/// Every DataArray of `file`: its attributes and decoded values. Appended
/// arrays must tile the appended section, in order, with no gap.
pub(super) fn data_arrays(file: &File) -> Vec<(HashMap<String, String>, Read)> {
    let root = attributes(split_tag(&file.xml[file.xml.find("<VTKFile").unwrap() + 1..]).0);
    let zlib = match root.get("compressor").map(String::as_str) {
        Some("vtkZLibDataCompressor") => true,
        None => false,
        Some(other) => panic!("compressor {other}"),
    };
    let mut out = Vec::new();
    let mut next_offset = 0;
    for piece in file.xml.split("<DataArray").skip(1) {
        let (tag, after) = split_tag(piece);
        let attrs = attributes(&format!("DataArray{}", tag.trim_end_matches('/')));
        let ty = attrs["type"].as_str();
        let values = match attrs["format"].as_str() {
            "appended" => {
                assert!(tag.ends_with('/'), "an appended DataArray has no body");
                let offset: usize = attrs["offset"].parse().unwrap();
                assert_eq!(offset, next_offset, "{}: offset", attrs["Name"]);
                let (raw, len) = if zlib {
                    inflate(&file.appended[offset..])
                } else {
                    let n = u64::from_le_bytes(file.appended[offset..][..8].try_into().unwrap());
                    let len = 8 + n as usize;
                    (file.appended[offset..offset + len].to_vec(), len)
                };
                next_offset = offset + len;
                decode_binary(ty, &raw)
            }
            format => {
                let body = after[..after.find("</DataArray>").unwrap()].trim();
                match format {
                    "binary" => decode_binary(ty, &base64_decode(body)),
                    "ascii" => decode_ascii(ty, body),
                    other => panic!("format {other}"),
                }
            }
        };
        out.push((attrs, values));
    }
    assert_eq!(
        next_offset,
        file.appended.len(),
        "the appended section's length"
    );
    out
}

/// Inflates the zlib-compressed array at the start of `data` (header:
/// blocks, block size, partial last block size, compressed sizes); returns
/// the byte count and the values' bytes, as raw data has them, and the
/// array's length in the section.
fn inflate(data: &[u8]) -> (Vec<u8>, usize) {
    let word = |i: usize| u64::from_le_bytes(data[8 * i..][..8].try_into().unwrap()) as usize;
    let (blocks, size, last) = (word(0), word(1), word(2));
    let mut at = 8 * (3 + blocks);
    let mut values = Vec::new();
    for b in 0..blocks {
        let before = values.len();
        let compressed = &data[at..at + word(3 + b)];
        flate2::read::ZlibDecoder::new(compressed)
            .read_to_end(&mut values)
            .unwrap();
        let expected = if b + 1 == blocks && last > 0 {
            last
        } else {
            size
        };
        assert_eq!(values.len() - before, expected, "block {b}");
        at += compressed.len();
    }
    let mut raw = (values.len() as u64).to_le_bytes().to_vec();
    raw.extend(values);
    (raw, at)
}

fn decode_binary(ty: &str, raw: &[u8]) -> Read {
    let (header, data) = raw.split_at(8);
    let count = u64::from_le_bytes(header.try_into().unwrap());
    assert_eq!(count as usize, data.len(), "header byte count");
    let words = |n: usize| data.chunks_exact(n).collect::<Vec<_>>();
    match ty {
        "Float64" => Read::F64(
            words(8)
                .iter()
                .map(|w| u64::from_le_bytes((*w).try_into().unwrap()))
                .collect(),
        ),
        "Int64" => Read::I64(
            words(8)
                .iter()
                .map(|w| i64::from_le_bytes((*w).try_into().unwrap()))
                .collect(),
        ),
        "Int32" => Read::I32(
            words(4)
                .iter()
                .map(|w| i32::from_le_bytes((*w).try_into().unwrap()))
                .collect(),
        ),
        "UInt8" => Read::U8(data.to_vec()),
        other => panic!("type {other}"),
    }
}

fn decode_ascii(ty: &str, body: &str) -> Read {
    let words = body.split_whitespace();
    match ty {
        "Float64" => Read::F64(words.map(|w| w.parse::<f64>().unwrap().to_bits()).collect()),
        "Int64" => Read::I64(words.map(|w| w.parse().unwrap()).collect()),
        "Int32" => Read::I32(words.map(|w| w.parse().unwrap()).collect()),
        "UInt8" => Read::U8(words.map(|w| w.parse().unwrap()).collect()),
        other => panic!("type {other}"),
    }
}

/// Standard base64 decoding; panics on anything malformed.
fn base64_decode(text: &str) -> Vec<u8> {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    assert_eq!(text.len() % 4, 0, "base64 length");
    let mut out = Vec::new();
    for quad in text.as_bytes().chunks(4) {
        let pad = quad.iter().rev().take_while(|&&c| c == b'=').count();
        let mut n = 0u32;
        for &c in &quad[..4 - pad] {
            let v = ALPHABET.iter().position(|&a| a == c).expect("base64 char");
            n = (n << 6) | v as u32;
        }
        n <<= 6 * pad as u32;
        out.extend_from_slice(&n.to_be_bytes()[1..4 - pad]);
    }
    out
}
