//! Case files (TOML): what to solve, read with every key checked. Unknown keys
//! are rejected, and every error names the file, the key path and the reason
//! (exit code 2). `--set key=value` overrides any key (dotted path) before
//! checking.
//!
//! # One case model
//! A case is a list of bodies (`[[body]]`, [`body`]), the contact pairs
//! between them (`[[contact]]`, [`contact`]), and the settings of the whole
//! run: `[stabilisation]`, `[solver]`, and for the Newton path `[load]` and
//! `[newton]` ([`physics`]). A case of one body may leave out `[[body]]` and
//! write the body's keys (`geometry`, `grid`, `material`, `dirichlet`, …) at
//! the top level: the shorthand reads as one body named
//! [`SHORTHAND_BODY`], and its errors name the keys as written.
//!
//! ```toml
//! name = "two_blocks"
//! overlap_tolerance = 1e-3     # overlap allowed at the start, × the smaller body's volume
//!
//! [[body]]
//! name = "lower"
//! geometry = { type = "cuboid", min = [-1, -1, -1], max = [1, 1, 0] }
//! material = { model = "neo_hookean", young = 1000.0, poisson = 0.3 }
//! dirichlet.zmin = { value = ["0", "0", "0"] }
//!
//! [[body]]
//! name = "upper"
//! # ...
//!
//! [[contact]]
//! slave = "upper.zmin"         # body.tag
//! master = "lower.zmax"
//! ```
//!
//! # Solution path
//! One case model, two ways to solve it ([`SolutionPath`]): a case of one
//! linear body that asks for nothing of load stepping runs the linear fixed
//! point on the recovered terms (`crate::fem`, Q1 or Q2, exact fields and
//! error norms); every other case (a hyperelastic model, several bodies,
//! contact, plane strain, symmetry planes, `[load]` or `[newton]`) runs
//! Newton over load
//! steps (`crate::bodies`, Q1), which holds dofs: plane strain and symmetry
//! planes. A key the chosen path cannot honour is an
//! error that names it and says why the case took that path.

pub mod body;
pub mod boundary;
mod check;
pub mod contact;
pub mod geometry;
pub mod image;
pub mod physics;
mod plane_strain;
pub mod stl;

use std::path::Path;

use serde::Deserialize;

use crate::cells::{cut_rule_points, Cells};
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::grid::{CellBox, Grid};
use crate::solver::{KrylovMethod, Preconditioner};
use crate::spatial::Aabb;
pub use body::{
    Body, BodySpec, GridSpec, MaterialSpec, Model, QuadratureSpec, PLANE_STRAIN_CAP, SHORTHAND_BODY,
};
pub use contact::{BoundaryRef, ContactPair, ContactPairSpec, MasterSurfaceKind};
pub use geometry::GeometrySpec;
use physics::{LoadSpec, NewtonSpec, SolverSpec, StabilisationSpec};

/// A case as written in its file (a shorthand one-body case after its body
/// keys are gathered into `body`).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CaseSpec {
    /// Name used in reports and as the output folder; defaults to the file stem.
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
    pub solver: SolverSpec,
    #[serde(default)]
    pub stabilisation: StabilisationSpec,
    /// The bodies as read; moved into [`Case::bodies`] (empty after), so
    /// that a body's spec has one copy.
    pub body: Vec<BodySpec>,
    #[serde(default)]
    pub contact: Vec<ContactPairSpec>,
}

fn default_overlap_tolerance() -> f64 {
    1e-3
}

/// The keys of a case that belong to the whole run; in the shorthand every
/// other top-level key belongs to the one body.
const CASE_KEYS: [&str; 8] = [
    "name",
    "overlap_tolerance",
    "load",
    "newton",
    "solver",
    "stabilisation",
    "body",
    "contact",
];

/// The `[solver]` keys of the linear path's fixed point (the Newton path
/// sets its fixed point in `[newton]`).
const LINEAR_SOLVER_KEYS: [&str; 5] = [
    "outer",
    "inner_rel_tol",
    "min_rel_tol",
    "fixed_point_tol",
    "max_fixed_point",
];

/// How a case is solved (see the module doc).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SolutionPath {
    /// One linear body: the fixed point on the recovered terms.
    Linear,
    /// Newton over load steps; the reason the case takes this path.
    Newton(String),
}

/// A case ready to run: its spec, its bodies, its contact pairs, how it is
/// solved and its file name.
#[derive(Clone, Debug)]
pub struct Case {
    pub file: String,
    pub spec: CaseSpec,
    pub bodies: Vec<Body>,
    pub pairs: Vec<ContactPair>,
    pub path: SolutionPath,
    /// Whether the file wrote its one body at the top level.
    pub shorthand: bool,
}

impl Case {
    /// Reads and checks a case file.
    pub fn from_file(path: &Path) -> Result<Case> {
        Case::from_file_with(path, &[])
    }

    /// Reads a case file with `key=value` overrides (dotted keys, TOML values;
    /// a value that is not valid TOML is taken as a string).
    pub fn from_file_with(path: &Path, overrides: &[String]) -> Result<Case> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io {
            path: file.clone(),
            reason: e.to_string(),
        })?;
        Case::from_str_with(&file, &text, overrides)
    }

    /// Parses and checks case text; `file` names it in errors.
    pub fn from_str(file: &str, text: &str) -> Result<Case> {
        Case::from_str_with(file, text, &[])
    }

    /// Parses case text, applies `key=value` overrides, then checks it.
    pub fn from_str_with(file: &str, text: &str, overrides: &[String]) -> Result<Case> {
        let mut table = parse_table(file, text, overrides)?;
        let shorthand = gather_shorthand(&mut table);
        let solver_keys: Vec<String> = match table.get("solver").and_then(|s| s.as_table()) {
            Some(t) => t.keys().cloned().collect(),
            None => Vec::new(),
        };
        let asks_newton: Vec<&str> = ["load", "newton", "overlap_tolerance"]
            .into_iter()
            .filter(|k| table.contains_key(*k))
            .collect();
        let mut spec: CaseSpec = deserialize(file, table, shorthand)?;
        if spec.name.is_none() {
            spec.name = file_stem(file);
        }
        let model = Model::default_for(!spec.contact.is_empty());
        let mut bodies = Vec::with_capacity(spec.body.len());
        for b in std::mem::take(&mut spec.body) {
            bodies.push(Body {
                geometry: b.geometry.build(file)?,
                model: b.material.model.unwrap_or(model),
                spec: b,
            });
        }
        let path = solution_path(&spec, &bodies, &asks_newton);
        if let SolutionPath::Newton(_) = path {
            if !solver_keys.iter().any(|k| k == "method") {
                spec.solver.method = KrylovMethod::BiCgStab;
            }
            if spec.solver.preconditioner == Preconditioner::Auto {
                spec.solver.preconditioner = Preconditioner::Multigrid;
            }
        }
        let mut case = Case {
            file: file.into(),
            spec,
            bodies,
            pairs: Vec::new(),
            path,
            shorthand,
        };
        case.check(&solver_keys)?;
        case.pairs = case.resolve_pairs()?;
        case.check_overlap()?;
        Ok(case)
    }

    /// The key path of body `i`'s key `key` as the file writes it.
    pub fn body_key(&self, i: usize, key: &str) -> String {
        match self.shorthand {
            true => key.into(),
            false => format!("body[{i}].{key}"),
        }
    }

    /// The first body: the one body of the linear path.
    pub fn body(&self) -> &Body {
        &self.bodies[0]
    }

    /// Refuses a case that is not one linear body (the linear path's
    /// set-up), saying why it takes the Newton path.
    pub fn require_linear(&self) -> Result<()> {
        match &self.path {
            SolutionPath::Linear => Ok(()),
            SolutionPath::Newton(why) => Err(self.bad(
                "body",
                format!("the linear path solves one linear body; this case runs Newton ({why})"),
            )),
        }
    }

    /// The grid of the first body at its level (or `level` when given).
    pub fn grid(&self, level: Option<u32>) -> Result<Grid> {
        self.body_grid(0, level)
    }

    /// The grid of every body, each at its own level or all at `level`
    /// (a plane-strain body's grid is one cell thick, see [`plane_strain`]).
    pub fn grids(&self, level: Option<u32>) -> Result<Vec<Grid>> {
        (0..self.bodies.len())
            .map(|i| self.body_grid(i, level))
            .collect()
    }

    fn body_grid(&self, i: usize, level: Option<u32>) -> Result<Grid> {
        let b = &self.bodies[i];
        let spec = match b.spec.plane_strain {
            true => self.slab_grid_spec(i, level)?,
            false => b.spec.grid.clone(),
        };
        grid_of(
            &self.file,
            &self.body_key(i, "grid"),
            &spec,
            &b.geometry,
            level,
        )
    }

    /// Refuses a grid of the first body whose memory estimate exceeds
    /// `budget_bytes` (the error names `grid.level` and the largest level
    /// that fits).
    pub fn check_memory(&self, grid: &Grid, budget_bytes: u64) -> Result<()> {
        grid.check_memory(self.body().spec.element, budget_bytes)
            .map_err(|e| self.bad(&self.body_key(0, "grid.level"), e.to_string()))
    }

    /// Points per segment of the first body's cut-cell rules.
    pub fn rule_points(&self) -> usize {
        self.rule_points_of(0)
    }

    /// Points per segment of body `i`'s cut-cell rules.
    pub fn rule_points_of(&self, i: usize) -> usize {
        let spec = &self.bodies[i].spec;
        match &spec.quadrature {
            Some(q) => q.points,
            None => cut_rule_points(spec.element),
        }
    }

    /// Classifies the grid against the first body's solid with its rule; an
    /// empty or misplaced solid is reported against the case's keys.
    pub fn classify(&self, grid: &Grid) -> Result<Cells> {
        self.classify_with_progress(grid, &crate::progress::Silent)
    }

    /// [`Case::classify`], reporting the cut-cell rules built to `progress`.
    pub fn classify_with_progress(
        &self,
        grid: &Grid,
        progress: &dyn crate::progress::Progress,
    ) -> Result<Cells> {
        self.classify_in(grid, &grid.all_cells(), progress)
    }

    /// [`Case::classify_with_progress`] over the cells of `window` only
    /// ([`Cells::classify_in`]).
    pub fn classify_in(
        &self,
        grid: &Grid,
        window: &CellBox,
        progress: &dyn crate::progress::Progress,
    ) -> Result<Cells> {
        let solid = &self.body().geometry;
        Cells::classify_in(grid, solid, self.rule_points_of(0), window, progress)
            .map_err(|e| self.classify_error(0, e))
    }

    /// Classifies `grid` against body `i`'s `solid` (its geometry, clipped
    /// for plane strain: [`Case::solid`]) with the body's rule; an empty or
    /// misplaced solid is reported against the body's keys.
    pub fn classify_body(
        &self,
        i: usize,
        grid: &Grid,
        solid: &Geometry,
        progress: &dyn crate::progress::Progress,
    ) -> Result<Cells> {
        Cells::classify_with_progress(grid, solid, self.rule_points_of(i), progress)
            .map_err(|e| self.classify_error(i, e))
    }

    /// A classification's error, reported against body `i`'s keys.
    fn classify_error(&self, i: usize, e: Error) -> Error {
        let key = match e {
            Error::GeometryOutsideGrid { .. } => "grid.box_min",
            _ => "geometry",
        };
        self.bad(&self.body_key(i, key), e.to_string())
    }

    pub(crate) fn bad(&self, key: &str, reason: String) -> Error {
        bad_key(&self.file, key, reason)
    }
}

/// Gathers the body keys of a shorthand one-body case (no `body` key) into
/// `body = [{ name = "body", … }]`; whether it did.
fn gather_shorthand(table: &mut toml::Table) -> bool {
    if table.contains_key("body") {
        return false;
    }
    let keys: Vec<String> = table
        .keys()
        .filter(|k| !CASE_KEYS.contains(&k.as_str()))
        .cloned()
        .collect();
    let mut body = toml::Table::new();
    for k in keys {
        let v = table.remove(&k).expect("listed key");
        body.insert(k, v);
    }
    body.insert("name".into(), toml::Value::String(SHORTHAND_BODY.into()));
    table.insert(
        "body".into(),
        toml::Value::Array(vec![toml::Value::Table(body)]),
    );
    true
}

/// The path of a case (see the module doc): Newton with the reason, or linear.
fn solution_path(spec: &CaseSpec, bodies: &[Body], asks_newton: &[&str]) -> SolutionPath {
    let why = if bodies.len() > 1 {
        format!("it has {} bodies", bodies.len())
    } else if !spec.contact.is_empty() {
        "it has contact pairs".into()
    } else if let Some(b) = bodies.iter().find(|b| b.model != Model::Linear) {
        format!("body '{}' is {:?}", b.spec.name, b.model)
    } else if let Some(b) = bodies.iter().find(|b| b.spec.plane_strain) {
        format!("body '{}' is plane strain", b.spec.name)
    } else if let Some(b) = bodies.iter().find(|b| !b.spec.symmetry.is_empty()) {
        format!("body '{}' has symmetry planes", b.spec.name)
    } else if let Some(k) = asks_newton.first() {
        format!("it sets `{k}`")
    } else {
        return SolutionPath::Linear;
    };
    SolutionPath::Newton(why)
}

/// A case-file error of `file` at `key`.
fn bad_key(file: &str, key: &str, reason: String) -> Error {
    Error::CaseFile {
        file: file.into(),
        key: key.into(),
        reason,
    }
}

/// The stem of a case file's name (the default case name).
fn file_stem(file: &str) -> Option<String> {
    Path::new(file)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
}

/// Parses case text as TOML (an error names the line and column) and applies
/// the `key=value` overrides.
fn parse_table(file: &str, text: &str, overrides: &[String]) -> Result<toml::Table> {
    let mut table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let at = match e.span() {
            Some(s) => {
                let before = text.get(..s.start).unwrap_or(text);
                let line = before.matches('\n').count() + 1;
                let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
                format!("line {line}, column {column}")
            }
            None => "(syntax)".into(),
        };
        let reason = match e.message().trim() {
            "" => "invalid TOML syntax".to_string(),
            m => format!("invalid TOML: {m}"),
        };
        bad_key(file, &at, reason)
    })?;
    for o in overrides {
        apply_override(&mut table, o).map_err(|reason| {
            let shown = match o.char_indices().nth(80) {
                Some((i, _)) => format!("{}…", &o[..i]),
                None => o.clone(),
            };
            bad_key(file, &format!("--set {shown}"), reason)
        })?;
    }
    Ok(table)
}

/// Deserialises a parsed case; an error names the key path (for a
/// `shorthand` case, as the file writes it).
fn deserialize<T: serde::de::DeserializeOwned>(
    file: &str,
    table: toml::Table,
    shorthand: bool,
) -> Result<T> {
    serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
        let mut key = e.path().to_string();
        if shorthand {
            // The shorthand's body keys are written at the top level.
            key = match key.strip_prefix("body[0]") {
                Some(rest) => rest.trim_start_matches('.').to_string(),
                None => key,
            };
        }
        let key = if key == "." || key.is_empty() {
            "(top level)".to_string()
        } else {
            key
        };
        bad_key(file, &key, e.into_inner().message().trim().to_string())
    })
}

/// The grid of a `[grid]` table (`key` its path in the file) around
/// `geometry`, at `level` when given, else at the table's level.
fn grid_of(
    file: &str,
    key: &str,
    g: &GridSpec,
    geometry: &Geometry,
    level: Option<u32>,
) -> Result<Grid> {
    let bbox = match (g.box_min, g.box_max) {
        (Some(lo), Some(hi)) => Aabb::new(lo, hi),
        (None, None) => geometry.bounding_box(),
        _ => {
            return Err(bad_key(
                file,
                &format!("{key}.box_min"),
                "give both box_min and box_max, or neither".into(),
            ))
        }
    };
    if !bbox.is_finite() {
        return Err(bad_key(
            file,
            &format!("{key}.box_min"),
            "the geometry is unbounded: give box_min and box_max".into(),
        ));
    }
    Grid::new(&bbox, level.unwrap_or(g.level), g.offset).map_err(|e| match e {
        Error::InvalidGrid { what, reason } => bad_key(file, &format!("{key}.{what}"), reason),
        other => other,
    })
}

/// The most dotted parts a `--set` key may have.
const MAX_OVERRIDE_DEPTH: usize = 32;

/// Sets the dotted `key` of `table` to `value` (`key=value`).
fn apply_override(table: &mut toml::Table, assignment: &str) -> std::result::Result<(), String> {
    let (key, value) = assignment
        .split_once('=')
        .ok_or_else(|| "expected key=value".to_string())?;
    let parts: Vec<&str> = key.trim().split('.').collect();
    if parts.iter().any(|p| p.is_empty()) {
        return Err(format!("bad key '{key}'"));
    }
    // Deeper tables than any case needs would only overflow the stack of the
    // recursive deserialiser (case files are bounded by TOML's own limit).
    if parts.len() > MAX_OVERRIDE_DEPTH {
        return Err(format!(
            "the key has {} parts; at most {MAX_OVERRIDE_DEPTH} are accepted",
            parts.len()
        ));
    }
    let parsed: toml::Value = format!("v = {}", value.trim())
        .parse::<toml::Table>()
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(value.trim().to_string()));
    let mut t = table;
    for p in &parts[..parts.len() - 1] {
        let entry = t
            .entry(p.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        t = entry
            .as_table_mut()
            .ok_or_else(|| format!("'{p}' is not a table"))?;
    }
    t.insert(parts[parts.len() - 1].to_string(), parsed);
    Ok(())
}

#[cfg(test)]
mod tests;
