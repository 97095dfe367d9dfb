//! Parsing and evaluation of expressions with known values, and
//! deserialisation from TOML.

use std::f64::consts::{E, PI};

use serde::Deserialize;

use super::parsed;
use crate::expr::{Expr, VectorExpr};

const P: [f64; 3] = [3.0, -2.0, 0.5];

#[test]
fn table_of_values() {
    let table: &[(&str, f64)] = &[
        ("1", 1.0),
        ("2.5", 2.5),
        (".5", 0.5),
        ("5.", 5.0),
        ("1.5e3", 1500.0),
        ("2.5E-1", 0.25),
        ("1e+2", 100.0),
        ("x", 3.0),
        ("y", -2.0),
        ("z", 0.5),
        ("pi", PI),
        ("e", E),
        ("1 + 2 * 3", 7.0),
        ("(1 + 2) * 3", 9.0),
        ("1 - 2 - 3", -4.0),
        ("8 / 4 / 2", 1.0),
        ("2 * 3 / 4 * 5", 7.5),
        ("2^3^2", 512.0),
        ("(2^3)^2", 64.0),
        ("-2^2", -4.0),
        ("(-2)^2", 4.0),
        ("-x^2", -9.0),
        ("2^-1", 0.5),
        ("2^-x", 0.125),
        ("-x * -y", -6.0),
        ("x - -y", 1.0),
        ("--x", 3.0),
        ("+x", 3.0),
        ("-+-x", 3.0),
        ("2*-x", -6.0),
        ("y^3", -8.0),
        ("y^-2", 0.25),
        ("x^0.5", 3f64.sqrt()),
        (
            "x + x^2 - 2*x*y + x^3 - 3*x*y^2 + x^2*y",
            3.0 + 9.0 + 12.0 + 27.0 - 36.0 - 18.0,
        ),
        ("sin(pi / 2)", 1.0),
        ("cos(0)", 1.0),
        ("tan(pi / 4)", 1.0),
        ("exp(1)", E),
        ("log(e^2)", 2.0),
        ("sqrt(16)", 4.0),
        ("abs(y)", 2.0),
        ("sinh(0)", 0.0),
        ("cosh(0)", 1.0),
        ("tanh(0)", 0.0),
        ("atan(1) * 4", PI),
        ("atan2(1, 1)", PI / 4.0),
        ("atan2(1, -1)", 3.0 * PI / 4.0),
        ("min(x, y)", -2.0),
        ("max(x, y)", 3.0),
        ("pow(2, 10)", 1024.0),
        ("pow(y, 3)", -8.0),
        ("max(min(x, 1), y) + sqrt(abs(y) * 8)", 5.0),
        ("  x\t+\n y  ", 1.0),
        ("z*(x+y)", 0.5),
    ];
    for &(src, expected) in table {
        let value = parsed(src).eval(P);
        let tol = 1e-14 * expected.abs().max(1.0);
        assert!(
            (value - expected).abs() <= tol,
            "{src}: got {value}, expected {expected}"
        );
    }
}

#[test]
fn precedence_shapes_the_tree() {
    assert_eq!(parsed("-x^2"), parsed("-(x^2)"));
    assert_ne!(parsed("-x^2"), parsed("(-x)^2"));
    assert_eq!(parsed("2^3^4"), parsed("2^(3^4)"));
    assert_eq!(parsed("1-2-3"), parsed("(1-2)-3"));
    assert_eq!(parsed("1+2*3^4"), parsed("1+(2*(3^4))"));
    assert_eq!(parsed("pow(x, y)"), parsed("x^y"));
    assert_eq!(parsed("+x"), parsed("x"));
}

#[test]
fn display_is_fully_parenthesised() {
    let cases = [
        ("-x^2", "(-(x ^ 2))"),
        ("1 - 2 - 3", "((1 - 2) - 3)"),
        ("2^3^2", "(2 ^ (3 ^ 2))"),
        ("atan2(y, x) + sin(pi*z)", "(atan2(y, x) + sin((pi * z)))"),
        ("1e-7 * 2.5e20 + e", "((1e-7 * 2.5e20) + e)"),
        ("pow(x, 2)", "(x ^ 2)"),
    ];
    for (src, shown) in cases {
        assert_eq!(parsed(src).to_string(), shown, "{src}");
    }
}

#[test]
fn source_and_constancy() {
    let e = parsed(" x + 1 ");
    assert_eq!(e.source(), " x + 1 ");
    assert_eq!(e, parsed("x+1"));
    assert!(!e.is_constant());
    assert!(parsed("2 * pi + sin(e)").is_constant());
    assert!(!parsed("max(1, z)").is_constant());
}

#[test]
fn constants_from_numbers() {
    let c = Expr::constant(-2.5).unwrap();
    assert_eq!(c.eval(P), -2.5);
    assert!(c.is_constant());
    assert_eq!(c, parsed("-2.5"));
    assert!(Expr::constant(f64::NAN).is_err());
    assert!(Expr::constant(f64::INFINITY).is_err());
}

#[derive(Debug, Deserialize)]
struct Case {
    #[serde(rename = "E")]
    young: Expr,
    nu: Expr,
    load: Expr,
    u: VectorExpr,
}

#[test]
fn deserialises_from_toml_strings_and_numbers() {
    let case: Case = toml::from_str(
        r#"
        E = 1000
        nu = 0.3
        load = "-x^2 + 2*y"
        u = ["x + y", 0, "sin(z)"]
        "#,
    )
    .unwrap();
    assert_eq!(case.young.eval(P), 1000.0);
    assert_eq!(case.nu.eval(P), 0.3);
    assert_eq!(case.load.eval(P), -13.0);
    assert_eq!(case.load.source(), "-x^2 + 2*y");
    assert_eq!(case.u.eval(P), [1.0, 0.0, 0.5f64.sin()]);
}

#[test]
fn toml_reports_parse_errors_with_their_message() {
    let err = toml::from_str::<Case>(
        r#"
        E = 1
        nu = 0.3
        load = "x + w"
        u = ["x", "y", "z"]
        "#,
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("cannot parse expression 'x + w' at 4: unknown variable 'w'; use x, y, z"),
        "{err}"
    );
}

#[test]
fn vector_needs_three_components() {
    #[derive(Deserialize)]
    struct V {
        u: VectorExpr,
    }
    let read = |text: &str| toml::from_str::<V>(text).map(|v| v.u.eval(P));
    assert_eq!(read(r#"u = ["x", "y", 1.5]"#).unwrap(), [3.0, -2.0, 1.5]);
    assert!(read(r#"u = ["x", "y"]"#).is_err());
    let err = read(r#"u = ["x", "y", "z", "x"]"#).unwrap_err().to_string();
    assert!(err.contains("a vector needs 3 components, got 4"), "{err}");
    assert!(read(r#"u = ["x", "y", true]"#).is_err());
}
