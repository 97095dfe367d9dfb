//! Analytic expressions in the coordinates `x`, `y`, `z`, as case files give
//! loads, Dirichlet data and exact displacement fields: parsing with typed,
//! positioned errors, evaluation, exact first and second derivatives by
//! forward-mode automatic differentiation, and deserialisation from TOML
//! strings or numbers.
//!
//! Grammar: decimal and scientific literals, `x y z`, `pi e`, `+ - * /`, `^`
//! (right-associative, binding tighter than unary minus: `-x^2 = -(x^2)`),
//! unary `-` and `+`, parentheses, the functions `sin cos tan exp log sqrt abs
//! sinh cosh tanh atan` of one argument and `atan2 min max pow` of two.
//! Submodules: `ast` (tree, printing), `lexer`, `parser`, `functions`
//! (scalar maths), `dual` (first-order AD), `jet` (second-order AD),
//! `tape` (trees compiled into a tape of operations on slots), `lanes` (the
//! tape evaluated over batches of points, values and derivatives) and
//! `elasticity` (vector fields and the derived stress and body load, point by
//! point and in batches).
//!
//! The recursive evaluation of the tree ([`Expr::eval`] and the AD types) is
//! the reference, and the faster one for a single point; callers with many
//! points compile a [`VectorTape`] once and evaluate it in batches.

mod ast;
mod dual;
mod elasticity;
mod functions;
mod jet;
mod lanes;
mod lexer;
mod parser;
mod tape;
#[cfg(test)]
mod tests;

use std::fmt;

use serde::de::{self, Deserialize, Deserializer, Visitor};

use crate::error::{Error, Result};
use ast::{Node, Op1};
use dual::Dual;
use jet::Jet;

pub use elasticity::{
    body_load_from_displacement, stress_from_displacement, VectorExpr, VectorTape,
};

/// A parsed expression in `x`, `y`, `z`, with the text it came from.
///
/// Equality compares the trees, not the spelling: `x+1 == x + 1`. [`Display`]
/// prints the fully parenthesised tree, which parses back to an equal
/// expression; [`Expr::source`] gives the original text.
///
/// [`Display`]: fmt::Display
#[derive(Clone, Debug)]
pub struct Expr {
    source: String,
    root: Node,
}

impl Expr {
    /// Parses `src`; errors are [`Error::Expression`] with the byte position.
    pub fn parse(src: &str) -> Result<Expr> {
        Ok(Expr {
            source: src.to_string(),
            root: parser::parse(src)?,
        })
    }

    /// The constant expression `value`, which must be finite.
    pub fn constant(value: f64) -> Result<Expr> {
        let source = value.to_string();
        if !value.is_finite() {
            return Err(expression_error(&source, 0, "not a finite number"));
        }
        let magnitude = Node::Num(value.abs());
        let root = if value.is_sign_negative() {
            Node::Un(Op1::Neg, Box::new(magnitude))
        } else {
            magnitude
        };
        Ok(Expr { source, root })
    }

    /// The value at `x`.
    pub fn eval(&self, x: [f64; 3]) -> f64 {
        self.root.eval(x)
    }

    /// Value and gradient at `x` (forward-mode first-order automatic
    /// differentiation), equal to [`Expr::eval_hessian`]'s bit for bit at
    /// about 40% of its cost (160 against 390 ns for the paper's `u_x`).
    pub fn eval_gradient(&self, x: [f64; 3]) -> (f64, [f64; 3]) {
        let dual: Dual = self.root.eval(x);
        (dual.value, dual.grad)
    }

    /// Value, gradient and Hessian at `x`, exact up to rounding (forward-mode
    /// second-order automatic differentiation). The value equals
    /// [`Expr::eval`]'s bit for bit.
    pub fn eval_hessian(&self, x: [f64; 3]) -> (f64, [f64; 3], [[f64; 3]; 3]) {
        let jet: Jet = self.root.eval(x);
        (jet.value, jet.grad, jet.hess)
    }

    /// Whether the expression contains no variable.
    pub fn is_constant(&self) -> bool {
        self.root.is_constant()
    }

    /// The text the expression was parsed from.
    pub fn source(&self) -> &str {
        &self.source
    }
}

impl PartialEq for Expr {
    fn eq(&self, other: &Expr) -> bool {
        self.root == other.root
    }
}

impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.root.fmt(f)
    }
}

/// Reads an expression from a string (parsed) or a number (a constant);
/// parse errors surface with their message.
impl<'de> Deserialize<'de> for Expr {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Expr, D::Error> {
        deserializer.deserialize_any(ExprVisitor)
    }
}

struct ExprVisitor;

impl Visitor<'_> for ExprVisitor {
    type Value = Expr;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("an expression in x, y, z (a string) or a number")
    }

    fn visit_str<E: de::Error>(self, v: &str) -> std::result::Result<Expr, E> {
        Expr::parse(v).map_err(E::custom)
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<Expr, E> {
        Expr::constant(v).map_err(E::custom)
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Expr, E> {
        self.visit_f64(v as f64)
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Expr, E> {
        self.visit_f64(v as f64)
    }
}

/// The error for `src` at byte `position`.
fn expression_error(src: &str, position: usize, reason: impl Into<String>) -> Error {
    Error::Expression {
        expr: src.to_string(),
        position,
        reason: reason.into(),
    }
}
