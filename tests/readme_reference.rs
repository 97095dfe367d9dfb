//! The README's case reference covers every key the case parser accepts.
//!
//! The parser's keys come from the parser itself: every spec struct of
//! `src/case` is `#[serde(deny_unknown_fields)]`, so a table with an unknown
//! key is refused with "unknown field `zz`, expected one of `a`, `b`, ...".
//! Starting from a minimal valid case (single-body and `[[body]]`), the test
//! inserts an unknown key into each table and nested table, and reads the
//! accepted names from the error; an unknown geometry `type` lists the node
//! types the same way.
//!
//! The README's reference tables follow one convention, read by
//! [`readme_keys`]: each table comes after a marker line
//! `<!-- reference: SCOPE -->`, and each row names one key in backticks in its
//! first cell (`` | `grid.level` | ... ``). In the `geometry` scope the first
//! cell is a node `type` and the second lists its keys in backticks.
//! Names: dotted paths from the case's top level, `<tag>` for a boundary tag,
//! no index for an array of tables (`body.material.young`,
//! `contact.penalty`); a key holding a table of its own is documented by its
//! leaves only. A nested table added to a spec shows up here as one key (its
//! name) until a probe for it is added below, which then lists its leaves.

use std::collections::BTreeSet;

use cgfem_gpu::case::bodies::BodiesCase;
use cgfem_gpu::case::Case;
use cgfem_gpu::Error;

/// The key inserted into every table: no spec accepts it.
const UNKNOWN: &str = "zz_not_a_key";

/// A minimal valid single-body case.
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

/// Which parser reads a probe.
#[derive(Clone, Copy)]
enum Parser {
    Single,
    Bodies,
}

impl Parser {
    fn parse(self, text: &str) -> Result<(), Error> {
        match self {
            Parser::Single => Case::from_str("probe.toml", text).map(|_| ()),
            Parser::Bodies => BodiesCase::from_str_with("probe.toml", text, &[]).map(|_| ()),
        }
    }
}

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
fn listed(
    parser: Parser,
    base: &str,
    path: &str,
    key: &str,
    value: toml::Value,
) -> Result<Vec<String>, String> {
    let mut root: toml::Table = base.parse().expect("the probe's base case is TOML");
    table_at(&mut root, path).insert(key.to_string(), value);
    let text = toml::to_string(&root).expect("serialises");
    match parser.parse(&text) {
        Ok(()) => Err(format!("accepted:\n{text}")),
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
    path: &'static str,
    base: &'static str,
}

const fn probe(canon: &'static str, path: &'static str, base: &'static str) -> Probe {
    Probe { canon, path, base }
}

/// The keys one parser accepts, by probing `probes`: `canon.field` for every
/// field listed, less the keys whose tables are probed themselves.
fn parser_keys(parser: Parser, probes: &[Probe]) -> BTreeSet<String> {
    let mut keys = BTreeSet::new();
    let mut probed = Vec::new();
    for p in probes {
        let value = toml::Value::Integer(1);
        match listed(parser, p.base, p.path, UNKNOWN, value) {
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

fn single_body_keys() -> BTreeSet<String> {
    let probes = [
        probe("", "", SINGLE),
        probe("grid", "grid", SINGLE),
        probe("quadrature", "quadrature", SINGLE),
        probe("material", "material", SINGLE),
        probe("exact", "exact", SINGLE),
        probe("body_load", "body_load", SINGLE),
        probe("dirichlet.<tag>", "dirichlet.xmin", SINGLE),
        probe("dirichlet.<tag>.region", "dirichlet.xmin.region", SINGLE),
        probe("neumann.<tag>", "neumann.xmax", SINGLE),
        probe("stabilisation", "stabilisation", SINGLE),
        probe("solver", "solver", SINGLE),
    ];
    parser_keys(Parser::Single, &probes)
}

fn multi_body_keys() -> BTreeSet<String> {
    let probes = [
        probe("", "", BODIES),
        probe("load", "load", BODIES),
        probe("newton", "newton", BODIES),
        probe("solver", "solver", BODIES),
        probe("stabilisation", "stabilisation", BODIES),
        probe("body", "body.0", BODIES),
        probe("body.grid", "body.0.grid", BODIES),
        probe("body.material", "body.0.material", BODIES),
        probe("body.dirichlet.<tag>", "body.0.dirichlet.zmin", BODIES),
        probe(
            "body.dirichlet.<tag>.region",
            "body.0.dirichlet.zmin.region",
            BODIES,
        ),
        probe("body.neumann.<tag>", "body.1.neumann.zmax", BODIES),
        probe("contact", "contact.0", BODIES),
    ];
    parser_keys(Parser::Bodies, &probes)
}

fn stl_part_keys() -> BTreeSet<String> {
    let probes = [
        probe("", "geometry.parts.0", STL),
        probe("box", "geometry.parts.0.box", STL),
        probe("plane", "geometry.parts.0.plane", STL),
        probe("normal", "geometry.parts.0.normal", STL),
    ];
    parser_keys(Parser::Single, &probes)
}

/// Geometry nodes: `type:T` for every node type, `T.key` for its keys.
fn geometry_keys() -> BTreeSet<String> {
    let unknown = toml::Value::String(UNKNOWN.into());
    let types = listed(Parser::Single, SINGLE, "geometry", "type", unknown)
        .expect("an unknown geometry type lists the types");
    assert!(types.len() > 5, "geometry types: {types:?}");
    let mut keys = BTreeSet::new();
    for t in types {
        let base = format!("[geometry]\ntype = \"{t}\"\n[material]\nyoung = 1.0\npoisson = 0.3\n");
        let fields = listed(
            Parser::Single,
            &base,
            "geometry",
            UNKNOWN,
            toml::Value::Integer(1),
        )
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
        ("single-body", single_body_keys()),
        ("multi-body", multi_body_keys()),
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
    let single = single_body_keys();
    assert!(single.contains("grid.level"), "{single:?}");
    assert!(single.contains("stabilisation.A"), "{single:?}");
    assert!(single.contains("geometry"), "{single:?}");
    assert!(!single.contains("grid"), "{single:?}");
    assert!(!single.contains(&format!("grid.{UNKNOWN}")));
    let bodies = multi_body_keys();
    assert!(
        bodies.contains("body.dirichlet.<tag>.region.min"),
        "{bodies:?}"
    );
    assert!(bodies.contains("contact.recovered_traction"), "{bodies:?}");
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

/// The README reader finds rows after a marker and nothing else.
#[test]
fn the_readme_reader_follows_the_convention() {
    let text = "intro `x.y`\n<!-- reference: demo -->\n\n| key | meaning |\n|---|---|\n\
                | `a.b` | one |\n| `c` | `d` two |\n\nafter\n| `e` | not read |\n";
    let keys = readme_keys(text, "demo");
    assert_eq!(keys, ["a.b", "c"].map(String::from).into_iter().collect());
}
