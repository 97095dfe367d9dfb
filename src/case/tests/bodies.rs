//! Multi-body case files: a full case parses with its defaults, and each bad
//! input names its key.

use crate::case::boundary::{Component, RampSpec};
use crate::case::*;
use crate::error::Error;

/// Two blocks stacked along z, 0.01 apart, the upper pushed down.
const BLOCKS: &str = r#"
name = "blocks"
[load]
steps = 4
[[body]]
name = "lower"
geometry = { type = "cuboid", min = [-1, -1, -1], max = [1, 1, 0] }
grid = { level = 2 }
material = { young = 1000.0, poisson = 0.3 }
dirichlet.zmin = { value = ["0", "0", "0"] }
[[body]]
name = "upper"
geometry = { type = "cuboid", min = [-0.5, -0.5, 0.01], max = [0.5, 0.5, 1.01] }
grid = { level = 3 }
material = { model = "st_venant_kirchhoff", young = 500.0, poisson = 0.25 }
dirichlet.zmax = { value = ["free", "free", "-0.1*z"], region = { min = [-inf, -inf, 1.0] } }
[[contact]]
slave = "upper.zmin"
master = "lower.zmax"
"#;

fn parse(text: &str) -> Result<Case> {
    Case::from_str_with("blocks.toml", text, &[])
}

/// The key of a case-file error, or a panic naming what came instead.
fn key_of(r: Result<Case>) -> String {
    match r {
        Err(Error::CaseFile { key, .. }) => key,
        Err(other) => panic!("not a case-file error: {other}"),
        Ok(_) => panic!("accepted"),
    }
}

#[test]
fn parses_two_bodies_and_a_pair() {
    let case = parse(BLOCKS).unwrap();
    assert_eq!(case.spec.load.steps, 4);
    assert_eq!(case.spec.newton, NewtonSpec::default());
    assert_eq!(case.spec.solver.method, KrylovMethod::BiCgStab);
    assert_eq!(case.bodies.len(), 2);
    let upper = &case.bodies[1].spec;
    assert_eq!(upper.material.model, Some(Model::StVenantKirchhoff));
    assert_eq!(case.bodies[1].model, Model::StVenantKirchhoff);
    // No model named, and the case has contact: neo-Hookean.
    assert_eq!(case.bodies[0].spec.material.model, None);
    assert_eq!(case.bodies[0].model, Model::NeoHookean);
    assert_eq!(case.path, SolutionPath::Newton("it has 2 bodies".into()));
    let d = &upper.dirichlet["zmax"];
    let value = d.components();
    assert_eq!(value[0], Component::Free);
    match &value[2] {
        Component::Given(e) => assert_eq!(e.eval([0.0, 0.0, 2.0]), -0.2),
        other => panic!("z is given, got {other:?}"),
    }
    let region = d.region.as_ref().unwrap();
    assert!(region.contains([5.0, -5.0, 1.01]) && !region.contains([0.0, 0.0, 0.5]));
    let pair = case.pairs[0];
    let tag = |b: usize, t: &str| case.bodies[b].geometry.tag_id(t).unwrap();
    assert_eq!(
        pair.slave,
        BoundaryRef {
            body: 1,
            tag: tag(1, "zmin")
        }
    );
    assert_eq!(
        pair.master,
        BoundaryRef {
            body: 0,
            tag: tag(0, "zmax")
        }
    );
    assert_eq!((pair.penalty, pair.friction), (30.0, 0.0));
}

#[test]
fn level_sets_every_body() {
    let case = parse(BLOCKS).unwrap();
    let own: Vec<f64> = case.grids(None).unwrap().iter().map(|g| g.h).collect();
    assert_eq!(own, vec![2.0 / 4.0, 1.0 / 8.0]);
    let all: Vec<f64> = case.grids(Some(1)).unwrap().iter().map(|g| g.h).collect();
    assert_eq!(all, vec![1.0, 0.5]);
}

#[test]
fn zero_steps_is_refused() {
    assert_eq!(
        key_of(parse(&BLOCKS.replace("steps = 4", "steps = 0"))),
        "load.steps"
    );
}

#[test]
fn unknown_tag_in_a_pair_is_refused() {
    let text = BLOCKS.replace("master = \"lower.zmax\"", "master = \"lower.top\"");
    assert_eq!(key_of(parse(&text)), "contact[0].master");
    let text = BLOCKS.replace("slave = \"upper.zmin\"", "slave = \"uper.zmin\"");
    assert_eq!(key_of(parse(&text)), "contact[0].slave");
    let text = BLOCKS.replace("slave = \"upper.zmin\"", "slave = \"lower.zmin\"");
    assert_eq!(key_of(parse(&text)), "contact[0]");
}

#[test]
fn overlapping_bodies_are_refused() {
    // The upper block sunk 0.2 into the lower one: 0.2 of its unit volume.
    let text = BLOCKS.replace(
        "0.01], max = [0.5, 0.5, 1.01]",
        "-0.2], max = [0.5, 0.5, 0.8]",
    );
    let err = parse(&text).unwrap_err();
    assert!(err.to_string().contains("overlap"), "{err}");
    assert_eq!(key_of(Err(err)), "body[1].geometry");
    // Allowed when the tolerance says so.
    let text = format!("overlap_tolerance = 0.5\n{text}");
    assert!(parse(&text).is_ok());
}

#[test]
fn other_bad_inputs_name_their_key() {
    let cases = [
        (
            BLOCKS.replace("name = \"upper\"", "name = \"lower\""),
            "body[1].name",
        ),
        (
            BLOCKS.replace("poisson = 0.25", "poisson = 0.5"),
            "body[1].material.poisson",
        ),
        (
            BLOCKS.replace("dirichlet.zmin", "dirichlet.bottom"),
            "body[0].dirichlet.bottom",
        ),
        (
            BLOCKS.replace("\"-0.1*z\"", "\"-0.1*\""),
            "body[1].dirichlet.zmax.value[2]",
        ),
        (
            BLOCKS.replace("model = \"st_venant_kirchhoff\"", "model = \"ogden\""),
            "body[1].material.model",
        ),
        (
            BLOCKS.replace("[load]", "[load]\nsubsteps = 2"),
            "load.substeps",
        ),
        (
            BLOCKS.replace("slave = \"upper.zmin\"", "slave = \"upper\""),
            "contact[0].slave",
        ),
        (format!("{BLOCKS}penalty = -1.0\n"), "contact[0].penalty"),
        (
            BLOCKS.replace("\"-0.1*z\"", "\"exact\""),
            "body[1].dirichlet.zmax.value",
        ),
        (
            BLOCKS.replace("[load]", "[stabilisation]\nbalanced = true\n[load]"),
            "stabilisation.balanced",
        ),
        (
            BLOCKS.replace("\"-0.1*z\"]", "\"-0.1*z\"], ramp = [0.5, 0.5]"),
            "body[1].dirichlet.zmax.ramp",
        ),
        (
            BLOCKS.replace(
                "\"-0.1*z\"]",
                "\"-0.1*z\"], ramp = [[0, 1], [0, 1], [0.2, 1.5]]",
            ),
            "body[1].dirichlet.zmax.ramp",
        ),
        (
            BLOCKS.replace(
                "dirichlet.zmin = { value = [\"0\", \"0\", \"0\"] }",
                "neumann.xmin = { pressure = \"1\", ramp = [1, 0] }\n\
                 dirichlet.zmin = { value = [\"0\", \"0\", \"0\"] }",
            ),
            "body[0].neumann.xmin.ramp",
        ),
    ];
    for (text, key) in cases {
        assert_eq!(key_of(parse(&text)), key, "{text}");
    }
}

#[test]
fn a_ramp_gives_each_component_its_load_path() {
    let text = BLOCKS.replace(
        "\"-0.1*z\"]",
        "\"-0.1*z\"], ramp = [[0.5, 1], [0, 1], [0, 0.25]]",
    );
    let ramps =
        |case: &Case| RampSpec::or_linear(case.bodies[1].spec.dirichlet["zmax"].ramp.as_ref());
    let each = parse(&text).unwrap();
    assert_eq!(ramps(&each), [[0.5, 1.0], [0.0, 1.0], [0.0, 0.25]]);
    let one = parse(&BLOCKS.replace("\"-0.1*z\"]", "\"-0.1*z\"], ramp = [0, 0.5]")).unwrap();
    assert_eq!(ramps(&one), [[0.0, 0.5]; 3]);
    assert_eq!(ramps(&parse(BLOCKS).unwrap()), [[0.0, 1.0]; 3]);
}

#[test]
fn a_case_without_bodies_is_refused() {
    assert_eq!(key_of(parse("name = \"x\"\nbody = []\n")), "body");
    assert_eq!(key_of(parse("name = \"x\"\n")), "(top level)");
}
