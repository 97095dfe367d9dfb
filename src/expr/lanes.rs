//! Batched evaluation of a tape's [`Plan`]: each step runs over [`LANES`]
//! points at once, every component of every slot an array of lanes, so that
//! each rule is a short loop the compiler vectorises (with AVX2 where the CPU
//! has it).
//!
//! The rules are [`super::dual`]'s and [`super::jet`]'s, lane by lane, with
//! the same operations in the same order, so the values equal the recursive
//! evaluator's bit for bit, and so do the derivatives wherever the recursive
//! evaluator's are finite, but for the sign of a zero. The exceptions all
//! drop a term the recursive evaluator adds as `0 · d`: an inactive component
//! (a derivative by a variable the slot does not depend on), the zero second
//! partials of a product. Where `d` is infinite or NaN the recursive
//! evaluator's derivative is NaN and the batched one is not.

use super::ast::{Op1, Op2};
use super::functions::{
    atan2_partials, div_partials, pow_partials, power_rule, Partials, MAX_POWI,
};
use super::tape::{Instr, Order, Plan, Step, HESSIAN, ONE};

/// Points per batch.
pub(super) const LANES: usize = 64;

/// One component of one slot over a batch.
pub(super) type Lane = [f64; LANES];

/// The lanes of a plan, with the constants in place, and room for the
/// partial derivatives of one step.
pub(super) struct Workspace {
    lanes: Vec<Lane>,
    scratch: Box<[Lane; 6]>,
}

impl Plan {
    /// A workspace for this plan: zeros, ones and constants filled once.
    pub(super) fn workspace(&self) -> Workspace {
        let mut lanes = vec![[0.0; LANES]; self.lanes];
        lanes[ONE as usize] = [1.0; LANES];
        for &(lane, value) in &self.constants {
            lanes[lane as usize] = [value; LANES];
        }
        Workspace {
            lanes,
            scratch: Box::new([[0.0; LANES]; 6]),
        }
    }

    /// Evaluates the tape at the points `xs` (1 to [`LANES`] of them; the
    /// lanes past them repeat the first point).
    pub(super) fn run(&self, ws: &mut Workspace, xs: &[[f64; 3]]) {
        assert!(
            !xs.is_empty() && xs.len() <= LANES,
            "a batch of 1 to {LANES} points"
        );
        for (axis, &lane) in self.coordinates.iter().enumerate() {
            let lane = &mut ws.lanes[lane as usize];
            for (l, v) in lane.iter_mut().enumerate() {
                *v = xs.get(l).unwrap_or(&xs[0])[axis];
            }
        }
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU reports AVX2.
            unsafe { self.steps_avx2(ws) };
            return;
        }
        self.steps(ws);
    }

    /// Component `k` of output `output` after [`Plan::run`].
    pub(super) fn lane<'w>(&self, ws: &'w Workspace, output: usize, k: usize) -> &'w Lane {
        &ws.lanes[self.outputs[output][k] as usize]
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn steps_avx2(&self, ws: &mut Workspace) {
        self.steps(ws);
    }

    #[inline(always)]
    fn steps(&self, ws: &mut Workspace) {
        for st in &self.steps {
            // Every step writes after the lanes it reads.
            let first = st.out[0] as usize;
            let (read, write) = ws.lanes.split_at_mut(first);
            let mut lanes = StepLanes {
                st,
                read,
                write,
                first,
            };
            match st.instr {
                Instr::Un(op, _) => {
                    unary_partials(op, self.order, lanes.a(0), &mut ws.scratch);
                    lanes.chain(&ws.scratch);
                }
                Instr::PowConst(_, n) => {
                    power_partials(n, self.order, lanes.a(0), &mut ws.scratch);
                    lanes.chain(&ws.scratch);
                }
                Instr::Bin(op, ..) => lanes.binary(op, self.order, &mut ws.scratch),
            }
        }
    }
}

/// The lanes one step reads (its operands') and writes (its own).
struct StepLanes<'a> {
    st: &'a Step,
    read: &'a [Lane],
    write: &'a mut [Lane],
    first: usize,
}

/// The operands' lanes one component of a rule reads: values (`a0`, `b0`),
/// the component itself (`ak`, `bk`) and, for a Hessian component of axes
/// `(i, j)`, the gradient components `i` and `j` (`ai`, `aj`, `bi`, `bj`).
struct Ops<'a> {
    a0: &'a Lane,
    ak: &'a Lane,
    ai: &'a Lane,
    aj: &'a Lane,
    b0: &'a Lane,
    bk: &'a Lane,
    bi: &'a Lane,
    bj: &'a Lane,
}

impl StepLanes<'_> {
    #[inline(always)]
    fn a(&self, k: usize) -> &Lane {
        &self.read[self.st.a[k] as usize]
    }

    #[inline(always)]
    fn b(&self, k: usize) -> &Lane {
        &self.read[self.st.b[k] as usize]
    }

    /// Writes `f(ops, l)` into lane `l` of each active component.
    #[inline(always)]
    fn each(&mut self, f: impl Fn(&Ops, usize) -> f64) {
        self.rules(&f, &f, &f);
    }

    /// Writes the active components, lane `l`: the value `value(ops, l)`, a
    /// gradient component `grad(ops, l)`, a Hessian component `hess(ops, l)`,
    /// with the lanes `ops` of the component gathered before the loop over
    /// the lanes (which the compiler then vectorises).
    #[inline(always)]
    fn rules(
        &mut self,
        value: impl Fn(&Ops, usize) -> f64,
        grad: impl Fn(&Ops, usize) -> f64,
        hess: impl Fn(&Ops, usize) -> f64,
    ) {
        let (read, st) = (self.read, self.st);
        for &k in &st.active {
            let k = k as usize;
            let (i, j) = if k >= 4 { HESSIAN[k - 4] } else { (0, 0) };
            let ops = Ops {
                a0: &read[st.a[0] as usize],
                ak: &read[st.a[k] as usize],
                ai: &read[st.a[1 + i] as usize],
                aj: &read[st.a[1 + j] as usize],
                b0: &read[st.b[0] as usize],
                bk: &read[st.b[k] as usize],
                bi: &read[st.b[1 + i] as usize],
                bj: &read[st.b[1 + j] as usize],
            };
            let o = &mut self.write[st.out[k] as usize - self.first];
            match k {
                0 => fill(o, &ops, &value),
                1..=3 => fill(o, &ops, &grad),
                _ => fill(o, &ops, &hess),
            }
        }
    }

    /// `g(a)` from the lanes `s = [g, g', g'']`.
    #[inline(always)]
    fn chain(&mut self, s: &[Lane; 6]) {
        self.rules(
            |_, l| s[0][l],
            |p, l| s[1][l] * p.ak[l],
            |p, l| s[2][l] * (p.ai[l] * p.aj[l]) + s[1][l] * p.ak[l],
        );
    }

    #[inline(always)]
    fn binary(&mut self, op: Op2, order: Order, s: &mut [Lane; 6]) {
        match op {
            Op2::Add => self.each(|p, l| p.ak[l] + p.bk[l]),
            Op2::Sub => self.each(|p, l| p.ak[l] - p.bk[l]),
            Op2::Min => self.each(|p, l| if p.b0[l] < p.a0[l] { p.bk[l] } else { p.ak[l] }),
            Op2::Max => self.each(|p, l| if p.b0[l] > p.a0[l] { p.bk[l] } else { p.ak[l] }),
            // `f_u = v`, `f_v = u`, `f_uu = f_vv = 0`, `f_uv = 1`.
            Op2::Mul => self.rules(
                |p, l| p.a0[l] * p.b0[l],
                |p, l| p.b0[l] * p.ak[l] + p.a0[l] * p.bk[l],
                |p, l| {
                    (p.b0[l] * p.ak[l] + p.a0[l] * p.bk[l])
                        + (p.ai[l] * p.bj[l] + p.bi[l] * p.aj[l])
                },
            ),
            Op2::Div | Op2::Atan2 | Op2::Pow => {
                self.binary_partials(op, order, s);
                let s: &[Lane; 6] = s;
                self.rules(
                    |_, l| s[0][l],
                    |p, l| s[1][l] * p.ak[l] + s[2][l] * p.bk[l],
                    |p, l| {
                        s[1][l] * p.ak[l]
                            + s[2][l] * p.bk[l]
                            + s[3][l] * (p.ai[l] * p.aj[l])
                            + s[5][l] * (p.bi[l] * p.bj[l])
                            + s[4][l] * (p.ai[l] * p.bj[l] + p.bi[l] * p.aj[l])
                    },
                );
            }
        }
    }

    /// `s = [f, f_u, f_v, f_uu, f_uv, f_vv]` of a quotient, `atan2` or power;
    /// a power whose exponent is locally constant in a lane takes the power
    /// rule there, as the recursive evaluator does.
    #[inline(always)]
    fn binary_partials(&self, op: Op2, order: Order, s: &mut [Lane; 6]) {
        let (a, b) = (self.a(0), self.b(0));
        let slopes: Vec<&Lane> = (1..order.components()).map(|k| self.b(k)).collect();
        for l in 0..LANES {
            let (u, v) = (a[l], b[l]);
            let p = match op {
                _ if order == Order::Value => Partials {
                    value: op.value(u, v),
                    first: [0.0; 2],
                    second: [0.0; 3],
                },
                Op2::Div => div_partials(u, v),
                Op2::Atan2 => atan2_partials(u, v),
                _ if slopes.iter().all(|d| d[l] == 0.0) => {
                    let [g, d1, d2] = power_rule(u, v);
                    Partials {
                        value: g,
                        first: [d1, 0.0],
                        second: [d2, 0.0, 0.0],
                    }
                }
                _ => pow_partials(u, v),
            };
            let all = [p.value, p.first[0], p.first[1]];
            for (q, x) in all.into_iter().chain(p.second).enumerate() {
                s[q][l] = x;
            }
        }
    }
}

/// `o[l] = f(ops, l)` over the lanes.
#[inline(always)]
fn fill(o: &mut Lane, ops: &Ops, f: &impl Fn(&Ops, usize) -> f64) {
    for (l, o) in o.iter_mut().enumerate() {
        *o = f(ops, l);
    }
}

/// `s[0..3] = [g, g', g'']` of a one-operand operation at `u` (`g` only for
/// values).
#[inline(always)]
fn unary_partials(op: Op1, order: Order, u: &Lane, s: &mut [Lane; 6]) {
    match (op, order) {
        (Op1::Neg, _) => {
            s[0] = u.map(|u| -u);
            s[1] = [-1.0; LANES];
            s[2] = [0.0; LANES];
        }
        (_, Order::Value) => s[0] = u.map(|u| op.value(u)),
        _ => {
            for l in 0..LANES {
                [s[0][l], s[1][l], s[2][l]] = op.derivatives(u[l]);
            }
        }
    }
}

/// `s[0..3] = [a^n, n a^(n-1), n (n-1) a^(n-2)]`
/// ([`super::functions::power_rule`]), as far as `order` needs.
#[inline(always)]
fn power_partials(n: f64, order: Order, a: &Lane, s: &mut [Lane; 6]) {
    let [g, d1, d2, ..] = s;
    pow_lanes(a, n, g);
    if order >= Order::Gradient {
        if n == 0.0 {
            *d1 = [0.0; LANES];
        } else {
            pow_lanes(a, n - 1.0, d1);
            d1.iter_mut().for_each(|d| *d *= n);
        }
    }
    if order >= Order::Hessian {
        if n == 0.0 || n == 1.0 {
            *d2 = [0.0; LANES];
        } else {
            pow_lanes(a, n - 2.0, d2);
            d2.iter_mut().for_each(|d| *d *= n * (n - 1.0));
        }
    }
}

/// `o = a^n` ([`super::functions::real_pow`]): small integer exponents by
/// the binary powering of `f64::powi` (the same products in the same order),
/// lane by lane; others with `powf`.
#[inline(always)]
fn pow_lanes(a: &Lane, n: f64, o: &mut Lane) {
    if n.fract() != 0.0 || n.abs() > MAX_POWI {
        for l in 0..LANES {
            o[l] = a[l].powf(n);
        }
        return;
    }
    let mut m = n.abs() as u32;
    let mut base = *a;
    *o = [1.0; LANES];
    loop {
        if m & 1 != 0 {
            lanes_mul(o, &base);
        }
        m >>= 1;
        if m == 0 {
            break;
        }
        let square = base;
        lanes_mul(&mut base, &square);
    }
    if n < 0.0 {
        o.iter_mut().for_each(|x| *x = 1.0 / *x);
    }
}

/// `o *= a`, lane by lane.
#[inline(always)]
fn lanes_mul(o: &mut Lane, a: &Lane) {
    for l in 0..LANES {
        o[l] *= a[l];
    }
}
