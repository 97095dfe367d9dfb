//! Random values for the case fuzzer: numbers of every kind, strings,
//! expressions (well formed, garbled, deep) and geometry trees.

use rand::seq::SliceRandom;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use toml::{Table, Value};

/// Key paths of the case format, so that mutations reach the checks behind
/// the parser and not only "unknown key".
pub const KEYS: &[&str] = &[
    "name",
    "element",
    "geometry",
    "grid.level",
    "grid.offset",
    "grid.box_min",
    "grid.box_max",
    "quadrature.points",
    "material.young",
    "material.poisson",
    "exact.displacement",
    "body_load.value",
    "dirichlet.surface.value",
    "dirichlet.outer.value",
    "dirichlet.xmin.value",
    "neumann.inner.traction",
    "neumann.xmax.traction",
    "neumann.load.traction",
    "stabilisation.k1",
    "stabilisation.k2",
    "stabilisation.A",
    "solver.method",
    "solver.preconditioner",
    "solver.rel_tol",
    "solver.min_rel_tol",
    "solver.max_iterations",
    "solver.fixed_point_tol",
    "solver.max_fixed_point",
];

pub const TAGS: &[&str] = &[
    "surface", "outer", "inner", "xmin", "xmax", "zmax", "side", "top", "plane", "load", "hole",
];

pub const WORDS: &[&str] = &[
    "exact",
    "q1",
    "q2",
    "q3",
    "cg",
    "cgs",
    "bicgstab",
    "jacobi",
    "none",
    "sphere",
    "",
    " ",
    "é",
    "\u{1F600}",
    "x",
    "nan",
    "inf",
    "-inf",
    "1e999",
    "0x10",
];

pub fn number(rng: &mut ChaCha8Rng) -> f64 {
    const SPECIAL: &[f64] = &[
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.5,
        1e308,
        -1e308,
        f64::MAX,
        f64::MIN_POSITIVE,
        5e-324,
        1e-12,
        1e12,
    ];
    match rng.gen_range(0..4) {
        0 => *SPECIAL.choose(rng).unwrap(),
        1 => rng.gen_range(-2.0..2.0),
        2 => rng.gen_range(0.0..1.0),
        _ => rng.gen_range(-1.0f64..1.0).signum() * 10f64.powi(rng.gen_range(-300..300)),
    }
}

pub fn integer(rng: &mut ChaCha8Rng) -> i64 {
    const SPECIAL: &[i64] = &[0, 1, -1, 2, 3, 12, 13, 40, 1 << 32, i64::MAX, i64::MIN];
    if rng.gen_bool(0.5) {
        *SPECIAL.choose(rng).unwrap()
    } else {
        rng.gen_range(-5..20)
    }
}

/// A random expression: mostly well formed, sometimes garbled or deep.
pub fn expression(rng: &mut ChaCha8Rng, depth: u32) -> String {
    let leaf = |rng: &mut ChaCha8Rng| -> String {
        match rng.gen_range(0..6) {
            0 => "x".into(),
            1 => "y".into(),
            2 => "z".into(),
            3 => ["pi", "e", "w", "1e309", "0"]
                .choose(rng)
                .unwrap()
                .to_string(),
            _ => format!("{}", rng.gen_range(-10.0..10.0)),
        }
    };
    if depth == 0 || rng.gen_bool(0.3) {
        return leaf(rng);
    }
    let a = expression(rng, depth - 1);
    let b = expression(rng, depth - 1);
    match rng.gen_range(0..12) {
        0 => format!("{a} + {b}"),
        1 => format!("({a}) * ({b})"),
        2 => format!("({a}) / ({b})"),
        3 => format!("({a})^({b})"),
        4 => format!("-{a}"),
        5 => {
            let f = [
                "sin", "cos", "tan", "exp", "log", "sqrt", "abs", "atan", "foo",
            ];
            format!("{}({a})", f.choose(rng).unwrap())
        }
        6 => {
            let f = ["atan2", "min", "max", "pow"];
            format!("{}({a}, {b})", f.choose(rng).unwrap())
        }
        7 => format!("{a} {b}"),
        8 => format!("{a} +* {b}"),
        9 => format!("{}{a}{}", "(".repeat(rng.gen_range(1..300)), ")"),
        10 => format!("{a},{b}"),
        _ => format!("{a} - {b}"),
    }
}

pub fn string(rng: &mut ChaCha8Rng) -> String {
    match rng.gen_range(0..4) {
        0 => WORDS.choose(rng).unwrap().to_string(),
        1 => TAGS.choose(rng).unwrap().to_string(),
        2 => expression(rng, 3),
        _ => (0..rng.gen_range(0..12))
            .map(|_| rng.gen_range(' '..='\u{2FF}'))
            .collect(),
    }
}

pub fn vec3(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> Value {
    if rng.gen_bool(0.03) {
        // Degenerate on purpose: zero axes, coincident ends, boundaries on
        // grid planes, offsets just below 1.
        let v = *[0.0, 1.0, 0.5, 1.0 - 1e-15, 0.25].choose(rng).unwrap();
        return Value::Array(vec![Value::Float(v); 3]);
    }
    Value::Array(
        (0..3)
            .map(|_| {
                if rng.gen_bool(0.95) {
                    Value::Float(rng.gen_range(lo..hi))
                } else {
                    Value::Float(number(rng))
                }
            })
            .collect(),
    )
}

/// A random value of any type.
pub fn value(rng: &mut ChaCha8Rng, depth: u32) -> Value {
    match rng.gen_range(0..if depth == 0 { 6 } else { 9 }) {
        0 => Value::Float(number(rng)),
        1 => Value::Integer(integer(rng)),
        2 | 3 => Value::String(string(rng)),
        4 => Value::Boolean(rng.gen()),
        5 => "1979-05-27T07:32:00Z".parse().map(Value::Datetime).unwrap(),
        6 => vec3(rng, -2.0, 2.0),
        7 => Value::Array(
            (0..rng.gen_range(0..5))
                .map(|_| value(rng, depth - 1))
                .collect(),
        ),
        _ => Value::Table(
            (0..rng.gen_range(0..3))
                .map(|_| (string(rng), value(rng, depth - 1)))
                .collect(),
        ),
    }
}

pub fn node(kind: &str, keys: Vec<(&str, Value)>) -> Value {
    let mut t = Table::new();
    t.insert("type".into(), Value::String(kind.into()));
    for (k, v) in keys {
        t.insert(k.into(), v);
    }
    Value::Table(t)
}

pub fn radius(rng: &mut ChaCha8Rng) -> Value {
    Value::Float(if rng.gen_bool(0.9) {
        rng.gen_range(0.05..1.5)
    } else {
        number(rng)
    })
}

/// A random geometry tree: primitives, CSG and motions, mostly valid.
pub fn geometry(rng: &mut ChaCha8Rng, depth: u32) -> Value {
    let leaf_only = depth == 0;
    match rng.gen_range(0..if leaf_only { 7 } else { 14 }) {
        0 => node(
            "sphere",
            vec![("center", vec3(rng, -1.0, 1.0)), ("radius", radius(rng))],
        ),
        1 => node(
            "shell",
            vec![
                ("center", vec3(rng, -1.0, 1.0)),
                ("inner_radius", radius(rng)),
                ("outer_radius", radius(rng)),
            ],
        ),
        2 => node(
            "cuboid",
            vec![("min", vec3(rng, -1.0, 0.2)), ("max", vec3(rng, -0.2, 1.0))],
        ),
        3 => node(
            "half_space",
            vec![
                ("point", vec3(rng, -1.0, 1.0)),
                ("normal", vec3(rng, -1.0, 1.0)),
            ],
        ),
        4 => node(
            "cylinder",
            vec![
                ("start", vec3(rng, -1.0, 1.0)),
                ("end", vec3(rng, -1.0, 1.0)),
                ("radius", radius(rng)),
            ],
        ),
        5 => node(
            "annulus",
            vec![
                ("start", vec3(rng, -1.0, 1.0)),
                ("end", vec3(rng, -1.0, 1.0)),
                ("inner_radius", radius(rng)),
                ("outer_radius", radius(rng)),
            ],
        ),
        6 => node(
            "torus",
            vec![
                ("center", vec3(rng, -1.0, 1.0)),
                ("axis", vec3(rng, -1.0, 1.0)),
                ("major_radius", radius(rng)),
                ("minor_radius", radius(rng)),
            ],
        ),
        7..=9 => {
            let kind = ["union", "intersection", "difference"][rng.gen_range(0..3)];
            let parts = (0..rng.gen_range(0..4))
                .map(|_| geometry(rng, depth - 1))
                .collect();
            node(kind, vec![("of", Value::Array(parts))])
        }
        10 => node(
            "translate",
            vec![
                ("by", vec3(rng, -1.0, 1.0)),
                ("of", geometry(rng, depth - 1)),
            ],
        ),
        11 => node(
            "rotate",
            vec![
                ("axis", vec3(rng, -1.0, 1.0)),
                ("angle_deg", Value::Float(rng.gen_range(-360.0..360.0))),
                ("of", geometry(rng, depth - 1)),
            ],
        ),
        12 => node(
            "tag",
            vec![
                ("name", Value::String(string(rng))),
                ("of", geometry(rng, depth - 1)),
            ],
        ),
        _ => node(
            "retag",
            vec![
                ("from", Value::String(TAGS.choose(rng).unwrap().to_string())),
                ("to", Value::String(string(rng))),
                ("of", geometry(rng, depth - 1)),
            ],
        ),
    }
}
