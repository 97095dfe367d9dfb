//! A case's loads and boundary conditions resolved into functions of the
//! position: body load, Dirichlet data (with the components it holds and the
//! region where it applies) and tractions per boundary tag, each given by
//! expressions or derived from the exact displacement field (`g = u`,
//! `t = σ(u) n`, `b = −∇·σ(u)`, by automatic differentiation).

use crate::case::boundary::{DirichletSpec, NeumannSpec};
use crate::case::physics::FieldValue;
use crate::case::Case;
use crate::element::reference::lame;
use crate::expr::{body_load_from_displacement, stress_from_displacement, VectorExpr, VectorTape};

/// The condition on one boundary part.
#[derive(Clone, Debug, PartialEq)]
pub enum Boundary {
    /// Traction free.
    Free,
    /// Prescribed displacement components, imposed weakly.
    Dirichlet(DirichletSpec),
    /// Prescribed traction or pressure.
    Neumann(NeumannSpec),
}

/// Loads and boundary conditions of a case.
#[derive(Clone, Debug)]
pub struct Problem {
    pub young: f64,
    pub poisson: f64,
    pub lambda: f64,
    pub mu: f64,
    pub exact: Option<VectorExpr>,
    body: Option<FieldValue>,
    /// The body load's field compiled (the given load, or the exact field
    /// whose load it is), for [`Problem::body_loads`].
    body_tape: Option<VectorTape>,
    /// Per boundary tag id.
    pub boundary: Vec<Boundary>,
}

impl Problem {
    /// Resolves the case's tables (already checked by [`Case`]).
    pub fn new(case: &Case) -> Problem {
        let s = &case.body().spec;
        let (lambda, mu) = lame(s.material.young, s.material.poisson);
        let exact = s.exact.as_ref().map(|e| e.displacement.clone());
        let body = match (&s.body_load, &exact) {
            (Some(b), _) => Some(b.value.clone()),
            (None, Some(_)) => Some(FieldValue::Exact),
            (None, None) => None,
        };
        let body_tape = match &body {
            Some(FieldValue::Given(v)) => Some(v.tape()),
            Some(FieldValue::Exact) => exact.as_ref().map(VectorExpr::tape),
            None => None,
        };
        let boundary = case
            .body()
            .geometry
            .tag_names()
            .iter()
            .map(|t| {
                if let Some(d) = s.dirichlet.get(t) {
                    Boundary::Dirichlet(d.clone())
                } else if let Some(n) = s.neumann.get(t) {
                    Boundary::Neumann(n.clone())
                } else {
                    Boundary::Free
                }
            })
            .collect();
        Problem {
            young: s.material.young,
            poisson: s.material.poisson,
            lambda,
            mu,
            exact,
            body,
            body_tape,
            boundary,
        }
    }

    fn exact(&self) -> &VectorExpr {
        self.exact
            .as_ref()
            .expect("\"exact\" is checked against [exact] when the case is read")
    }

    /// Does some boundary part carry a Dirichlet condition?
    pub fn has_dirichlet(&self) -> bool {
        self.boundary
            .iter()
            .any(|b| matches!(b, Boundary::Dirichlet(_)))
    }

    /// The components held at `x` on part `tag`: `None` where no Dirichlet
    /// condition applies (another kind of part, or outside its region).
    pub fn dirichlet_mask(&self, tag: u16, x: [f64; 3]) -> Option<[bool; 3]> {
        match &self.boundary[tag as usize] {
            Boundary::Dirichlet(d) if d.applies_at(x) => Some(d.mask()),
            _ => None,
        }
    }

    /// True when some body load is applied.
    pub fn has_body_load(&self) -> bool {
        self.body.is_some()
    }

    /// The body load at `x`.
    pub fn body_load(&self, x: [f64; 3]) -> [f64; 3] {
        match &self.body {
            None => [0.0; 3],
            Some(FieldValue::Given(v)) => v.eval(x),
            Some(FieldValue::Exact) => {
                body_load_from_displacement(self.exact(), self.lambda, self.mu, x)
            }
        }
    }

    /// The body loads at the points `xs`, into `out` (as long): the values of
    /// [`Problem::body_load`], computed in batches.
    pub fn body_loads(&self, xs: &[[f64; 3]], out: &mut [[f64; 3]]) {
        match (&self.body, &self.body_tape) {
            (Some(FieldValue::Given(_)), Some(tape)) => tape.values(xs, out),
            (Some(FieldValue::Exact), Some(tape)) => tape.body_loads(self.lambda, self.mu, xs, out),
            _ => out.fill([0.0; 3]),
        }
    }

    /// The stress of the exact field at `x`, if the case has one.
    pub fn exact_stress(&self, x: [f64; 3]) -> Option<[[f64; 3]; 3]> {
        let u = self.exact.as_ref()?;
        Some(stress_from_displacement(u, self.lambda, self.mu, x))
    }

    /// The prescribed displacement at `x` on a Dirichlet part (0 in its
    /// free components).
    pub fn dirichlet_value(&self, tag: u16, x: [f64; 3]) -> [f64; 3] {
        match &self.boundary[tag as usize] {
            Boundary::Dirichlet(d) => d.value_at(x, || self.exact().eval(x)),
            _ => [0.0; 3],
        }
    }

    /// The pressure at `x` on a pressure part (0 elsewhere).
    pub fn pressure(&self, tag: u16, x: [f64; 3]) -> f64 {
        match &self.boundary[tag as usize] {
            Boundary::Neumann(NeumannSpec {
                pressure: Some(p), ..
            }) => p.eval(x),
            _ => 0.0,
        }
    }

    /// The prescribed traction at `x` (outward normal `n`) on a Neumann part.
    pub fn traction(&self, tag: u16, x: [f64; 3], n: [f64; 3]) -> [f64; 3] {
        let Boundary::Neumann(spec) = &self.boundary[tag as usize] else {
            return [0.0; 3];
        };
        spec.eval(x, n, |x, n| {
            let s = stress_from_displacement(self.exact(), self.lambda, self.mu, x);
            [0, 1, 2].map(|i| s[i][0] * n[0] + s[i][1] * n[1] + s[i][2] * n[2])
        })
    }
}
