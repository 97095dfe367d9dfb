//! Recursive-descent parser from tokens to the expression tree.
//!
//! ```text
//! sum     := product (('+' | '-') product)*
//! product := unary (('*' | '/') unary)*
//! unary   := ('-' | '+') unary | power
//! power   := primary ('^' unary)?          (right-associative, above unary minus)
//! primary := number | constant | variable | function '(' args ')' | '(' sum ')'
//! ```
//!
//! Errors carry the byte position of the offending token. The tree depth and
//! the recursion are bounded so that neither parsing nor evaluation can
//! overflow the stack.

use super::ast::{Constant, Function, Node, Op1, Op2, VARIABLES};
use super::expression_error;
use super::lexer::{tokenize, Kind, Token};
use crate::error::{Error, Result};

/// Deepest tree accepted (a sum of more terms than this is too deep).
pub(super) const MAX_DEPTH: usize = 256;
/// Deepest recursion accepted: the printed form of a tree of depth `d` nests
/// at most `2 d + 1` levels, so every accepted tree prints to parsable text.
const MAX_NESTING: usize = 2 * MAX_DEPTH + 1;

/// The tree of `src`.
pub(super) fn parse(src: &str) -> Result<Node> {
    let tokens = tokenize(src)?;
    let mut parser = Parser {
        src,
        tokens,
        next: 0,
        nesting: 0,
    };
    if parser.peek().kind == Kind::End {
        return Err(parser.fail(0, "empty expression".into()));
    }
    let tree = parser.sum()?;
    parser.finish()?;
    Ok(tree.node)
}

/// A parsed subtree and its depth.
struct Parsed {
    node: Node,
    depth: usize,
}

impl Parsed {
    fn leaf(node: Node) -> Parsed {
        Parsed { node, depth: 1 }
    }
}

struct Parser<'a> {
    src: &'a str,
    tokens: Vec<Token<'a>>,
    next: usize,
    nesting: usize,
}

impl<'a> Parser<'a> {
    fn peek(&self) -> Token<'a> {
        self.tokens[self.next]
    }

    /// The next token, consumed (the end marker is never passed).
    fn bump(&mut self) -> Token<'a> {
        let token = self.peek();
        if token.kind != Kind::End {
            self.next += 1;
        }
        token
    }

    fn fail(&self, pos: usize, reason: String) -> Error {
        expression_error(self.src, pos, reason)
    }

    /// `op(a)`, within the depth limit.
    fn unary_node(&self, op: Op1, a: Parsed, pos: usize) -> Result<Parsed> {
        self.checked(Node::Un(op, Box::new(a.node)), a.depth + 1, pos)
    }

    /// `op(a, b)`, within the depth limit.
    fn binary_node(&self, op: Op2, a: Parsed, b: Parsed, pos: usize) -> Result<Parsed> {
        let depth = a.depth.max(b.depth) + 1;
        self.checked(
            Node::Bin(op, Box::new(a.node), Box::new(b.node)),
            depth,
            pos,
        )
    }

    fn checked(&self, node: Node, depth: usize, pos: usize) -> Result<Parsed> {
        if depth > MAX_DEPTH {
            return Err(self.too_deep(pos));
        }
        Ok(Parsed { node, depth })
    }

    fn too_deep(&self, pos: usize) -> Error {
        self.fail(
            pos,
            format!("expression nested deeper than {MAX_DEPTH} levels"),
        )
    }

    fn sum(&mut self) -> Result<Parsed> {
        self.left_chain(Parser::product, |s| match s {
            b'+' => Some(Op2::Add),
            b'-' => Some(Op2::Sub),
            _ => None,
        })
    }

    fn product(&mut self) -> Result<Parsed> {
        self.left_chain(Parser::unary, |s| match s {
            b'*' => Some(Op2::Mul),
            b'/' => Some(Op2::Div),
            _ => None,
        })
    }

    /// `operand (op operand)*`, associating to the left.
    fn left_chain(
        &mut self,
        operand: fn(&mut Self) -> Result<Parsed>,
        op_of: fn(u8) -> Option<Op2>,
    ) -> Result<Parsed> {
        let mut lhs = operand(self)?;
        loop {
            let token = self.peek();
            let Some(op) = symbol(token).and_then(op_of) else {
                return Ok(lhs);
            };
            self.bump();
            let rhs = operand(self)?;
            lhs = self.binary_node(op, lhs, rhs, token.pos)?;
        }
    }

    fn unary(&mut self) -> Result<Parsed> {
        let token = self.peek();
        self.nesting += 1;
        if self.nesting > MAX_NESTING {
            return Err(self.too_deep(token.pos));
        }
        let parsed = match symbol(token) {
            Some(b'-') => {
                self.bump();
                let operand = self.unary()?;
                self.unary_node(Op1::Neg, operand, token.pos)
            }
            Some(b'+') => {
                self.bump();
                self.unary()
            }
            _ => self.power(),
        };
        self.nesting -= 1;
        parsed
    }

    fn power(&mut self) -> Result<Parsed> {
        let base = self.primary()?;
        let token = self.peek();
        if symbol(token) != Some(b'^') {
            return Ok(base);
        }
        self.bump();
        let exponent = self.unary()?;
        self.binary_node(Op2::Pow, base, exponent, token.pos)
    }

    fn primary(&mut self) -> Result<Parsed> {
        let token = self.bump();
        match token.kind {
            Kind::Number(value) => Ok(Parsed::leaf(Node::Num(value))),
            Kind::Name if symbol(self.peek()) == Some(b'(') => self.call(token),
            Kind::Name => self.name(token),
            Kind::Symbol(b'(') => {
                let inner = self.sum()?;
                self.close(token)?;
                Ok(inner)
            }
            _ => Err(self.fail(
                token.pos,
                format!(
                    "unexpected {}: expected a number, variable, function or '('",
                    token.describe()
                ),
            )),
        }
    }

    /// A variable or constant.
    fn name(&self, token: Token) -> Result<Parsed> {
        if let Some(axis) = VARIABLES.iter().position(|&v| v == token.text) {
            return Ok(Parsed::leaf(Node::Var(axis)));
        }
        if let Some(c) = Constant::named(token.text) {
            return Ok(Parsed::leaf(Node::Const(c)));
        }
        let reason = match Function::named(token.text) {
            Some(f) => format!("function '{}' needs its arguments in parentheses", f.name()),
            None => format!("unknown variable '{}'; use x, y, z", token.text),
        };
        Err(self.fail(token.pos, reason))
    }

    /// A function call; the next token is its '('.
    fn call(&mut self, name: Token) -> Result<Parsed> {
        let Some(function) = Function::named(name.text) else {
            return Err(self.fail(name.pos, not_a_function(name.text)));
        };
        let open = self.bump();
        let args = self.arguments(function, open)?;
        let arity_error = |got: usize| {
            let plural = if function.arity() == 1 { "" } else { "s" };
            let reason = format!(
                "'{}' takes {} argument{plural}, got {got}",
                function.name(),
                function.arity()
            );
            self.fail(name.pos, reason)
        };
        match function {
            Function::One(op) => match <[Parsed; 1]>::try_from(args) {
                Ok([a]) => self.unary_node(op, a, name.pos),
                Err(args) => Err(arity_error(args.len())),
            },
            Function::Two(op) => match <[Parsed; 2]>::try_from(args) {
                Ok([a, b]) => self.binary_node(op, a, b, name.pos),
                Err(args) => Err(arity_error(args.len())),
            },
        }
    }

    /// The comma-separated arguments up to and including the ')'.
    fn arguments(&mut self, function: Function, open: Token) -> Result<Vec<Parsed>> {
        let mut args = Vec::new();
        if symbol(self.peek()) == Some(b')') {
            self.bump();
            return Ok(args);
        }
        loop {
            args.push(self.sum()?);
            let token = self.bump();
            match token.kind {
                Kind::Symbol(b',') => continue,
                Kind::Symbol(b')') => return Ok(args),
                Kind::End => return Err(self.unclosed(token, open)),
                _ => {
                    let reason = format!(
                        "unexpected {}: expected ',' or ')' in the arguments of '{}'",
                        token.describe(),
                        function.name()
                    );
                    return Err(self.fail(token.pos, reason));
                }
            }
        }
    }

    /// Consumes the ')' matching `open`.
    fn close(&mut self, open: Token) -> Result<()> {
        let token = self.bump();
        match token.kind {
            Kind::Symbol(b')') => Ok(()),
            Kind::End => Err(self.unclosed(token, open)),
            _ => {
                let reason = format!(
                    "unexpected {}: expected ')' to close '(' at {}",
                    token.describe(),
                    open.pos
                );
                Err(self.fail(token.pos, reason))
            }
        }
    }

    fn unclosed(&self, end: Token, open: Token) -> Error {
        let reason = format!("unexpected end: '(' at {} is never closed", open.pos);
        self.fail(end.pos, reason)
    }

    /// Checks that all tokens were used.
    fn finish(&self) -> Result<()> {
        let token = self.peek();
        let reason = match token.kind {
            Kind::End => return Ok(()),
            Kind::Symbol(b')') => "unmatched ')'".to_string(),
            _ => format!(
                "unexpected {}: expected an operator or the end",
                token.describe()
            ),
        };
        Err(self.fail(token.pos, reason))
    }
}

/// The symbol byte of `token`, if it is a symbol.
fn symbol(token: Token) -> Option<u8> {
    match token.kind {
        Kind::Symbol(s) => Some(s),
        _ => None,
    }
}

/// Why the name before a '(' cannot be called.
fn not_a_function(name: &str) -> String {
    if VARIABLES.contains(&name) || Constant::named(name).is_some() {
        format!("'{name}' is not a function; write {name}*(...) to multiply")
    } else {
        format!(
            "unknown function '{name}'; known: {}",
            Function::all_names()
        )
    }
}
