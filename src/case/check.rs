//! The checks of a parsed case: the ranges of every setting, unique body
//! names, boundary tags that exist, and the keys the case's solution path
//! cannot honour (each refused with the reason the case took that path).

use super::boundary::check_boundary;
use super::physics::FieldValue;
use super::{Body, Case, SolutionPath, LINEAR_SOLVER_KEYS};
use crate::error::Result;

/// The largest `stabilisation.k1` a case may set. Above it the penalty
/// `β = k1 E` dominates the recovered traction and locks the cut cells'
/// Dirichlet points; the answer is wrong with every solver converged
/// (docs/verification.md, *The penalty factor k1*).
pub const MAX_K1: f64 = 1e3;

impl Case {
    /// Checks the whole case; `solver_keys` are the keys `[solver]` writes.
    pub(super) fn check(&self, solver_keys: &[String]) -> Result<()> {
        self.check_name()?;
        let s = &self.spec;
        if self.bodies.is_empty() {
            return Err(self.bad("body", "a case needs at least one [[body]]".into()));
        }
        let st = &s.stabilisation;
        if !(st.k1.is_finite() && st.k1 > 0.0 && st.k1 <= MAX_K1) {
            return Err(self.bad(
                "stabilisation.k1",
                format!(
                    "must lie in (0, {MAX_K1:e}], got {}: a larger Dirichlet penalty locks \
                     the cut cells (the paper's sphere's energy error at level 4: 0.072 at \
                     k1 = 30, 0.080 at 1e3, 0.144 at 1e4; at level 3: 1.28 at 1e6)",
                    st.k1
                ),
            ));
        }
        if !(st.k2.is_finite() && st.k2 >= 0.0) {
            return Err(self.bad("stabilisation.k2", format!("must be ≥ 0, got {}", st.k2)));
        }
        if let Some(a) = st.a.filter(|a| !(0.0..1.0).contains(a)) {
            return Err(self.bad("stabilisation.A", format!("must lie in [0, 1), got {a}")));
        }
        let so = &s.solver;
        for (key, v) in [
            ("solver.rel_tol", so.rel_tol),
            ("solver.min_rel_tol", so.min_rel_tol),
            ("solver.fixed_point_tol", so.fixed_point_tol()),
            ("solver.inner_rel_tol", so.inner_rel_tol()),
        ] {
            if !(v.is_finite() && v > 0.0 && v < 1.0) {
                return Err(self.bad(key, format!("must lie in (0, 1), got {v}")));
            }
        }
        if so.max_iterations == 0 || so.max_fixed_point == 0 {
            return Err(self.bad("solver", "iteration limits must be at least 1".into()));
        }
        if let SolutionPath::Newton(why) = &self.path {
            self.check_newton(why, solver_keys)?;
        }
        for (i, b) in self.bodies.iter().enumerate() {
            self.check_body(i, b)?;
        }
        Ok(())
    }

    /// The name is the default output folder, `out/<name>`.
    fn check_name(&self) -> Result<()> {
        let Some(name) = &self.spec.name else {
            return Ok(());
        };
        let plain = !name.is_empty()
            && name != "."
            && name != ".."
            && !name
                .chars()
                .any(|c| c == '/' || c == '\\' || c.is_control());
        if plain {
            return Ok(());
        }
        Err(self.bad(
            "name",
            format!(
                "{name:?} is not a plain folder name (no '/', '\\', '..' or control characters)"
            ),
        ))
    }

    /// The settings of load stepping and Newton, and the linear path's keys
    /// refused (`why`: the reason the case runs Newton).
    fn check_newton(&self, why: &str, solver_keys: &[String]) -> Result<()> {
        let s = &self.spec;
        let linear_only = |key: &str| {
            self.bad(
                key,
                format!(
                    "applies to one linear body (the linear path); this case runs Newton ({why})"
                ),
            )
        };
        if let Some(k) = solver_keys
            .iter()
            .find(|k| LINEAR_SOLVER_KEYS.contains(&k.as_str()))
        {
            return Err(linear_only(&format!("solver.{k}")));
        }
        if s.stabilisation.balanced.is_some() {
            return Err(linear_only("stabilisation.balanced"));
        }
        if s.load.steps == 0 {
            return Err(self.bad("load.steps", "must be at least 1, got 0".into()));
        }
        let n = &s.newton;
        if n.max_iterations == 0 {
            return Err(self.bad("newton.max_iterations", "must be at least 1".into()));
        }
        if n.max_fixed_point == 0 {
            return Err(self.bad("newton.max_fixed_point", "must be at least 1".into()));
        }
        for (key, v) in [
            ("newton.rel_tol", n.rel_tol),
            ("newton.fixed_point_tol", n.fixed_point_tol),
            ("newton.energy_tol", n.energy_tol),
        ] {
            if !(v.is_finite() && v > 0.0 && v < 1.0) {
                return Err(self.bad(key, format!("must lie in (0, 1), got {v}")));
            }
        }
        if !(s.overlap_tolerance.is_finite() && s.overlap_tolerance >= 0.0) {
            return Err(self.bad(
                "overlap_tolerance",
                format!("must be ≥ 0, got {}", s.overlap_tolerance),
            ));
        }
        for (i, b) in self.bodies.iter().enumerate() {
            let key = |k: &str| self.body_key(i, k);
            let b = &b.spec;
            for (k, given) in [
                ("exact", b.exact.is_some()),
                ("body_load", b.body_load.is_some()),
                ("quadrature", b.quadrature.is_some()),
            ] {
                if given {
                    return Err(linear_only(&key(k)));
                }
            }
        }
        Ok(())
    }

    /// Body `i`: its name, material, quadrature, body load and boundary
    /// conditions.
    fn check_body(&self, i: usize, b: &Body) -> Result<()> {
        let key = |k: &str| self.body_key(i, k);
        let name = &b.spec.name;
        let plain = !name.is_empty() && name.chars().all(|c| c.is_alphanumeric() || c == '_');
        if !plain {
            return Err(self.bad(
                &key("name"),
                format!("{name:?} must be letters, digits and '_' (it is used in body.tag)"),
            ));
        }
        if self.bodies[..i].iter().any(|o| o.spec.name == *name) {
            return Err(self.bad(&key("name"), format!("two bodies are named '{name}'")));
        }
        let m = &b.spec.material;
        if !(m.young.is_finite() && m.young > 0.0) {
            return Err(self.bad(
                &key("material.young"),
                format!("E must be positive, got {}", m.young),
            ));
        }
        if !(m.poisson > -1.0 && m.poisson < 0.5) {
            return Err(self.bad(
                &key("material.poisson"),
                format!("ν must lie in (-1, 0.5), got {}", m.poisson),
            ));
        }
        let s = &b.spec;
        if let Some(q) = &s.quadrature {
            if !(1..=12).contains(&q.points) {
                return Err(self.bad(
                    &key("quadrature.points"),
                    format!("must lie in 1..=12, got {}", q.points),
                ));
            }
        }
        if let Some(load) = &s.body_load {
            if load.value == FieldValue::Exact && s.exact.is_none() {
                return Err(self.bad(&key("body_load.value"), "\"exact\" needs [exact]".into()));
            }
        }
        for (k, tag) in s.symmetry.iter().enumerate() {
            let at = key(&format!("symmetry[{k}]"));
            if b.geometry.tag_id(tag).is_none() {
                let known = b.geometry.tag_names().join(", ");
                let reason = format!("no boundary part is tagged '{tag}' (known: {known})");
                return Err(self.bad(&at, reason));
            }
            if s.dirichlet.contains_key(tag) || s.neumann.contains_key(tag) {
                let reason = format!("'{tag}' is a symmetry plane and has another condition");
                return Err(self.bad(&at, reason));
            }
        }
        let prefix = key("");
        check_boundary(
            &self.file,
            &prefix,
            &b.geometry,
            &s.dirichlet,
            &s.neumann,
            s.exact.is_some(),
            self.path != SolutionPath::Linear,
        )
    }
}
