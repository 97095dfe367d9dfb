//! Every malformed expression is an [`Error::Expression`] at the right byte
//! position with the right reason, never a panic.

use crate::error::Error;
use crate::expr::Expr;

/// The position and reason of the error parsing `src`.
fn failure(src: &str) -> (usize, String) {
    match Expr::parse(src) {
        Err(Error::Expression {
            expr,
            position,
            reason,
        }) => {
            assert_eq!(expr, src);
            (position, reason)
        }
        Err(other) => panic!("{src:?}: wrong error kind {other:?}"),
        Ok(e) => panic!("{src:?} should not parse, got {e}"),
    }
}

#[test]
fn errors_have_positions_and_reasons() {
    let cases: &[(&str, usize, &str)] = &[
        ("", 0, "empty expression"),
        ("   ", 0, "empty expression"),
        ("x + 2*y + w", 10, "unknown variable 'w'; use x, y, z"),
        ("X", 0, "unknown variable 'X'"),
        ("x2 + 1", 0, "unknown variable 'x2'"),
        ("(x + 1", 6, "unexpected end: '(' at 0 is never closed"),
        ("((x) + 1", 8, "'(' at 0 is never closed"),
        ("x + 1)", 5, "unmatched ')'"),
        ("(x y)", 3, "unexpected 'y': expected ')' to close '(' at 0"),
        (
            "2 +",
            3,
            "unexpected end: expected a number, variable, function or '('",
        ),
        ("2 * * 3", 4, "unexpected '*': expected a number"),
        ("x ^ ^ 2", 4, "unexpected '^'"),
        ("()", 1, "unexpected ')'"),
        ("x y", 2, "unexpected 'y': expected an operator or the end"),
        ("2 3", 2, "unexpected '3'"),
        ("1e", 1, "unexpected 'e'"),
        ("2..3", 2, "unexpected '.3'"),
        ("x $ y", 2, "unexpected character '$'"),
        ("x + é", 4, "unexpected character 'é'"),
        ("é + x", 0, "unexpected character 'é'"),
        ("1e999", 0, "number '1e999' is too large to be finite"),
        ("x + 1e400", 4, "is too large to be finite"),
        (
            "foo(x)",
            0,
            "unknown function 'foo'; known: sin, cos, tan, exp, log",
        ),
        (
            "1 + x(2)",
            4,
            "'x' is not a function; write x*(...) to multiply",
        ),
        ("pi(2)", 0, "'pi' is not a function"),
        ("max(x)", 0, "'max' takes 2 arguments, got 1"),
        ("2 * sin(x, y)", 4, "'sin' takes 1 argument, got 2"),
        ("atan2()", 0, "'atan2' takes 2 arguments, got 0"),
        ("min(1, 2, 3)", 0, "'min' takes 2 arguments, got 3"),
        (
            "sin x",
            0,
            "function 'sin' needs its arguments in parentheses",
        ),
        (
            "sin",
            0,
            "function 'sin' needs its arguments in parentheses",
        ),
        ("sqrt(x", 6, "unexpected end: '(' at 4 is never closed"),
        (
            "max(x y)",
            6,
            "unexpected 'y': expected ',' or ')' in the arguments of 'max'",
        ),
        ("max(x,)", 6, "unexpected ')': expected a number"),
        (",", 0, "unexpected ','"),
        ("x, y", 1, "unexpected ','"),
    ];
    for &(src, position, reason) in cases {
        let (got_position, got_reason) = failure(src);
        assert_eq!(got_position, position, "{src:?}: {got_reason}");
        assert!(
            got_reason.contains(reason),
            "{src:?}: reason {got_reason:?} lacks {reason:?}"
        );
    }
}

#[test]
fn error_message_names_expression_and_position() {
    let message = Expr::parse("x + 2*y + w").unwrap_err().to_string();
    assert_eq!(
        message,
        "cannot parse expression 'x + 2*y + w' at 10: unknown variable 'w'; use x, y, z"
    );
    assert_eq!(Expr::parse("w").unwrap_err().exit_code(), 2);
}

#[test]
fn nesting_is_bounded_without_overflowing_the_stack() {
    let deep = format!("{}x{}", "(".repeat(100_000), ")".repeat(100_000));
    let (_, reason) = failure(&deep);
    assert!(reason.contains("nested deeper than"), "{reason}");
    let (_, reason) = failure(&format!("{}x", "-".repeat(100_000)));
    assert!(reason.contains("nested deeper than"), "{reason}");
    let (_, reason) = failure(&vec!["x"; 100_000].join(" + "));
    assert!(reason.contains("nested deeper than"), "{reason}");
    let (_, reason) = failure(&format!("{}x", "sin(".repeat(100_000)));
    assert!(reason.contains("nested deeper than"), "{reason}");
}

#[test]
fn moderate_nesting_is_accepted() {
    let src = format!("{}x{}", "(".repeat(200), ")".repeat(200));
    assert_eq!(Expr::parse(&src).unwrap().eval([2.0, 0.0, 0.0]), 2.0);
    let sum = vec!["x"; 200].join(" + ");
    assert_eq!(Expr::parse(&sum).unwrap().eval([1.0, 0.0, 0.0]), 200.0);
}
