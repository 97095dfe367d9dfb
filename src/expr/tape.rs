//! Expression trees compiled once into a tape: a list of operations on
//! numbered slots in evaluation order, shared by several expressions (the
//! components of a vector field), with common subexpressions computed once
//! and constant subtrees folded; and the plan of a tape for one derivative
//! order, which lays out the lanes each slot's components occupy for the
//! batched evaluation of [`super::lanes`].
//!
//! A slot's components are its value, gradient (`∂x ∂y ∂z`) and the upper
//! triangle of its Hessian (`xx xy xz yy yz zz`). A component is *active* when
//! the order asks for it and the slot depends on the variables it
//! differentiates by; an inactive one reads a shared lane of zeros and is
//! never computed. Constants and coordinates occupy lanes filled once per
//! workspace or per batch; each operation's active components occupy a block
//! of lanes after those of its operands.
//!
//! Folding evaluates a constant subtree with the recursive second-order
//! evaluator and keeps the value only where its derivatives are exactly zero
//! (`sqrt(0)` has an infinite derivative, which the recursive evaluator
//! carries into a NaN: such a subtree stays on the tape).

use std::collections::HashMap;

use super::ast::{Node, Op1, Op2};
use super::jet::Jet;

/// Components of a slot: value, gradient, Hessian's upper triangle.
pub(super) const COMPONENTS: usize = 10;

/// The axes `(i, j)`, `i ≤ j`, of the Hessian components `4..10`.
pub(super) const HESSIAN: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];

/// The lane of zeros and the lane of ones, first in every layout.
pub(super) const ZERO: u32 = 0;
pub(super) const ONE: u32 = 1;

/// The derivatives a batched evaluation computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Order {
    /// Values only.
    Value = 0,
    /// Values and gradients.
    Gradient = 1,
    /// Values, gradients and Hessians.
    Hessian = 2,
}

impl Order {
    /// How many of the [`COMPONENTS`] this order computes.
    pub(super) fn components(self) -> usize {
        [1, 4, 10][self as usize]
    }
}

/// The variables component `k` differentiates by, as a bit mask.
fn component_vars(k: usize) -> u8 {
    match k {
        0 => 0,
        1..=3 => 1 << (k - 1),
        _ => {
            let (i, j) = HESSIAN[k - 4];
            (1 << i) | (1 << j)
        }
    }
}

/// An operation of the tape on earlier slots.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Instr {
    Un(Op1, usize),
    /// `a^n` for an exponent that does not vary (the power rule).
    PowConst(usize, f64),
    Bin(Op2, usize, usize),
}

/// What a slot holds.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Source {
    Const(f64),
    Var(usize),
    Op(Instr),
}

/// Identity of a slot's computation, for sharing common subexpressions.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
enum Key {
    Const(u64),
    Var(usize),
    Un(Op1, usize),
    PowConst(usize, u64),
    Bin(Op2, usize, usize),
}

/// Expressions compiled into slots in evaluation order; `outputs[k]` is the
/// slot of the `k`-th expression.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Tape {
    sources: Vec<Source>,
    /// The variables each slot depends on, as a bit mask.
    vars: Vec<u8>,
    outputs: Vec<usize>,
}

impl Tape {
    /// Compiles the trees `roots` into one tape.
    pub(super) fn compile(roots: &[&Node]) -> Tape {
        let mut builder = Builder::default();
        let outputs = roots.iter().map(|r| builder.node(r)).collect();
        Tape {
            sources: builder.sources,
            vars: builder.vars,
            outputs,
        }
    }

    /// How many operations the tape performs (constants and variables aside).
    pub(super) fn operations(&self) -> usize {
        let op = |s: &&Source| matches!(s, Source::Op(_));
        self.sources.iter().filter(op).count()
    }

    /// The lane layout and the steps of an evaluation at `order`.
    pub(super) fn plan(&self, order: Order) -> Plan {
        let n = order.components();
        // Zeros, ones, the coordinates; then constants; then operations.
        let mut lanes = 5u32;
        let coordinates = [2, 3, 4];
        let mut maps = Vec::with_capacity(self.sources.len());
        let mut constants = Vec::new();
        let mut steps = Vec::new();
        for source in &self.sources {
            let mut map = [ZERO; COMPONENTS];
            match *source {
                Source::Const(value) => {
                    map[0] = lanes;
                    constants.push((lanes, value));
                    lanes += 1;
                }
                Source::Var(axis) => {
                    map[0] = coordinates[axis];
                    if n > 1 {
                        map[1 + axis] = ONE;
                    }
                }
                Source::Op(_) => {}
            }
            maps.push(map);
        }
        let first_output = lanes;
        for (slot, source) in self.sources.iter().enumerate() {
            let Source::Op(instr) = *source else {
                continue;
            };
            let mut map = [ZERO; COMPONENTS];
            let mut active = Vec::new();
            for (k, m) in map.iter_mut().enumerate().take(n) {
                if component_vars(k) & !self.vars[slot] == 0 {
                    *m = lanes;
                    active.push(k as u8);
                    lanes += 1;
                }
            }
            let operand = |s: usize| maps[s];
            let (a, b) = match instr {
                Instr::Un(_, a) | Instr::PowConst(a, _) => (operand(a), [ZERO; COMPONENTS]),
                Instr::Bin(_, a, b) => (operand(a), operand(b)),
            };
            steps.push(Step {
                instr,
                a,
                b,
                out: map,
                active,
            });
            maps[slot] = map;
        }
        Plan {
            order,
            lanes: lanes as usize,
            first_output,
            coordinates,
            constants,
            steps,
            outputs: self.outputs.iter().map(|&s| maps[s]).collect(),
        }
    }
}

/// One operation of a plan: its operands' and its own lanes per component,
/// and its active components in increasing order.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Step {
    pub instr: Instr,
    pub a: [u32; COMPONENTS],
    pub b: [u32; COMPONENTS],
    pub out: [u32; COMPONENTS],
    pub active: Vec<u8>,
}

/// A tape laid out for one order: lanes `0..first_output` are read-only
/// during the steps (zeros, ones, coordinates, constants), each step writes
/// its own lanes after those.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Plan {
    pub order: Order,
    pub lanes: usize,
    pub first_output: u32,
    pub coordinates: [u32; 3],
    pub constants: Vec<(u32, f64)>,
    pub steps: Vec<Step>,
    /// The lane of each component of each output.
    pub outputs: Vec<[u32; COMPONENTS]>,
}

#[derive(Default)]
struct Builder {
    sources: Vec<Source>,
    vars: Vec<u8>,
    seen: HashMap<Key, usize>,
}

impl Builder {
    /// The slot computing `key`, added with `source` if new.
    fn slot(&mut self, key: Key, source: Source, vars: u8) -> usize {
        *self.seen.entry(key).or_insert_with(|| {
            self.sources.push(source);
            self.vars.push(vars);
            self.sources.len() - 1
        })
    }

    fn constant(&mut self, value: f64) -> usize {
        self.slot(Key::Const(value.to_bits()), Source::Const(value), 0)
    }

    fn node(&mut self, node: &Node) -> usize {
        if node.is_constant() {
            let jet: Jet = node.eval([0.0; 3]);
            let zero = |d: &f64| *d == 0.0;
            if jet.grad.iter().all(zero) && jet.hess.iter().flatten().all(zero) {
                return self.constant(jet.value);
            }
        }
        match node {
            Node::Num(_) | Node::Const(_) => self.constant(node.eval([0.0; 3])),
            Node::Var(axis) => self.slot(Key::Var(*axis), Source::Var(*axis), 1 << axis),
            Node::Un(op, a) => {
                let a = self.node(a);
                let vars = self.vars[a];
                self.slot(Key::Un(*op, a), Source::Op(Instr::Un(*op, a)), vars)
            }
            Node::Bin(op, a, b) => {
                let (a, b) = (self.node(a), self.node(b));
                let vars = self.vars[a] | self.vars[b];
                match (op, self.sources[b]) {
                    (Op2::Pow, Source::Const(n)) => {
                        let instr = Instr::PowConst(a, n);
                        self.slot(Key::PowConst(a, n.to_bits()), Source::Op(instr), vars)
                    }
                    _ => self.slot(Key::Bin(*op, a, b), Source::Op(Instr::Bin(*op, a, b)), vars),
                }
            }
        }
    }
}
