//! The expression tree: nodes, operators and the function table, evaluation
//! over any [`Scalar`] (plain numbers or second-order jets) and the fully
//! parenthesised printing that parses back to the same tree.

use std::fmt;

/// Names of the variables, indexed by axis.
pub(super) const VARIABLES: [&str; 3] = ["x", "y", "z"];

/// Named constants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Constant {
    Pi,
    E,
}

impl Constant {
    /// The constant spelled `name`, if any.
    pub(super) fn named(name: &str) -> Option<Constant> {
        match name {
            "pi" => Some(Constant::Pi),
            "e" => Some(Constant::E),
            _ => None,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Constant::Pi => "pi",
            Constant::E => "e",
        }
    }

    fn value(self) -> f64 {
        match self {
            Constant::Pi => std::f64::consts::PI,
            Constant::E => std::f64::consts::E,
        }
    }
}

/// One-operand operations: negation and the one-argument functions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Op1 {
    Neg,
    Sin,
    Cos,
    Tan,
    Exp,
    Log,
    Sqrt,
    Abs,
    Sinh,
    Cosh,
    Tanh,
    Atan,
}

impl Op1 {
    /// The one-argument functions, in the order the error messages list them.
    const FUNCTIONS: [Op1; 11] = [
        Op1::Sin,
        Op1::Cos,
        Op1::Tan,
        Op1::Exp,
        Op1::Log,
        Op1::Sqrt,
        Op1::Abs,
        Op1::Sinh,
        Op1::Cosh,
        Op1::Tanh,
        Op1::Atan,
    ];

    fn name(self) -> &'static str {
        match self {
            Op1::Neg => "-",
            Op1::Sin => "sin",
            Op1::Cos => "cos",
            Op1::Tan => "tan",
            Op1::Exp => "exp",
            Op1::Log => "log",
            Op1::Sqrt => "sqrt",
            Op1::Abs => "abs",
            Op1::Sinh => "sinh",
            Op1::Cosh => "cosh",
            Op1::Tanh => "tanh",
            Op1::Atan => "atan",
        }
    }
}

/// Two-operand operations: the arithmetic operators and the two-argument
/// functions (`pow` is `^`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Op2 {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Atan2,
    Min,
    Max,
}

impl Op2 {
    /// The two-argument functions, in the order the error messages list them.
    const FUNCTIONS: [Op2; 4] = [Op2::Atan2, Op2::Min, Op2::Max, Op2::Pow];

    fn name(self) -> &'static str {
        match self {
            Op2::Add => "+",
            Op2::Sub => "-",
            Op2::Mul => "*",
            Op2::Div => "/",
            Op2::Pow => "pow",
            Op2::Atan2 => "atan2",
            Op2::Min => "min",
            Op2::Max => "max",
        }
    }

    /// The infix symbol, for the operators printed between their operands.
    fn infix(self) -> Option<&'static str> {
        match self {
            Op2::Pow => Some("^"),
            Op2::Add | Op2::Sub | Op2::Mul | Op2::Div => Some(self.name()),
            Op2::Atan2 | Op2::Min | Op2::Max => None,
        }
    }
}

/// A function callable by name, with its number of arguments.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Function {
    One(Op1),
    Two(Op2),
}

impl Function {
    /// The function called `name`, if any.
    pub(super) fn named(name: &str) -> Option<Function> {
        let one = Op1::FUNCTIONS.into_iter().map(Function::One);
        let two = Op2::FUNCTIONS.into_iter().map(Function::Two);
        one.chain(two).find(|f| f.name() == name)
    }

    /// All function names, comma separated, for error messages.
    pub(super) fn all_names() -> String {
        let one = Op1::FUNCTIONS.into_iter().map(Op1::name);
        let two = Op2::FUNCTIONS.into_iter().map(Op2::name);
        one.chain(two).collect::<Vec<_>>().join(", ")
    }

    pub(super) fn name(self) -> &'static str {
        match self {
            Function::One(op) => op.name(),
            Function::Two(op) => op.name(),
        }
    }

    pub(super) fn arity(self) -> usize {
        match self {
            Function::One(_) => 1,
            Function::Two(_) => 2,
        }
    }
}

/// A node of the expression tree.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Node {
    /// A finite, non-negative literal (the parser makes signs [`Op1::Neg`]).
    Num(f64),
    Const(Constant),
    /// A coordinate, by axis.
    Var(usize),
    Un(Op1, Box<Node>),
    Bin(Op2, Box<Node>, Box<Node>),
}

/// Numbers an expression can be evaluated over.
pub(super) trait Scalar: Copy {
    fn constant(value: f64) -> Self;
    /// Coordinate `axis` of the point `x`.
    fn variable(x: [f64; 3], axis: usize) -> Self;
    fn unary(self, op: Op1) -> Self;
    fn binary(self, op: Op2, rhs: Self) -> Self;
}

impl Node {
    /// The value of the tree at `x`, over the scalar type `S`.
    pub(super) fn eval<S: Scalar>(&self, x: [f64; 3]) -> S {
        match self {
            Node::Num(value) => S::constant(*value),
            Node::Const(c) => S::constant(c.value()),
            Node::Var(axis) => S::variable(x, *axis),
            Node::Un(op, a) => a.eval::<S>(x).unary(*op),
            Node::Bin(op, a, b) => a.eval::<S>(x).binary(*op, b.eval(x)),
        }
    }

    /// Whether no variable occurs in the tree.
    pub(super) fn is_constant(&self) -> bool {
        match self {
            Node::Num(_) | Node::Const(_) => true,
            Node::Var(_) => false,
            Node::Un(_, a) => a.is_constant(),
            Node::Bin(_, a, b) => a.is_constant() && b.is_constant(),
        }
    }
}

/// Prints every operation in parentheses, so that parsing the text gives the
/// same tree back.
impl fmt::Display for Node {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Node::Num(value) => write_number(f, *value),
            Node::Const(c) => f.write_str(c.name()),
            Node::Var(axis) => f.write_str(VARIABLES[*axis]),
            Node::Un(Op1::Neg, a) => write!(f, "(-{a})"),
            Node::Un(op, a) => write!(f, "{}({a})", op.name()),
            Node::Bin(op, a, b) => match op.infix() {
                Some(symbol) => write!(f, "({a} {symbol} {b})"),
                None => write!(f, "{}({a}, {b})", op.name()),
            },
        }
    }
}

/// Shortest text that reads back as exactly `value`: positional for moderate
/// magnitudes, scientific otherwise.
fn write_number(f: &mut fmt::Formatter<'_>, value: f64) -> fmt::Result {
    if value == 0.0 || (1e-4..1e16).contains(&value.abs()) {
        write!(f, "{value}")
    } else {
        write!(f, "{value:e}")
    }
}
