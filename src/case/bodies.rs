//! Multi-body case files (large deformation and contact, DESIGN §6): several
//! bodies, each with its own geometry, grid, hyperelastic material and
//! boundary conditions, the contact pairs between them, the load steps and the
//! Newton settings. Read with every key checked, as [`super::Case`] is; every
//! error names the file, the key path and the reason (exit code 2).
//!
//! ```toml
//! name = "two_blocks"
//! overlap_tolerance = 1e-3     # overlap allowed at the start, × the smaller body's volume
//!
//! [load]
//! steps = 5                    # step k of N is load factor t = k/N; a prescribed value grows
//!                              # with t (linearly, or along its `ramp`: case::boundary)
//!
//! [newton]
//! max_iterations = 25          # per load step
//! rel_tol = 1e-8               # ‖R‖ / ‖R_0‖ of the step
//! energy_tol = 1e-16           # |Δu · R| / |Δu_0 · R_0| of the step
//! line_search = true           # backtracking on ‖R‖
//! max_cuts = 5                 # a failed step is halved at most this many times
//! fixed_point_tol = 1e-6       # recovered terms (T̂_N, S): ‖u_k − u_{k−1}‖/‖u_k‖ between passes
//! max_fixed_point = 30         # Newton passes per step with recovered terms
//! recovery = "passes"          # or "embedded" (after every Newton update), "step" (once per step)
//!
//! [solver]                     # the inner Krylov solves
//! method = "bicgstab"          # cgs | cg | bicgstab
//! preconditioner = "multigrid" # or jacobi, none
//! rel_tol = 1e-8
//! max_iterations = 20000
//!
//! [stabilisation]              # as in single-body cases, for every body (same
//! k1 = 30.0                    # defaults: k2 = 0.01, A = 0.05 as for Q1)
//! k2 = 0.01
//! A = 0.01
//!
//! [[body]]
//! name = "lower"
//! geometry = { type = "cuboid", min = [-1, -1, -1], max = [1, 1, 0] }
//! grid = { level = 3 }
//! material = { model = "neo_hookean", young = 1000.0, poisson = 0.3 }   # or st_venant_kirchhoff, linear
//! dirichlet.bottom = { value = ["0", "0", "0"] }
//! # the boundary vocabulary of every case (super::boundary): components may be
//! # "free", and a condition may be restricted to a box:
//! # dirichlet.outer = { value = ["0", "0.5", "free"], region = { max = [-0.95, inf, inf] } }
//!
//! [[body]]
//! name = "upper"
//! # ...
//! neumann.top = { traction = ["0", "0", "-10"] }   # or { pressure = "10" }: −p N
//!
//! [[body]]                     # a plane-strain body (see "Plane strain")
//! name = "ring"
//! plane_strain = true
//! geometry = { type = "annulus", start = [0, 0, -1], end = [0, 0, 1], inner_radius = 0.5, outer_radius = 1 }
//! # ...
//!
//! [[contact]]
//! slave = "upper.bottom"       # body.tag
//! master = "lower.top"
//! penalty = 30.0               # k of λ_N = min(0, T̂_N + (k E/h) g_N), as k1
//! friction = 0.0               # Coulomb coefficient (0: frictionless)
//! recovered_traction = true    # T̂_N recovered by SPR (false: pure penalty, T̂_N = 0)
//! master_surface = "facets"    # or "curved": PN patches on the current vertex normals
//! ```
//!
//! # Plane strain
//! A body with `plane_strain = true` is solved as a slab one cell thick: its
//! grid box spans the x–y extent of the grid box (or the geometry's) and
//! exactly `z ∈ [−h/2, h/2]` at every level (`h` from the x–y extent and the
//! level; the z offset must be 0), its solid is the geometry clipped to that
//! slab (see [`BodiesCase::solid`]: the two caps lie on the grid's two node
//! planes and are tagged [`PLANE_STRAIN_CAP`], traction free), and the runner
//! holds `u_z = 0` at every node (strongly). The geometry must span the slab
//! (z from −h/2 to h/2 at least); it is meant to be a prism along z.

use serde::Deserialize;

use super::boundary::{check_boundary, DirichletTable, NeumannTable};
use super::geometry::GeometrySpec;
use super::physics::StabilisationSpec;
use super::{bad_key, deserialize, file_stem, grid_of, parse_table, GridSpec};
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::geometry::{Aabb, Geometry};
use crate::grid::Grid;
use crate::solver::{KrylovMethod, Preconditioner};

/// A multi-body case as written in its file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BodiesSpec {
    #[serde(default)]
    pub name: Option<String>,
    /// Overlap of two bodies allowed at the start, as a fraction of the
    /// smaller body's volume.
    #[serde(default = "default_overlap_tolerance")]
    pub overlap_tolerance: f64,
    #[serde(default)]
    pub load: LoadSpec,
    #[serde(default)]
    pub newton: NewtonSpec,
    #[serde(default)]
    pub solver: InnerSolverSpec,
    #[serde(default)]
    pub stabilisation: StabilisationSpec,
    pub body: Vec<BodySpec>,
    #[serde(default)]
    pub contact: Vec<ContactPairSpec>,
}

fn default_overlap_tolerance() -> f64 {
    1e-3
}

/// `[load]`: load stepping.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct LoadSpec {
    /// Load steps; step k of N is load factor `k/N`, where every prescribed
    /// value is at its ramp's factor (`t` itself by default).
    pub steps: usize,
}

impl Default for LoadSpec {
    fn default() -> Self {
        LoadSpec { steps: 1 }
    }
}

/// `[newton]`: the Newton–Raphson iterations of each load step.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct NewtonSpec {
    pub max_iterations: usize,
    /// Converged when ‖R‖ ≤ rel_tol ‖R_0‖ ...
    pub rel_tol: f64,
    /// ... and |Δu·R| ≤ energy_tol |Δu_0·R_0| (the energy norm of the increment).
    pub energy_tol: f64,
    pub line_search: bool,
    /// Halvings of a failed step before the run stops (exit code 3).
    pub max_cuts: usize,
    /// With recovered terms: passes end when ‖u_k − u_{k−1}‖ ≤ fixed_point_tol ‖u_k‖.
    pub fixed_point_tol: f64,
    /// With recovered terms: Newton passes allowed per step.
    pub max_fixed_point: usize,
    /// With recovered terms: `"passes"` (between Newton solves),
    /// `"embedded"` (after every Newton update) or `"step"` (once per step).
    pub recovery: crate::hyper::newton::RecoveryMode,
}

impl Default for NewtonSpec {
    fn default() -> Self {
        NewtonSpec {
            max_iterations: 25,
            rel_tol: 1e-8,
            energy_tol: 1e-16,
            line_search: true,
            max_cuts: 5,
            fixed_point_tol: 1e-6,
            max_fixed_point: 30,
            recovery: crate::hyper::newton::RecoveryMode::Passes,
        }
    }
}

/// `[solver]`: the Krylov solves inside Newton (the tangent with contact is
/// not symmetric in general: BiCGStab or CGS).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct InnerSolverSpec {
    pub method: KrylovMethod,
    pub preconditioner: Preconditioner,
    pub rel_tol: f64,
    pub max_iterations: usize,
}

impl Default for InnerSolverSpec {
    fn default() -> Self {
        InnerSolverSpec {
            method: KrylovMethod::BiCgStab,
            preconditioner: Preconditioner::Multigrid,
            rel_tol: 1e-8,
            max_iterations: 20_000,
        }
    }
}

/// One `[[body]]`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    pub name: String,
    #[serde(default = "default_element")]
    pub element: ElementOrder,
    pub geometry: GeometrySpec,
    #[serde(default)]
    pub grid: GridSpec,
    pub material: HyperMaterialSpec,
    #[serde(default)]
    pub dirichlet: DirichletTable,
    #[serde(default)]
    pub neumann: NeumannTable,
    /// Solve as a plane-strain slab (see the module doc).
    #[serde(default)]
    pub plane_strain: bool,
}

/// The tag of the two caps of a plane-strain slab.
pub const PLANE_STRAIN_CAP: &str = "plane_strain_cap";

fn default_element() -> ElementOrder {
    ElementOrder::Q1
}

/// A hyperelastic material.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct HyperMaterialSpec {
    #[serde(default)]
    pub model: HyperModel,
    pub young: f64,
    pub poisson: f64,
}

/// The strain energy (DESIGN §6).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum HyperModel {
    /// `W = μ/2 (tr C − 3) − μ ln J + λ/2 (ln J)²`.
    #[default]
    NeoHookean,
    /// `W = λ/2 (tr E)² + μ E:E`.
    StVenantKirchhoff,
    /// Small-strain linear elasticity, `W = λ/2 (tr ε)² + μ ε:ε`,
    /// `ε = sym(∇u)`: with the same Newton, contact and boundary conditions.
    Linear,
}

/// One `[[contact]]` pair.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ContactPairSpec {
    /// `body.tag` of the slave boundary (where the gap is measured).
    pub slave: String,
    /// `body.tag` of the master boundary.
    pub master: String,
    /// Penalty factor k of the augmented Lagrangian (as k1).
    #[serde(default = "default_penalty")]
    pub penalty: f64,
    /// Coulomb friction coefficient (0: frictionless).
    #[serde(default)]
    pub friction: f64,
    /// `T̂_N` recovered from the slave's stress (false: `T̂_N = 0`, pure
    /// penalty).
    #[serde(default = "default_recovered_traction")]
    pub recovered_traction: bool,
    /// The master surface: flat facets of its triangulation or curved (PN)
    /// patches on them.
    #[serde(default)]
    pub master_surface: MasterSurfaceKind,
}

/// How the master surface is represented (`contact.master_surface`).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MasterSurfaceKind {
    /// The flat marching-tetrahedra facets.
    #[default]
    Facets,
    /// Curved PN patches on the facets, from the current vertex normals.
    Curved,
}

fn default_penalty() -> f64 {
    30.0
}

fn default_recovered_traction() -> bool {
    true
}

/// A body of a checked case: its spec and its solid.
#[derive(Clone, Debug)]
pub struct Body {
    pub spec: BodySpec,
    pub geometry: Geometry,
}

/// A boundary part of a body, resolved from `body.tag`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoundaryRef {
    pub body: usize,
    pub tag: u16,
}

/// A contact pair with both sides resolved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactPair {
    pub slave: BoundaryRef,
    pub master: BoundaryRef,
    pub penalty: f64,
    pub friction: f64,
}

/// A multi-body case ready to run.
#[derive(Clone, Debug)]
pub struct BodiesCase {
    pub file: String,
    pub spec: BodiesSpec,
    pub bodies: Vec<Body>,
    pub pairs: Vec<ContactPair>,
}

/// Is this case text a multi-body case (does it have `[[body]]`)?
pub fn is_bodies_case(text: &str) -> bool {
    text.parse::<toml::Table>()
        .map(|t| t.contains_key("body"))
        .unwrap_or(false)
}

impl BodiesCase {
    /// Reads a multi-body case file with `key=value` overrides.
    pub fn from_file_with(path: &std::path::Path, overrides: &[String]) -> Result<BodiesCase> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io {
            path: file.clone(),
            reason: e.to_string(),
        })?;
        BodiesCase::from_str_with(&file, &text, overrides)
    }

    /// Parses multi-body case text, applies overrides, then checks it.
    pub fn from_str_with(file: &str, text: &str, overrides: &[String]) -> Result<BodiesCase> {
        let table = parse_table(file, text, overrides)?;
        let mut spec: BodiesSpec = deserialize(file, table)?;
        if spec.name.is_none() {
            spec.name = file_stem(file);
        }
        let mut bodies = Vec::with_capacity(spec.body.len());
        for b in &spec.body {
            bodies.push(Body {
                spec: b.clone(),
                geometry: b.geometry.build(file)?,
            });
        }
        let mut case = BodiesCase {
            file: file.into(),
            spec,
            bodies,
            pairs: Vec::new(),
        };
        case.check()?;
        case.pairs = case.resolve_pairs()?;
        case.check_overlap()?;
        Ok(case)
    }

    /// The grid of every body, each at its own level or all at `level`
    /// (a plane-strain body's grid is one cell thick, see the module doc).
    pub fn grids(&self, level: Option<u32>) -> Result<Vec<Grid>> {
        self.bodies
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let key = format!("body[{i}].grid");
                let spec = match b.spec.plane_strain {
                    true => self.slab_grid_spec(i, level)?,
                    false => b.spec.grid.clone(),
                };
                grid_of(&self.file, &key, &spec, &b.geometry, level)
            })
            .collect()
    }

    pub(crate) fn bad(&self, key: &str, reason: String) -> Error {
        bad_key(&self.file, key, reason)
    }

    /// Ranges of the settings, unique body names, known tags.
    fn check(&self) -> Result<()> {
        let s = &self.spec;
        if s.body.is_empty() {
            return Err(self.bad(
                "body",
                "a multi-body case needs at least one [[body]]".into(),
            ));
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
            ("solver.rel_tol", s.solver.rel_tol),
        ] {
            if !(v.is_finite() && v > 0.0 && v < 1.0) {
                return Err(self.bad(key, format!("must lie in (0, 1), got {v}")));
            }
        }
        if s.solver.max_iterations == 0 {
            return Err(self.bad("solver.max_iterations", "must be at least 1".into()));
        }
        if !(s.overlap_tolerance.is_finite() && s.overlap_tolerance >= 0.0) {
            return Err(self.bad(
                "overlap_tolerance",
                format!("must be ≥ 0, got {}", s.overlap_tolerance),
            ));
        }
        let st = &s.stabilisation;
        if !(st.k1.is_finite() && st.k1 > 0.0) {
            return Err(self.bad(
                "stabilisation.k1",
                format!("must be positive, got {}", st.k1),
            ));
        }
        if !(st.k2.is_finite() && st.k2 >= 0.0) {
            return Err(self.bad("stabilisation.k2", format!("must be ≥ 0, got {}", st.k2)));
        }
        if let Some(a) = st.a.filter(|a| !(0.0..1.0).contains(a)) {
            return Err(self.bad("stabilisation.A", format!("must lie in [0, 1), got {a}")));
        }
        if st.balanced.is_some() {
            return Err(self.bad(
                "stabilisation.balanced",
                "applies to single-body cases; [[body]] cases run the paper's S-term".into(),
            ));
        }
        for (i, b) in self.bodies.iter().enumerate() {
            self.check_body(i, b)?;
        }
        Ok(())
    }

    fn check_body(&self, i: usize, b: &Body) -> Result<()> {
        let key = |k: &str| format!("body[{i}].{k}");
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
        let prefix = format!("body[{i}].");
        let s = &b.spec;
        check_boundary(
            &self.file,
            &prefix,
            &b.geometry,
            &s.dirichlet,
            &s.neumann,
            false,
            true,
        )
    }

    /// Resolves `body.tag` of every pair.
    fn resolve_pairs(&self) -> Result<Vec<ContactPair>> {
        let mut pairs = Vec::with_capacity(self.spec.contact.len());
        for (i, c) in self.spec.contact.iter().enumerate() {
            let slave = self.resolve(&format!("contact[{i}].slave"), &c.slave)?;
            let master = self.resolve(&format!("contact[{i}].master"), &c.master)?;
            if slave.body == master.body {
                return Err(self.bad(
                    &format!("contact[{i}]"),
                    "slave and master lie on the same body (self-contact is not supported)".into(),
                ));
            }
            if !(c.penalty.is_finite() && c.penalty > 0.0) {
                return Err(self.bad(
                    &format!("contact[{i}].penalty"),
                    format!("must be positive, got {}", c.penalty),
                ));
            }
            if !(c.friction.is_finite() && c.friction >= 0.0) {
                return Err(self.bad(
                    &format!("contact[{i}].friction"),
                    format!("must be ≥ 0, got {}", c.friction),
                ));
            }
            pairs.push(ContactPair {
                slave,
                master,
                penalty: c.penalty,
                friction: c.friction,
            });
        }
        Ok(pairs)
    }

    fn resolve(&self, key: &str, name: &str) -> Result<BoundaryRef> {
        let Some((body, tag)) = name.split_once('.') else {
            return Err(self.bad(key, format!("expected body.tag, got '{name}'")));
        };
        let names: Vec<&str> = self.bodies.iter().map(|b| b.spec.name.as_str()).collect();
        let Some(b) = names.iter().position(|n| *n == body) else {
            return Err(self.bad(
                key,
                format!("no body is named '{body}' (bodies: {})", names.join(", ")),
            ));
        };
        let g = &self.bodies[b].geometry;
        match g.tag_id(tag) {
            Some(tag) => Ok(BoundaryRef { body: b, tag }),
            None => Err(self.bad(
                key,
                format!(
                    "body '{body}' has no boundary part tagged '{tag}' (known: {})",
                    g.tag_names().join(", ")
                ),
            )),
        }
    }

    /// Refuses bodies that overlap at the start by more than
    /// `overlap_tolerance` × the smaller body's volume. Volumes are counted on
    /// a lattice of [`OVERLAP_SAMPLES`]³ points over each pair's common box.
    fn check_overlap(&self) -> Result<()> {
        for i in 0..self.bodies.len() {
            for j in i + 1..self.bodies.len() {
                let (a, b) = (&self.bodies[i].geometry, &self.bodies[j].geometry);
                let common = a.bounding_box().intersection(&b.bounding_box());
                if common.is_empty() {
                    continue;
                }
                let overlap = lattice_volume(&common, |x| a.inside(x) && b.inside(x));
                let smaller = lattice_volume(&a.bounding_box(), |x| a.inside(x))
                    .min(lattice_volume(&b.bounding_box(), |x| b.inside(x)));
                if overlap > self.spec.overlap_tolerance * smaller {
                    return Err(self.bad(
                        &format!("body[{j}].geometry"),
                        format!(
                            "bodies '{}' and '{}' overlap at the start: about {overlap:.3e} \
                             of volume, {:.2e} of the smaller body's (overlap_tolerance = {})",
                            self.bodies[i].spec.name,
                            self.bodies[j].spec.name,
                            overlap / smaller,
                            self.spec.overlap_tolerance
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Lattice points per axis of the overlap check.
pub const OVERLAP_SAMPLES: usize = 64;

/// The volume of `{x ∈ bbox : inside(x)}` by the midpoint rule on a lattice
/// of [`OVERLAP_SAMPLES`]³ cells.
fn lattice_volume(bbox: &Aabb, inside: impl Fn([f64; 3]) -> bool) -> f64 {
    let n = OVERLAP_SAMPLES;
    let d = [0, 1, 2].map(|a| (bbox.hi[a] - bbox.lo[a]) / n as f64);
    let mut count = 0usize;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let m = [i, j, k];
                let x = [0, 1, 2].map(|a| bbox.lo[a] + (m[a] as f64 + 0.5) * d[a]);
                count += inside(x) as usize;
            }
        }
    }
    count as f64 * d[0] * d[1] * d[2]
}

mod plane_strain;
#[cfg(test)]
mod tests;
