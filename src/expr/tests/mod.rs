//! Tests of the expression module: parsing and evaluation, errors, exact
//! derivatives against finite differences, the elasticity helpers, and a fuzz
//! of the parser and the printer, and the batched tape against the recursive
//! evaluator.

mod derivatives;
mod elasticity;
mod errors;
mod fuzz;
mod parsing;
mod tape;

use super::Expr;

/// Parses `src`, failing the test with the error if it does not parse.
fn parsed(src: &str) -> Expr {
    Expr::parse(src).unwrap_or_else(|e| panic!("{src:?} should parse: {e}"))
}
