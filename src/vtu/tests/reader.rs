//! A minimal reader for the writer's own output, for the tests: a
//! tag-balance check for well-formedness, attribute parsing, DataArray
//! extraction and decoding (base64 with the `UInt64` byte-count header
//! checked, or ASCII) into bit-comparable values.

use std::collections::HashMap;

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

/// Every DataArray of the document: its attributes and decoded values.
pub(super) fn data_arrays(text: &str) -> Vec<(HashMap<String, String>, Read)> {
    let mut out = Vec::new();
    for piece in text.split("<DataArray").skip(1) {
        let (tag, after) = split_tag(piece);
        let body = &after[..after.find("</DataArray>").unwrap()];
        let attrs = attributes(&format!("DataArray{tag}"));
        let values = decode(&attrs, body.trim());
        out.push((attrs, values));
    }
    out
}

fn decode(attrs: &HashMap<String, String>, body: &str) -> Read {
    let ty = attrs["type"].as_str();
    match attrs["format"].as_str() {
        "binary" => decode_binary(ty, &base64_decode(body)),
        "ascii" => decode_ascii(ty, body),
        other => panic!("format {other}"),
    }
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
