//! Mutations of a parsed case (delete, replace, add keys, new geometry),
//! of its text (truncate, garble), and random `--set` overrides.

use rand::seq::SliceRandom;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use toml::{Table, Value};

use super::values::{expression, geometry, integer, number, string, value, vec3, KEYS};

/// The table holding the last part of a dotted `path`, created on the way
/// when `create`.
pub fn parent<'a>(t: &'a mut Table, path: &[&str], create: bool) -> Option<&'a mut Table> {
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
pub fn paths(v: &Value, prefix: &str, out: &mut Vec<String>) {
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

pub fn slot<'a>(root: &'a mut Value, path: &str) -> Option<&'a mut Value> {
    path.split('.').try_fold(root, |v, p| match v {
        Value::Table(t) => t.get_mut(p),
        Value::Array(a) => a.get_mut(p.parse::<usize>().ok()?),
        _ => None,
    })
}

/// One structural mutation of a parsed case.
pub fn mutate_tree(rng: &mut ChaCha8Rng, root: &mut Value) {
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
            if rng.gen_bool(0.5) {
                // The seed's tags are likely gone: set up without conditions.
                t.remove("dirichlet");
                t.remove("neumann");
            }
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
pub fn mutate_text(rng: &mut ChaCha8Rng, text: &mut String) {
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

pub fn overrides(rng: &mut ChaCha8Rng) -> Vec<String> {
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
            3 if rng.gen_bool(0.1) => {
                let depth = rng.gen_range(1..2000);
                format!("geometry{}.type=sphere", ".of".repeat(depth))
            }
            _ => string(rng),
        })
        .collect()
}
