//! Splits the text of an expression into tokens, each with its byte position:
//! numbers, names, the symbols `+ - * / ^ ( ) ,` and a final end marker.

use super::expression_error;
use crate::error::Result;

/// What a token is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Kind {
    /// A finite number literal.
    Number(f64),
    /// A name: variable, constant or function.
    Name,
    Symbol(u8),
    End,
}

/// A token and where it sits in the source.
#[derive(Clone, Copy, Debug)]
pub(super) struct Token<'a> {
    pub kind: Kind,
    pub text: &'a str,
    pub pos: usize,
}

impl Token<'_> {
    /// The token as error messages quote it.
    pub(super) fn describe(&self) -> String {
        match self.kind {
            Kind::End => "end".into(),
            _ => format!("'{}'", self.text),
        }
    }
}

const SYMBOLS: &[u8] = b"+-*/^(),";

/// The tokens of `src`, ending with [`Kind::End`] at `src.len()`.
pub(super) fn tokenize(src: &str) -> Result<Vec<Token<'_>>> {
    let mut tokens = Vec::new();
    let mut pos = 0;
    while let Some(c) = src[pos..].chars().next() {
        if c.is_whitespace() {
            pos += c.len_utf8();
            continue;
        }
        let token = token_at(src, pos, c)?;
        pos += token.text.len();
        tokens.push(token);
    }
    tokens.push(Token {
        kind: Kind::End,
        text: "",
        pos,
    });
    Ok(tokens)
}

/// The token starting with character `c` at byte `pos`.
fn token_at(src: &str, pos: usize, c: char) -> Result<Token<'_>> {
    let rest = &src[pos..];
    let token = |kind, len: usize| Token {
        kind,
        text: &rest[..len],
        pos,
    };
    let starts_number =
        c.is_ascii_digit() || (c == '.' && rest.as_bytes().get(1).is_some_and(u8::is_ascii_digit));
    if starts_number {
        let text = &rest[..number_len(rest.as_bytes())];
        Ok(token(Kind::Number(number(src, pos, text)?), text.len()))
    } else if c.is_ascii_alphabetic() || c == '_' {
        let len = rest
            .find(|ch: char| !(ch.is_ascii_alphanumeric() || ch == '_'))
            .unwrap_or(rest.len());
        Ok(token(Kind::Name, len))
    } else if c.is_ascii() && SYMBOLS.contains(&(c as u8)) {
        Ok(token(Kind::Symbol(c as u8), 1))
    } else {
        Err(expression_error(
            src,
            pos,
            format!("unexpected character '{c}'"),
        ))
    }
}

/// Length of the literal at the start of `s`: digits, an optional fraction
/// and an optional exponent (`e`/`E`, optional sign, at least one digit).
fn number_len(s: &[u8]) -> usize {
    let digits = |from: usize| s[from..].iter().take_while(|b| b.is_ascii_digit()).count();
    let mut n = digits(0);
    if s.get(n) == Some(&b'.') {
        n += 1 + digits(n + 1);
    }
    if matches!(s.get(n), Some(b'e' | b'E')) {
        let sign = usize::from(matches!(s.get(n + 1), Some(b'+' | b'-')));
        let exponent = digits(n + 1 + sign);
        if exponent > 0 {
            n += 1 + sign + exponent;
        }
    }
    n
}

/// The value of the literal `text` at `pos`, which must be finite.
fn number(src: &str, pos: usize, text: &str) -> Result<f64> {
    match text.parse::<f64>() {
        Ok(value) if value.is_finite() => Ok(value),
        Ok(_) => Err(expression_error(
            src,
            pos,
            format!("number '{text}' is too large to be finite"),
        )),
        Err(e) => Err(expression_error(
            src,
            pos,
            format!("malformed number '{text}': {e}"),
        )),
    }
}
