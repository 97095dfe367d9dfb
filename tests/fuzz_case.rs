//! Property test of the case parser and the setup: seeded random and mutated
//! case files (the files of `cases/` with keys deleted, values replaced by
//! numbers of every kind — NaN, ±∞, negative, huge, subnormal — strings,
//! arrays and tables, random geometry trees and placements, truncated and
//! garbled text, random `--set` overrides) go through `Case::from_str_with`
//! and, when they parse, through `Setup` at a tiny level. Nothing may panic;
//! every error must be a `CaseFile` error naming the file and a key.
//!
//! 10 000 inputs by default (a third of those that parse are set up; about
//! half a minute in release); set
//! `CGFEM_FUZZ_CASES=1000000` for a long run and `CGFEM_FUZZ_SEED` to change
//! the seed. A failure prints the input that caused it.

use std::panic::{catch_unwind, AssertUnwindSafe};

use cgfem_gpu::case::Case;
use cgfem_gpu::fem::setup::Setup;
use cgfem_gpu::Error;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use toml::{Table, Value};

const FILE: &str = "fuzz.toml";

/// Key paths of the case format, so that mutations reach the checks behind
/// the parser and not only "unknown key".
const KEYS: &[&str] = &[
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

const TAGS: &[&str] = &[
    "surface", "outer", "inner", "xmin", "xmax", "zmax", "side", "top", "plane", "load", "hole",
];

const WORDS: &[&str] = &[
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

fn seeds() -> Vec<String> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let seeds: Vec<String> = files
        .iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect();
    assert!(seeds.len() >= 2, "no case files to start from");
    seeds
}

fn number(rng: &mut ChaCha8Rng) -> f64 {
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

fn integer(rng: &mut ChaCha8Rng) -> i64 {
    const SPECIAL: &[i64] = &[0, 1, -1, 2, 3, 12, 13, 40, 1 << 32, i64::MAX, i64::MIN];
    if rng.gen_bool(0.5) {
        *SPECIAL.choose(rng).unwrap()
    } else {
        rng.gen_range(-5..20)
    }
}

/// A random expression: mostly well formed, sometimes garbled or deep.
fn expression(rng: &mut ChaCha8Rng, depth: u32) -> String {
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

fn string(rng: &mut ChaCha8Rng) -> String {
    match rng.gen_range(0..4) {
        0 => WORDS.choose(rng).unwrap().to_string(),
        1 => TAGS.choose(rng).unwrap().to_string(),
        2 => expression(rng, 3),
        _ => (0..rng.gen_range(0..12))
            .map(|_| rng.gen_range(' '..='\u{2FF}'))
            .collect(),
    }
}

fn vec3(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> Value {
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
fn value(rng: &mut ChaCha8Rng, depth: u32) -> Value {
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

fn node(kind: &str, keys: Vec<(&str, Value)>) -> Value {
    let mut t = Table::new();
    t.insert("type".into(), Value::String(kind.into()));
    for (k, v) in keys {
        t.insert(k.into(), v);
    }
    Value::Table(t)
}

fn radius(rng: &mut ChaCha8Rng) -> Value {
    Value::Float(if rng.gen_bool(0.9) {
        rng.gen_range(0.05..1.5)
    } else {
        number(rng)
    })
}

/// A random geometry tree: primitives, CSG and motions, mostly valid.
fn geometry(rng: &mut ChaCha8Rng, depth: u32) -> Value {
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

/// The table holding the last part of a dotted `path`, created on the way
/// when `create`.
fn parent<'a>(t: &'a mut Table, path: &[&str], create: bool) -> Option<&'a mut Table> {
    let mut t = t;
    for p in path {
        if create && !t.contains_key(*p) {
            t.insert(p.to_string(), Value::Table(Table::new()));
        }
        t = t.get_mut(*p)?.as_table_mut()?;
    }
    Some(t)
}

/// All dotted key paths of `t`, arrays included (as `key.N`).
fn paths(v: &Value, prefix: &str, out: &mut Vec<String>) {
    let mut push = |k: String, v: &Value| {
        out.push(k.clone());
        paths(v, &k, out);
    };
    let join = |k: &str| {
        if prefix.is_empty() {
            k.to_string()
        } else {
            format!("{prefix}.{k}")
        }
    };
    match v {
        Value::Table(t) => t.iter().for_each(|(k, v)| push(join(k), v)),
        Value::Array(a) => a
            .iter()
            .enumerate()
            .for_each(|(i, v)| push(join(&i.to_string()), v)),
        _ => {}
    }
}

fn slot<'a>(root: &'a mut Value, path: &str) -> Option<&'a mut Value> {
    path.split('.').try_fold(root, |v, p| match v {
        Value::Table(t) => t.get_mut(p),
        Value::Array(a) => a.get_mut(p.parse::<usize>().ok()?),
        _ => None,
    })
}

/// One structural mutation of a parsed case.
fn mutate_tree(rng: &mut ChaCha8Rng, root: &mut Value) {
    let mut all = Vec::new();
    paths(root, "", &mut all);
    match rng.gen_range(0..6) {
        0 if !all.is_empty() => {
            // Delete a key or array element.
            let p = all.choose(rng).unwrap().clone();
            let (head, last) = p.rsplit_once('.').unwrap_or(("", &p));
            let parent = if head.is_empty() {
                Some(&mut *root)
            } else {
                slot(root, head)
            };
            match parent {
                Some(Value::Table(t)) => drop(t.remove(last)),
                Some(Value::Array(a)) => {
                    if let Ok(i) = last.parse::<usize>() {
                        if i < a.len() {
                            a.remove(i);
                        }
                    }
                }
                _ => {}
            }
        }
        1 if !all.is_empty() => {
            // Replace any value by a random one.
            let p = all.choose(rng).unwrap().clone();
            if let Some(v) = slot(root, &p) {
                *v = value(rng, 2);
            }
        }
        2 => {
            // Set a known key to a random value.
            let key = KEYS.choose(rng).unwrap();
            let parts: Vec<&str> = key.split('.').collect();
            let (last, head) = parts.split_last().unwrap();
            let v = if *key == "geometry" {
                geometry(rng, 3)
            } else if rng.gen_bool(0.3) {
                Value::Array((0..3).map(|_| Value::String(expression(rng, 3))).collect())
            } else {
                value(rng, 2)
            };
            if let Some(t) = root.as_table_mut().and_then(|t| parent(t, head, true)) {
                t.insert(last.to_string(), v);
            }
        }
        3 => {
            // A random geometry tree with a random grid.
            let t = root.as_table_mut().unwrap();
            t.insert("geometry".into(), geometry(rng, 3));
            t.remove("grid");
            if rng.gen_bool(0.3) {
                let mut g = Table::new();
                g.insert("box_min".into(), vec3(rng, -2.0, 0.0));
                g.insert("box_max".into(), vec3(rng, 0.0, 2.0));
                g.insert("offset".into(), vec3(rng, 0.0, 1.0));
                t.insert("grid".into(), Value::Table(g));
            }
        }
        4 if !all.is_empty() => {
            // Nudge a number.
            let p = all.choose(rng).unwrap().clone();
            if let Some(v) = slot(root, &p) {
                match v {
                    Value::Float(f) => *f = *f * number(rng) + number(rng),
                    Value::Integer(i) => *i = i.wrapping_add(integer(rng)),
                    _ => {}
                }
            }
        }
        _ => {
            // Add an unknown key somewhere.
            let (k, v) = (string(rng), value(rng, 1));
            let target = match all.choose(rng) {
                Some(p) if rng.gen_bool(0.7) => slot(root, p),
                _ => Some(root),
            };
            if let Some(Value::Table(t)) = target {
                t.insert(k, v);
            }
        }
    }
}

/// One textual mutation: truncation, deleted or repeated lines, stray bytes.
fn mutate_text(rng: &mut ChaCha8Rng, text: &mut String) {
    let boundary = |rng: &mut ChaCha8Rng, s: &str| {
        let mut i = rng.gen_range(0..=s.len());
        while !s.is_char_boundary(i) {
            i -= 1;
        }
        i
    };
    match rng.gen_range(0..4) {
        0 => {
            let i = boundary(rng, text);
            text.truncate(i);
        }
        1 => {
            let mut lines: Vec<&str> = text.lines().collect();
            if !lines.is_empty() {
                let i = rng.gen_range(0..lines.len());
                if rng.gen_bool(0.5) {
                    lines.remove(i);
                } else {
                    lines.insert(i, lines[i]);
                }
            }
            *text = lines.join("\n");
        }
        2 => {
            let i = boundary(rng, text);
            let c = *[
                '[', ']', '"', '=', '\n', '{', ',', '#', '\'', '\\', '\u{0}', 'é',
            ]
            .choose(rng)
            .unwrap();
            text.insert(i, c);
        }
        _ => {
            let i = boundary(rng, text);
            let j = boundary(rng, &text[i..]) + i;
            text.replace_range(i..j, "");
        }
    }
}

fn overrides(rng: &mut ChaCha8Rng) -> Vec<String> {
    (0..rng.gen_range(0..3))
        .map(|_| match rng.gen_range(0..4) {
            0 => format!("{}={}", KEYS.choose(rng).unwrap(), number(rng)),
            1 => format!("{}={}", KEYS.choose(rng).unwrap(), string(rng)),
            2 => format!(
                "{}.{}={}",
                KEYS.choose(rng).unwrap(),
                string(rng),
                integer(rng)
            ),
            _ => string(rng),
        })
        .collect()
}

/// One input: a mutated seed (structure, then text), and overrides.
fn input(rng: &mut ChaCha8Rng, seeds: &[String]) -> (String, Vec<String>) {
    let seed = seeds.choose(rng).unwrap();
    let mut root = Value::Table(seed.parse::<Table>().unwrap());
    for _ in 0..rng.gen_range(0..4) {
        mutate_tree(rng, &mut root);
    }
    let mut text = if rng.gen_bool(0.1) {
        seed.clone()
    } else {
        toml::to_string(&root).unwrap_or_else(|_| seed.clone())
    };
    if rng.gen_bool(0.2) {
        mutate_text(rng, &mut text);
    }
    let sets = if rng.gen_bool(0.2) {
        overrides(rng)
    } else {
        Vec::new()
    };
    (text, sets)
}

fn check_error(e: &Error, what: &str, text: &str, sets: &[String]) {
    match e {
        Error::CaseFile { file, key, reason } => {
            assert_eq!(file, FILE, "{what}: {e}\n--- input ---\n{text}\n{sets:?}");
            assert!(
                !key.is_empty() && !reason.is_empty(),
                "{what}: {e}\n--- input ---\n{text}\n{sets:?}"
            );
        }
        other => panic!("{what}: untyped error {other:?}\n--- input ---\n{text}\n{sets:?}"),
    }
}

#[test]
fn random_and_mutated_cases_never_panic() {
    let n: usize = std::env::var("CGFEM_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000);
    let seed: u64 = std::env::var("CGFEM_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20_260_509);
    let seeds = seeds();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut parsed, mut set_up, mut setup_seconds) = (0, 0, 0.0);
    let start = std::time::Instant::now();
    for k in 0..n {
        let (text, sets) = input(&mut rng, &seeds);
        let r = catch_unwind(AssertUnwindSafe(|| Case::from_str_with(FILE, &text, &sets)));
        let case = match r {
            Err(_) => panic!("input {k}: the parser panicked on\n{text}\n{sets:?}"),
            Ok(Err(e)) => {
                check_error(&e, "parse", &text, &sets);
                continue;
            }
            Ok(Ok(case)) => case,
        };
        parsed += 1;
        // A setup costs a thousand parses (cut-cell rules and matrices even
        // at level 0): set up one parsed case in three.
        if !rng.gen_bool(1.0 / 3.0) {
            continue;
        }
        // Level 2 for a quarter of the cases: cut cells of every kind appear
        // already at levels 0 and 1, at a fraction of the cost.
        let level = if rng.gen_bool(0.25) {
            2
        } else {
            rng.gen_range(0..=1)
        };
        let t = std::time::Instant::now();
        let r = catch_unwind(AssertUnwindSafe(|| Setup::new(&case, Some(level))));
        setup_seconds += t.elapsed().as_secs_f64();
        match r {
            Err(_) => panic!("input {k}: the setup panicked at level {level} on\n{text}\n{sets:?}"),
            Ok(Err(e)) => check_error(&e, "setup", &text, &sets),
            Ok(Ok(s)) => {
                set_up += 1;
                assert!(
                    s.fixed_rhs.iter().all(|v| v.is_finite()),
                    "input {k}: non-finite load\n{text}\n{sets:?}"
                );
            }
        }
    }
    println!(
        "{n} inputs: {parsed} parsed, {set_up} set up; {:.1} s in all, {setup_seconds:.1} s in setups",
        start.elapsed().as_secs_f64()
    );
    // The generator must reach the checks behind the parser and the setup.
    assert!(parsed * 10 >= n, "only {parsed} of {n} inputs parsed");
    assert!(set_up * 40 >= n, "only {set_up} of {n} inputs were set up");
}
