//! Case-file parsing: the geometry tree, defaults, and errors that name the key.

use super::*;
use crate::element::ElementOrder;

const MATERIAL: &str = "[material]\nyoung = 1000\npoisson = 0.3\n";

const BRACKET: &str = r#"
name = "plate"
element = "q2"
[grid]
level = 3
offset = [0.25, 0.5, 0.0]
[geometry]
type = "difference"
of = [
  { type = "cuboid", min = [-1, -1, -0.25], max = [1, 1, 0.25] },
  { type = "tag", name = "hole", of = { type = "cylinder", start = [0, 0, -1], end = [0, 0, 1], radius = 0.3 } },
]
[material]
young = 1000
poisson = 0.3
"#;

#[test]
fn parses_a_csg_case() {
    let case = Case::from_str("plate.toml", BRACKET).unwrap();
    assert_eq!(case.body().spec.element, ElementOrder::Q2);
    assert_eq!(case.spec.name.as_deref(), Some("plate"));
    let g = &case.body().geometry;
    assert!(g.inside([0.5, 0.5, 0.0]) && !g.inside([0.1, 0.1, 0.0]));
    assert!(g.tag_id("hole").is_some() && g.tag_id("xmin").is_some());
    let grid = case.grid(None).unwrap();
    assert_eq!((grid.level, grid.n), (3, [9, 9, 2]));
    assert_eq!(case.grid(Some(5)).unwrap().level, 5);
}

#[test]
fn motions_apply_in_order() {
    let text = r#"
[material]
young = 1
poisson = 0
[geometry]
type = "translate"
by = [1, 0, 0]
of = { type = "rotate", axis = [0, 0, 1], angle_deg = 90, of = { type = "cylinder", start = [0, 0, 0], end = [1, 0, 0], radius = 0.1 } }
"#;
    let case = Case::from_str("t.toml", text).unwrap();
    // The rod along +x turned to +y, then moved by +x.
    assert!(case.body().geometry.inside([1.0, 0.5, 0.0]));
    assert!(!case.body().geometry.inside([0.5, 0.0, 0.0]));
    assert_eq!(case.spec.name.as_deref(), Some("t"));
}

fn error_of(text: &str) -> (String, String) {
    let text = format!("{text}{MATERIAL}");
    match Case::from_str("case.toml", &text).and_then(|c| c.grid(None).map(|_| c)) {
        Err(Error::CaseFile { file, key, reason }) => {
            assert_eq!(file, "case.toml");
            (key, reason)
        }
        other => panic!("expected a case-file error, got {other:?}"),
    }
}

#[test]
fn errors_name_the_key() {
    let (key, reason) = error_of("[geometry]\ntype = \"sphere\"\ncenter = [0,0,0]\nradius = -1\n");
    assert_eq!(key, "geometry");
    assert!(reason.contains("radius"), "{reason}");
    let (key, reason) = error_of("[geometry]\ntype = \"sphere\"\ncentre = [0,0,0]\nradius = 1\n");
    assert_eq!(key, "geometry");
    assert!(reason.contains("centre"), "{reason}");
    let (key, _) = error_of(
        "[geometry]\ntype = \"sphere\"\ncenter = [0,0,0]\nradius = 1\n[grid]\nlevle = 3\n",
    );
    assert_eq!(key, "grid.levle");
    let (key, _) = error_of(
        "[geometry]\ntype = \"sphere\"\ncenter = [0,0,0]\nradius = 1\n[grid]\nlevel = 99\n",
    );
    assert_eq!(key, "grid.level");
    // Inside a tagged table the path stops at the table; the reason says more.
    let (key, reason) = error_of("[geometry]\ntype = \"sphere\"\ncenter = [0,0]\nradius = 1\n");
    assert_eq!(key, "geometry");
    assert!(reason.contains("length 2"), "{reason}");
    let (key, _) = error_of("[geometry]\ntype = \"union\"\nof = [{ type = \"sphere\", center = [0,0,0], radius = 1 }, { type = \"torus\", center = [0,0,0], axis = [0,0,1], major_radius = 0.1, minor_radius = 0.5 }]\n");
    assert_eq!(key, "geometry.of[1]");
    let (key, _) =
        error_of("[geometry]\ntype = \"half_space\"\npoint = [0,0,0]\nnormal = [0,0,1]\n");
    assert_eq!(key, "grid.box_min");
    let (key, _) =
        error_of("element = \"q3\"\n[geometry]\ntype = \"sphere\"\ncenter = [0,0,0]\nradius = 1\n");
    assert_eq!(key, "element");
}

const SPHERE: &str = "[geometry]\ntype = \"sphere\"\ncenter = [0,0,0]\nradius = 1\n";

#[test]
fn physics_tables_and_overrides() {
    let text = format!(
        "{SPHERE}{MATERIAL}[exact]\ndisplacement = [\"x\", \"2*y\", \"0\"]\n[dirichlet.surface]\nvalue = \"exact\"\n"
    );
    let overrides = [
        "solver.method=cg".into(),
        "material.young = 5".into(),
        "grid.level=2".into(),
    ];
    let case = Case::from_str_with("c.toml", &text, &overrides).unwrap();
    assert_eq!(case.spec.solver.method, crate::solver::KrylovMethod::Cg);
    assert_eq!(case.body().spec.material.young, 5.0);
    assert_eq!(case.body().spec.grid.level, 2);
    assert_eq!(
        case.body().spec.dirichlet["surface"].value,
        boundary::DirichletValue::Exact
    );
    assert_eq!(case.spec.stabilisation.k1, 30.0);
}

#[test]
fn physics_errors_name_the_key() {
    let cases: &[(&str, &str)] = &[
        ("[material]\nyoung = 1000\npoisson = 0.5\n", "material.poisson"),
        ("[material]\nyoung = -1\npoisson = 0.3\n", "material.young"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[dirichlet.top]\nvalue = [\"0\",\"0\",\"0\"]\n", "dirichlet.top"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[dirichlet.surface]\nvalue = \"exact\"\n", "dirichlet.surface.value"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[dirichlet.surface]\nvalue = [\"x +\",\"0\",\"0\"]\n", "dirichlet.surface.value[0]"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[dirichlet.surface]\nvalue = [\"w\",\"0\",\"0\"]\n", "dirichlet.surface.value[0]"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[solver]\nmethod = \"gmres\"\n", "solver.method"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[stabilisation]\nk1 = 0\n", "stabilisation.k1"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[stabilisation]\nk1 = 1.5e3\n", "stabilisation.k1"),
        ("[materail]\nyoung = 1\npoisson = 0.3\n", "materail"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[dirichlet.surface]\nvalue = [\"free\",\"free\",\"free\"]\n", "dirichlet.surface.value"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[dirichlet.surface]\nvalue = [\"0\",\"free\",\"exact\"]\n", "dirichlet.surface.value"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[dirichlet.surface]\nvalue = [\"0\",\"0\",\"0\"]\nregion = { min = [0, 0, 1], max = [1, 1, 0] }\n", "dirichlet.surface.region"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[dirichlet.surface]\nvalue = [\"0\",\"0\",\"0\"]\nregion = { mid = [0, 0, 1] }\n", "dirichlet.surface.region.mid"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[dirichlet.surface]\nvalue = [\"0\",\"0\",\"0\"]\nramp = [0, 0.5]\n", "dirichlet.surface.ramp"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[neumann.surface]\npressure = \"1\"\nramp = [0, 0.5]\n", "neumann.surface.ramp"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[neumann.surface]\npressure = \"1\"\ntraction = [\"0\",\"0\",\"0\"]\n", "neumann.surface"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[neumann.surface]\n", "neumann.surface"),
        ("[material]\nyoung = 1\npoisson = 0.3\n[neumann.surface]\npressure = \"1 +\"\n", "neumann.surface.pressure"),
    ];
    for (physics, key) in cases {
        let text = format!("{SPHERE}{physics}");
        match Case::from_str("c.toml", &text) {
            Err(Error::CaseFile { key: k, reason, .. }) => assert_eq!(&k, key, "{reason}"),
            other => panic!("{physics}: expected a case error, got {other:?}"),
        }
    }
}

mod bodies;
