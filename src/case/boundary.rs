//! The boundary-condition vocabulary shared by every body of every case
//! (every body on either solution path), and its checks.
//!
//! ```toml
//! [dirichlet.clamp]              # a prescribed displacement, imposed weakly
//! value = ["0", "0", "0"]        # three expressions of x, y, z ...
//! # value = "exact"              # ... or the exact field ([exact] cases)
//! # value = ["0", "free", "free"] # a roller / symmetry plane: only u_x held
//! # value = ["exact", "free", "0"] # components may also be "exact"
//! region = { min = [-inf, -inf, 0.5] }   # optional: only where min ≤ x ≤ max
//! ramp = [0.5, 1]                # optional, [[body]] cases: the load path
//! # ramp = [[0.5, 1], [0, 1], [0, 0.5]]  # or one [start, end] per component
//!
//! [neumann.load]                 # a traction per unit area ...
//! traction = ["0", "0", "-1"]    # ... three expressions, or "exact" (σ(u) n)
//! # pressure = "100"             # or a scalar pressure p: t = −p n
//! ramp = [0, 0.5]                # optional, [[body]] cases: the load path
//! ```
//! A free component of a Dirichlet part is traction free. A point of a
//! Dirichlet part outside its `region` is traction free too. Parts named in
//! neither table are traction free.
//!
//! `ramp = [start, end]` is the load path of a prescribed value or a traction
//! in a `[[body]]` case: at load factor `t` the value is `r(t) g(x)` with
//! `r(t) = clamp((t − start)/(end − start), 0, 1)`, so `[0, 1]` (the default)
//! grows with the load factor and `[0, 0.5]` then `[0.5, 1]` press first and
//! push after. The linear path has no load steps and refuses the key.

use std::collections::BTreeMap;

use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;

use super::bad_key;
use super::physics::FieldValue;
use crate::error::Result;
use crate::expr::Expr;
use crate::geometry::Geometry;

/// `dirichlet.<tag>`: a prescribed displacement, optionally only in a box.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DirichletSpec {
    pub value: DirichletValue,
    #[serde(default)]
    pub region: Option<RegionSpec>,
    #[serde(default)]
    pub ramp: Option<RampSpec>,
}

/// `ramp`: one `[start, end]` for every component or one per component.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum RampSpec {
    All([f64; 2]),
    Each([[f64; 2]; 3]),
}

impl RampSpec {
    /// `[start, end]` per component.
    pub fn per_component(&self) -> [[f64; 2]; 3] {
        match self {
            RampSpec::All(r) => [*r; 3],
            RampSpec::Each(r) => *r,
        }
    }

    /// `[start, end]` per component of an optional `ramp` (`[0, 1]`, growth
    /// with the load factor, when there is none).
    pub fn or_linear(ramp: Option<&RampSpec>) -> [[f64; 2]; 3] {
        ramp.map_or([[0.0, 1.0]; 3], RampSpec::per_component)
    }
}

/// The prescribed value: `"exact"` (every component from `[exact]`) or three
/// components.
#[derive(Clone, Debug, PartialEq)]
pub enum DirichletValue {
    Exact,
    Components([Component; 3]),
}

/// One prescribed displacement component.
#[derive(Clone, Debug, PartialEq)]
pub enum Component {
    /// Not prescribed: traction free in this direction.
    Free,
    /// The exact field's component.
    Exact,
    Given(Expr),
}

impl<'de> Deserialize<'de> for Component {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        match text.trim() {
            "free" => Ok(Component::Free),
            "exact" => Ok(Component::Exact),
            _ => Expr::parse(&text)
                .map(Component::Given)
                .map_err(|e| de::Error::custom(e.to_string())),
        }
    }
}

impl<'de> Deserialize<'de> for DirichletValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = DirichletValue;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("\"exact\" or an array of three components (expressions or \"free\")")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> std::result::Result<DirichletValue, E> {
                match s {
                    "exact" => Ok(DirichletValue::Exact),
                    _ => Err(E::custom(format!(
                        "expected \"exact\" or an array of three components, got \"{s}\""
                    ))),
                }
            }
            fn visit_seq<A: SeqAccess<'de>>(
                self,
                seq: A,
            ) -> std::result::Result<DirichletValue, A::Error> {
                let c = <[Component; 3]>::deserialize(de::value::SeqAccessDeserializer::new(seq))?;
                Ok(DirichletValue::Components(c))
            }
        }
        d.deserialize_any(V)
    }
}

impl DirichletSpec {
    /// The three components (`"exact"` as three exact components).
    pub fn components(&self) -> [Component; 3] {
        match &self.value {
            DirichletValue::Exact => [Component::Exact, Component::Exact, Component::Exact],
            DirichletValue::Components(c) => c.clone(),
        }
    }

    /// Component `a` (without cloning the expressions).
    fn component(&self, a: usize) -> &Component {
        match &self.value {
            DirichletValue::Exact => &Component::Exact,
            DirichletValue::Components(c) => &c[a],
        }
    }

    /// Which components are held.
    pub fn mask(&self) -> [bool; 3] {
        [0, 1, 2].map(|a| *self.component(a) != Component::Free)
    }

    /// Does the condition apply at `x` (inside its region, if any)?
    pub fn applies_at(&self, x: [f64; 3]) -> bool {
        self.region.as_ref().is_none_or(|r| r.contains(x))
    }

    /// Does some component come from the exact field?
    pub fn uses_exact(&self) -> bool {
        (0..3).any(|a| *self.component(a) == Component::Exact)
    }

    /// The prescribed value at `x`: 0 in a free component, `exact()` (called
    /// at most once) in an exact one.
    pub fn value_at(&self, x: [f64; 3], exact: impl FnOnce() -> [f64; 3]) -> [f64; 3] {
        let u = match self.uses_exact() {
            true => exact(),
            false => [0.0; 3],
        };
        [0, 1, 2].map(|a| match self.component(a) {
            Component::Free => 0.0,
            Component::Exact => u[a],
            Component::Given(e) => e.eval(x),
        })
    }
}

/// A box `min ≤ x ≤ max` (components may be ±inf) where a condition applies.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RegionSpec {
    #[serde(default = "minus_infinity")]
    pub min: [f64; 3],
    #[serde(default = "plus_infinity")]
    pub max: [f64; 3],
}

fn minus_infinity() -> [f64; 3] {
    [f64::NEG_INFINITY; 3]
}

fn plus_infinity() -> [f64; 3] {
    [f64::INFINITY; 3]
}

impl RegionSpec {
    /// Is `x` in the region?
    pub fn contains(&self, x: [f64; 3]) -> bool {
        (0..3).all(|a| self.min[a] <= x[a] && x[a] <= self.max[a])
    }
}

/// `neumann.<tag>`: a traction, or a pressure `p` (traction `−p n`, `n` the
/// outward normal). Exactly one of the two.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NeumannSpec {
    #[serde(default)]
    pub traction: Option<FieldValue>,
    #[serde(default)]
    pub pressure: Option<Expr>,
    /// Per traction component (a pressure's applies to its traction).
    #[serde(default)]
    pub ramp: Option<RampSpec>,
}

impl NeumannSpec {
    /// The traction at `x` with outward normal `n`; `exact_traction` gives
    /// `σ(u) n` of the exact field for `traction = "exact"`.
    pub fn eval(
        &self,
        x: [f64; 3],
        n: [f64; 3],
        exact_traction: impl Fn([f64; 3], [f64; 3]) -> [f64; 3],
    ) -> [f64; 3] {
        match (&self.traction, &self.pressure) {
            (Some(FieldValue::Given(v)), _) => v.eval(x),
            (Some(FieldValue::Exact), _) => exact_traction(x, n),
            (None, Some(p)) => {
                let p = p.eval(x);
                n.map(|c| -p * c)
            }
            (None, None) => [0.0; 3],
        }
    }

    /// Is the traction `"exact"`?
    pub fn is_exact(&self) -> bool {
        self.traction == Some(FieldValue::Exact)
    }
}

/// Why `ramp` is not a valid load path, if it is not.
fn ramp_problem(ramp: &RampSpec, load_path: bool) -> Option<String> {
    if !load_path {
        return Some(
            "the linear path has no load steps: add [load] steps to run the case by Newton".into(),
        );
    }
    let bad = |[start, end]: &[f64; 2]| !(0.0 <= *start && start < end && *end <= 1.0);
    ramp.per_component()
        .iter()
        .find(|r| bad(r))
        .map(|r| format!("[start, end] must have 0 ≤ start < end ≤ 1, got {r:?}"))
}

/// Boundary conditions per tag.
pub type DirichletTable = BTreeMap<String, DirichletSpec>;
/// Tractions per tag.
pub type NeumannTable = BTreeMap<String, NeumannSpec>;

/// Checks a body's boundary tables against its `geometry`: every tag exists,
/// no tag has both kinds, a Dirichlet part holds a component and its region
/// is a box, a Neumann part has one of `traction` and `pressure`, `"exact"`
/// only where the body has an exact field, a `ramp` only where the case has
/// a load path (`load_path`) and with `0 ≤ start < end ≤ 1`. `prefix` is the
/// tables' key path (`""` or `"body[2]."`).
pub(super) fn check_boundary(
    file: &str,
    prefix: &str,
    geometry: &Geometry,
    dirichlet: &DirichletTable,
    neumann: &NeumannTable,
    has_exact: bool,
    load_path: bool,
) -> Result<()> {
    let known = geometry.tag_names().join(", ");
    let key = |k: String| format!("{prefix}{k}");
    let bad = |k: String, reason: String| Err(bad_key(file, &key(k), reason));
    let needs_exact = "\"exact\" needs an [exact] field".to_string();
    for (tag, d) in dirichlet {
        if geometry.tag_id(tag).is_none() {
            let reason = format!("no boundary part is tagged '{tag}' (known: {known})");
            return bad(format!("dirichlet.{tag}"), reason);
        }
        if d.mask() == [false; 3] {
            let reason = "every component is \"free\": hold at least one".to_string();
            return bad(format!("dirichlet.{tag}.value"), reason);
        }
        if d.uses_exact() && !has_exact {
            return bad(format!("dirichlet.{tag}.value"), needs_exact);
        }
        if let Some(r) = &d.region {
            if (0..3).any(|a| r.min[a].is_nan() || r.max[a].is_nan() || r.min[a] > r.max[a]) {
                let reason = format!("min {:?} must not exceed max {:?}", r.min, r.max);
                return bad(format!("dirichlet.{tag}.region"), reason);
            }
        }
        if let Some(r) = &d.ramp {
            if let Some(reason) = ramp_problem(r, load_path) {
                return bad(format!("dirichlet.{tag}.ramp"), reason);
            }
        }
    }
    for (tag, n) in neumann {
        if geometry.tag_id(tag).is_none() {
            let reason = format!("no boundary part is tagged '{tag}' (known: {known})");
            return bad(format!("neumann.{tag}"), reason);
        }
        if dirichlet.contains_key(tag) {
            let reason = format!("'{tag}' already has a Dirichlet condition");
            return bad(format!("neumann.{tag}"), reason);
        }
        if n.traction.is_some() == n.pressure.is_some() {
            let reason = "give exactly one of `traction` and `pressure`".to_string();
            return bad(format!("neumann.{tag}"), reason);
        }
        if n.is_exact() && !has_exact {
            return bad(format!("neumann.{tag}.traction"), needs_exact);
        }
        if let Some(r) = &n.ramp {
            if let Some(reason) = ramp_problem(r, load_path) {
                return bad(format!("neumann.{tag}.ramp"), reason);
            }
        }
    }
    Ok(())
}
