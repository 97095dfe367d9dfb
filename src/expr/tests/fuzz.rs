//! Fuzz of the parser: random token soups, random grammatical expressions and
//! their byte mutations never panic, errors point inside the text, and
//! printing then parsing gives back the same tree, which evaluates
//! identically.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::Error;
use crate::expr::Expr;

const CASES: usize = 6000;

/// Pieces of the grammar, some valid, some almost valid.
const TOKENS: &[&str] = &[
    "x", "y", "z", "w", "pi", "e", "0", "1", "2.5", "1e-3", "3E2", ".5", "7.", "1e400", "1e", "+",
    "-", "*", "/", "^", "(", ")", ",", " ", "\t", "sin", "cos", "tan", "exp", "log", "sqrt", "abs",
    "sinh", "cosh", "tanh", "atan", "atan2", "min", "max", "pow", "foo", "(", ")", "x",
];

const NUMBERS: &[&str] = &[
    "0", "1", "2", "2.5", "1e-3", "3E2", ".5", "7.", "1e300", "4e-320",
];
const ATOMS: &[&str] = &["x", "y", "z", "pi", "e"];
const FUNCTIONS_1: &[&str] = &[
    "sin", "cos", "tan", "exp", "log", "sqrt", "abs", "sinh", "cosh", "tanh", "atan",
];
const FUNCTIONS_2: &[&str] = &["atan2", "min", "max", "pow"];

const POINTS: &[[f64; 3]] = &[[0.0; 3], [0.7, -1.3, 2.1], [-2.0, 0.5, -0.25]];

/// Equal values, NaN included.
fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

/// Printing `e` and parsing the text gives an equal tree with equal values,
/// and the jet's value is the plain value.
fn check_round_trip(e: &Expr) {
    let shown = e.to_string();
    let back = Expr::parse(&shown)
        .unwrap_or_else(|err| panic!("{:?} printed as {shown:?}: {err}", e.source()));
    assert_eq!(&back, e, "{:?} printed as {shown:?}", e.source());
    assert_eq!(back.to_string(), shown);
    for &x in POINTS {
        let value = e.eval(x);
        assert!(same(back.eval(x), value), "{shown} at {x:?}");
        assert!(same(e.eval_hessian(x).0, value), "{shown} at {x:?}: jet");
    }
}

/// The error is an expression error inside `src`, on a character boundary.
fn check_error(src: &str, err: Error) {
    match err {
        Error::Expression { expr, position, .. } => {
            assert_eq!(expr, src);
            let inside = position <= src.len() && src.is_char_boundary(position);
            assert!(inside, "{src:?} at {position}");
        }
        other => panic!("{src:?}: wrong error kind {other:?}"),
    }
}

/// Parses `src` and checks whichever way it goes; whether it parsed.
fn check(src: &str) -> bool {
    match Expr::parse(src) {
        Ok(e) => {
            check_round_trip(&e);
            true
        }
        Err(err) => {
            check_error(src, err);
            false
        }
    }
}

fn token_soup(rng: &mut ChaCha8Rng) -> String {
    let count = rng.gen_range(1..24);
    (0..count)
        .map(|_| {
            if rng.gen_bool(0.08) {
                char::from(rng.gen::<u8>()).to_string()
            } else {
                TOKENS.choose(rng).copied().unwrap_or_default().to_string()
            }
        })
        .collect()
}

#[test]
fn token_soups_never_panic() {
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let parsed = (0..CASES).filter(|_| check(&token_soup(&mut rng))).count();
    // Most soups are malformed; enough parse to exercise the round trip.
    assert!(parsed >= 50, "only {parsed} soups parsed");
}

/// Random expressions following the grammar, with random spacing.
struct Generator {
    rng: ChaCha8Rng,
}

impl Generator {
    fn pick(&mut self, from: &[&str]) -> String {
        from.choose(&mut self.rng)
            .copied()
            .unwrap_or_default()
            .into()
    }

    fn space(&mut self) -> String {
        self.pick(&[" ", "", "", "  ", "\t"])
    }

    fn sum(&mut self, depth: u32) -> String {
        let mut text = self.product(depth);
        while depth > 0 && self.rng.gen_bool(0.3) {
            let (op, a) = (self.pick(&["+", "-"]), self.space());
            text = format!("{text}{a}{op}{}{}", self.space(), self.product(depth - 1));
        }
        text
    }

    fn product(&mut self, depth: u32) -> String {
        let mut text = self.unary(depth);
        while depth > 0 && self.rng.gen_bool(0.3) {
            let (op, a) = (self.pick(&["*", "/"]), self.space());
            text = format!("{text}{a}{op}{}", self.unary(depth - 1));
        }
        text
    }

    fn unary(&mut self, depth: u32) -> String {
        if depth > 0 && self.rng.gen_bool(0.15) {
            let sign = self.pick(&["-", "+"]);
            return format!("{sign}{}{}", self.space(), self.unary(depth - 1));
        }
        let base = self.primary(depth);
        if depth > 0 && self.rng.gen_bool(0.2) {
            return format!("{base}{}^{}", self.space(), self.unary(depth - 1));
        }
        base
    }

    fn primary(&mut self, depth: u32) -> String {
        let kinds = if depth == 0 { 2 } else { 5 };
        match self.rng.gen_range(0..kinds) {
            0 => self.pick(NUMBERS),
            1 => self.pick(ATOMS),
            2 => format!("({}{})", self.sum(depth - 1), self.space()),
            3 => format!("{}({})", self.pick(FUNCTIONS_1), self.sum(depth - 1)),
            _ => {
                let f = self.pick(FUNCTIONS_2);
                let (a, b) = (self.sum(depth - 1), self.sum(depth - 1));
                format!("{f}({a},{}{b})", self.space())
            }
        }
    }
}

#[test]
fn grammatical_expressions_parse_and_round_trip() {
    let mut generator = Generator {
        rng: ChaCha8Rng::seed_from_u64(99),
    };
    for _ in 0..CASES {
        let src = generator.sum(5);
        assert!(check(&src), "{src:?} should parse");
    }
}

#[test]
fn mutated_expressions_never_panic() {
    let mut generator = Generator {
        rng: ChaCha8Rng::seed_from_u64(5),
    };
    for _ in 0..CASES {
        let mut bytes = generator.sum(4).into_bytes();
        let at = generator.rng.gen_range(0..bytes.len());
        bytes[at] = generator.rng.gen();
        check(&String::from_utf8_lossy(&bytes));
    }
}
