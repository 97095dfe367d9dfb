//! The README's case reference covers every key the case parser accepts.
//!
//! The parser's keys come from the parser itself: every spec struct of
//! `src/case` is `#[serde(deny_unknown_fields)]`, so a table with an unknown
//! key is refused with "unknown field `zz`, expected one of `a`, `b`, ...".
//! Starting from a minimal valid case (the one-body shorthand and
//! `[[body]]`), the test inserts an unknown key into each table and nested
//! table, and reads the accepted names from the error; an unknown geometry
//! `type` lists the node types the same way.
//!
//! The README's reference tables follow one convention, read by
//! [`readme_keys`]: each table comes after a marker line
//! `<!-- reference: SCOPE -->`, and each row names one key in backticks in its
//! first cell (`` | `grid.level` | ... ``). In the `geometry` scope the first
//! cell is a node `type` and the second lists its keys in backticks.
//! Names: dotted paths from the case's top level (`case` scope) or from the
//! body's table (`body` scope), `<tag>` for a boundary tag, no index for an
//! array of tables (`contact.penalty`, `material.young`); a key holding a
//! table of its own is documented by its leaves only. A nested table added to a spec shows up here as one key (its
//! name) until a probe for it is added below, which then lists its leaves.

use std::collections::BTreeSet;

use cgfem_gpu::case::Case;
use cgfem_gpu::Error;

/// The key inserted into every table: no spec accepts it.
const UNKNOWN: &str = "zz_not_a_key";

/// A minimal valid one-body case in the shorthand.
const SINGLE: &str = r#"
[geometry]
type = "cuboid"
min = [0, 0, 0]
max = [1, 1, 1]

[material]
young = 1.0
poisson = 0.3

[dirichlet.xmin]
value = ["0", "0", "0"]

[neumann.xmax]
traction = ["1", "0", "0"]
"#;

/// A minimal valid multi-body case.
const BODIES: &str = r#"
[[body]]
name = "lower"
geometry = { type = "cuboid", min = [0, 0, 0], max = [1, 1, 1] }
material = { young = 1.0, poisson = 0.3 }
dirichlet.zmin = { value = ["0", "0", "0"] }

[[body]]
name = "upper"
geometry = { type = "cuboid", min = [0, 0, 1], max = [1, 1, 2] }
material = { young = 1.0, poisson = 0.3 }
neumann.zmax = { traction = ["0", "0", "-1"] }

[[contact]]
slave = "upper.zmin"
master = "lower.zmax"
"#;

/// An `stl` geometry node with one boundary part (never read from disk: the
/// unknown key is refused while the case is deserialised).
const STL: &str = r#"
[geometry]
type = "stl"
path = "none.stl"
parts = [{ name = "a", box = { min = [0, 0, 0], max = [1, 1, 1] }, plane = { point = [0, 0, 0], normal = [0, 0, 1], tolerance = 0.1 }, normal = { direction = [0, 0, 1], angle_deg = 10 } }]

[material]
young = 1.0
poisson = 0.3
"#;

/// The table at `path` (dot-separated; a number indexes an array), created
/// where missing.
fn table_at<'a>(root: &'a mut toml::Table, path: &str) -> &'a mut toml::Table {
    let mut t = root;
    let mut parts = path.split('.').filter(|p| !p.is_empty()).peekable();
    while let Some(p) = parts.next() {
        let next_is_index = parts.peek().is_some_and(|n| n.parse::<usize>().is_ok());
        let v = t
            .entry(p.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        let v = if next_is_index {
            let i: usize = parts.next().unwrap().parse().unwrap();
            &mut v
                .as_array_mut()
                .unwrap_or_else(|| panic!("{p} is not an array"))[i]
        } else {
            v
        };
        t = v
            .as_table_mut()
            .unwrap_or_else(|| panic!("{p} is not a table"));
    }
    t
}

/// The backquoted names after "expected" in a serde error ("expected one of
/// `a`, `b`", "expected `a`"; "there are no fields" gives none).
fn expected_names(reason: &str) -> Vec<String> {
    let Some(at) = reason.find("expected") else {
        return Vec::new();
    };
    reason[at..]
        .split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// What the parser says of `base` with `key = value` inserted into the table
/// at `path`: the names it lists after "unknown field/variant `key`", or the
/// error it gave instead.
fn listed(base: &str, path: &str, key: &str, value: toml::Value) -> Result<Vec<String>, String> {
    let mut root: toml::Table = base.parse().expect("the probe's base case is TOML");
    table_at(&mut root, path).insert(key.to_string(), value);
    let text = toml::to_string(&root).expect("serialises");
    match Case::from_str("probe.toml", &text) {
        Ok(_) => Err(format!("accepted:\n{text}")),
        Err(Error::CaseFile { reason, .. })
            if reason.starts_with(&format!("unknown field `{UNKNOWN}`"))
                || reason.starts_with(&format!("unknown variant `{UNKNOWN}`")) =>
        {
            Ok(expected_names(&reason))
        }
        Err(e) => Err(e.to_string()),
    }
}

/// One table to probe: its name in the reference (`canon`) and where it is
/// in the base case (`path`).
struct Probe {
    canon: &'static str,
    path: String,
    base: &'static str,
}

fn probe(canon: &'static str, path: impl Into<String>, base: &'static str) -> Probe {
    Probe {
        canon,
        path: path.into(),
        base,
    }
}

/// The keys the parser accepts, by probing `probes`: `canon.field` for every
/// field listed, less the keys whose tables are probed themselves.
fn parser_keys(probes: &[Probe]) -> BTreeSet<String> {
    let mut keys = BTreeSet::new();
    let mut probed = Vec::new();
    for p in probes {
        let value = toml::Value::Integer(1);
        match listed(p.base, &p.path, UNKNOWN, value) {
            Ok(names) => {
                assert!(
                    !names.is_empty() || p.canon.is_empty(),
                    "{}: no fields",
                    p.canon
                );
                probed.push(p.canon);
                for n in names {
                    keys.insert(match p.canon {
                        "" => n,
                        c => format!("{c}.{n}"),
                    });
                }
            }
            Err(e) => panic!(
                "probing `{}` ({}): expected an unknown-field error, got: {e}",
                p.canon, p.path
            ),
        }
    }
    keys.retain(|k| {
        !probed
            .iter()
            .any(|c| c == k || c.starts_with(&format!("{k}.")))
    });
    keys
}

/// The keys of the whole run (the top level less the bodies).
fn case_keys() -> BTreeSet<String> {
    let probes = [
        probe("", "", BODIES),
        probe("load", "load", BODIES),
        probe("newton", "newton", BODIES),
        probe("solver", "solver", BODIES),
        probe("stabilisation", "stabilisation", BODIES),
        probe("body", "body.0", BODIES),
        probe("contact", "contact.0", BODIES),
    ];
    let mut keys = parser_keys(&probes);
    keys.retain(|k| !k.starts_with("body"));
    keys
}

/// The keys of a body, probed in `base` at `body` (the path of the body's
/// table: `body.0` under `[[body]]`, the top level in the shorthand).
fn body_keys(base: &'static str, body: &str) -> BTreeSet<String> {
    let at = |t: &str| match (body, t) {
        ("", t) => t.to_string(),
        (b, "") => b.to_string(),
        (b, t) => format!("{b}.{t}"),
    };
    let probes = [
        probe("", at(""), base),
        probe("grid", at("grid"), base),
        probe("quadrature", at("quadrature"), base),
        probe("material", at("material"), base),
        probe("exact", at("exact"), base),
        probe("body_load", at("body_load"), base),
        probe("dirichlet.<tag>", at("dirichlet.zmin"), base),
        probe("dirichlet.<tag>.region", at("dirichlet.zmin.region"), base),
        probe("neumann.<tag>", at("neumann.xmax"), base),
    ];
    parser_keys(&probes)
}

fn stl_part_keys() -> BTreeSet<String> {
    let probes = [
        probe("", "geometry.parts.0", STL),
        probe("box", "geometry.parts.0.box", STL),
        probe("plane", "geometry.parts.0.plane", STL),
        probe("normal", "geometry.parts.0.normal", STL),
    ];
    parser_keys(&probes)
}

/// Geometry nodes: `type:T` for every node type, `T.key` for its keys.
fn geometry_keys() -> BTreeSet<String> {
    let unknown = toml::Value::String(UNKNOWN.into());
    let types = listed(SINGLE, "geometry", "type", unknown)
        .expect("an unknown geometry type lists the types");
    assert!(types.len() > 5, "geometry types: {types:?}");
    let mut keys = BTreeSet::new();
    for t in types {
        let base = format!("[geometry]\ntype = \"{t}\"\n[material]\nyoung = 1.0\npoisson = 0.3\n");
        let fields = listed(&base, "geometry", UNKNOWN, toml::Value::Integer(1))
            .unwrap_or_else(|e| panic!("geometry type {t}: {e}"));
        for f in fields {
            keys.insert(format!("{t}.{f}"));
        }
        keys.insert(format!("type:{t}"));
    }
    keys
}

/// The README's reference rows of `scope` (see the module doc).
fn readme_keys(readme: &str, scope: &str) -> BTreeSet<String> {
    let marker = format!("<!-- reference: {scope} -->");
    let mut keys = BTreeSet::new();
    let mut found = false;
    for (at, _) in readme.match_indices(&marker) {
        found = true;
        let rows = readme[at + marker.len()..]
            .lines()
            .skip_while(|l| l.trim().is_empty())
            .take_while(|l| l.trim_start().starts_with('|'));
        for row in rows {
            let cells: Vec<&str> = row
                .trim()
                .trim_matches('|')
                .split('|')
                .map(str::trim)
                .collect();
            let first = cells[0];
            let Some(name) = first
                .strip_prefix('`')
                .and_then(|s| s.strip_suffix('`'))
                .filter(|s| !s.contains('`'))
            else {
                continue; // the header and the separator
            };
            if scope == "geometry" {
                keys.insert(format!("type:{name}"));
                for k in cells.get(1).unwrap_or(&"").split('`').skip(1).step_by(2) {
                    keys.insert(format!("{name}.{k}"));
                }
            } else {
                keys.insert(name.to_string());
            }
        }
    }
    assert!(found, "README.md has no `{marker}` table");
    assert!(
        !keys.is_empty(),
        "README.md: the `{marker}` table has no rows"
    );
    keys
}

#[test]
fn readme_reference_lists_every_key_the_parser_accepts() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md"))
        .expect("README.md");
    let scopes = [
        ("case", case_keys()),
        ("body", body_keys(BODIES, "body.0")),
        ("geometry", geometry_keys()),
        ("stl-parts", stl_part_keys()),
    ];
    let (mut undocumented, mut unknown) = (Vec::new(), Vec::new());
    for (scope, parser) in &scopes {
        let documented = readme_keys(&readme, scope);
        println!(
            "{scope}: the parser accepts {} keys, the README lists {}",
            parser.len(),
            documented.len()
        );
        for k in parser.difference(&documented) {
            undocumented.push(format!("{scope}: `{k}`"));
        }
        for k in documented.difference(parser) {
            unknown.push(format!("{scope}: `{k}`"));
        }
    }
    assert!(
        unknown.is_empty(),
        "in the README's case reference but not accepted by the parser:\n  {}",
        unknown.join("\n  ")
    );
    assert!(
        undocumented.is_empty(),
        "accepted by the parser but missing from the README's case reference \
         (add a row whose first cell is the key in backticks, under the scope's marker):\n  {}",
        undocumented.join("\n  ")
    );
}

/// The probe reads the parser's own lists: a key the parser does not have
/// is not among them, and one it has is.
#[test]
fn the_probe_reads_the_parser() {
    let case = case_keys();
    assert!(case.contains("stabilisation.A"), "{case:?}");
    assert!(case.contains("contact.recovered_traction"), "{case:?}");
    assert!(case.contains("name") && !case.contains("body"), "{case:?}");
    let body = body_keys(BODIES, "body.0");
    assert!(body.contains("grid.level"), "{body:?}");
    assert!(body.contains("geometry"), "{body:?}");
    assert!(body.contains("dirichlet.<tag>.region.min"), "{body:?}");
    assert!(!body.contains("grid"), "{body:?}");
    assert!(!body.contains(&format!("grid.{UNKNOWN}")));
    let geometry = geometry_keys();
    assert!(geometry.contains("type:sphere") && geometry.contains("sphere.radius"));
    assert!(geometry.contains("stl.parts"), "{geometry:?}");
    let parts = stl_part_keys();
    assert!(
        parts.contains("box.min") && parts.contains("name"),
        "{parts:?}"
    );
    assert_eq!(
        expected_names("unknown field `q`, expected one of `a`, `b`"),
        ["a", "b"]
    );
    assert_eq!(expected_names("unknown field `q`, expected `a`"), ["a"]);
    assert!(expected_names("unknown field `q`, there are no fields").is_empty());
}

/// The shorthand is one body: its top level accepts the body's keys, the
/// same as a `[[body]]` table (one parser for both).
#[test]
fn the_shorthand_accepts_the_body_keys() {
    assert_eq!(body_keys(SINGLE, ""), body_keys(BODIES, "body.0"));
}

/// The README reader finds rows after a marker and nothing else.
#[test]
fn the_readme_reader_follows_the_convention() {
    let text = "intro `x.y`\n<!-- reference: demo -->\n\n| key | meaning |\n|---|---|\n\
                | `a.b` | one |\n| `c` | `d` two |\n\nafter\n| `e` | not read |\n";
    let keys = readme_keys(text, "demo");
    assert_eq!(keys, ["a.b", "c"].map(String::from).into_iter().collect());
}
