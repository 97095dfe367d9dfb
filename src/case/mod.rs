//! Case files (TOML): what to solve, read with every key checked. Unknown keys
//! are rejected, and every error names the file, the key path and the reason.
//!
//! The geometry tree is in [`geometry`], the physics tables in [`physics`].
//! `--set key=value` overrides any key (dotted path) before checking.

pub mod bodies;
pub mod boundary;
pub mod geometry;
pub mod physics;
pub mod stl;

use std::path::Path;

use serde::Deserialize;

use crate::cells::{cut_rule_points, Cells};
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::geometry::{Aabb, Geometry};
use crate::grid::Grid;
use boundary::{check_boundary, DirichletTable, NeumannTable};
pub use geometry::GeometrySpec;
use physics::{BodyLoadSpec, ExactSpec, FieldValue, MaterialSpec, SolverSpec, StabilisationSpec};

/// A case as written in its file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CaseSpec {
    /// Name used in reports; defaults to the file stem.
    #[serde(default)]
    pub name: Option<String>,
    /// Element order, `"q1"` (default) or `"q2"`.
    #[serde(default = "default_element")]
    pub element: ElementOrder,
    pub geometry: GeometrySpec,
    #[serde(default)]
    pub grid: GridSpec,
    /// `[quadrature] points`: Gauss points per segment of the cut-cell rules
    /// (default: [`cut_rule_points`] of the element).
    #[serde(default)]
    pub quadrature: Option<QuadratureSpec>,
    pub material: MaterialSpec,
    #[serde(default)]
    pub exact: Option<ExactSpec>,
    #[serde(default)]
    pub body_load: Option<BodyLoadSpec>,
    #[serde(default)]
    pub dirichlet: DirichletTable,
    #[serde(default)]
    pub neumann: NeumannTable,
    #[serde(default)]
    pub stabilisation: StabilisationSpec,
    #[serde(default)]
    pub solver: SolverSpec,
}

fn default_element() -> ElementOrder {
    ElementOrder::Q1
}

/// The `[grid]` table.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    /// Level L: the longest side of the box is split into 2^L cells (default 4).
    #[serde(default = "default_level")]
    pub level: u32,
    /// Grid box corners; default the geometry's bounding box.
    #[serde(default)]
    pub box_min: Option<[f64; 3]>,
    #[serde(default)]
    pub box_max: Option<[f64; 3]>,
    /// Shift of the grid origin in cells, each component in [0, 1).
    #[serde(default)]
    pub offset: [f64; 3],
}

fn default_level() -> u32 {
    4
}

impl Default for GridSpec {
    fn default() -> Self {
        GridSpec {
            level: default_level(),
            box_min: None,
            box_max: None,
            offset: [0.0; 3],
        }
    }
}

/// The `[quadrature]` table.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct QuadratureSpec {
    pub points: usize,
}

/// A case ready to run: its spec, its solid and its file name.
#[derive(Clone, Debug)]
pub struct Case {
    pub file: String,
    pub spec: CaseSpec,
    pub geometry: Geometry,
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
        let table = parse_table(file, text, overrides)?;
        let mut spec: CaseSpec = deserialize(file, table)?;
        if spec.name.is_none() {
            spec.name = file_stem(file);
        }
        let geometry = spec.geometry.build(file)?;
        let case = Case {
            file: file.into(),
            spec,
            geometry,
        };
        case.check_physics()?;
        Ok(case)
    }

    /// Ranges of the physics keys, and boundary tags that exist.
    fn check_physics(&self) -> Result<()> {
        let s = &self.spec;
        if let Some(name) = &s.name {
            // The name is the default output folder, `out/<name>`.
            let plain = !name.is_empty()
                && name != "."
                && name != ".."
                && !name
                    .chars()
                    .any(|c| c == '/' || c == '\\' || c.is_control());
            if !plain {
                return Err(self.bad_key(
                    "name",
                    format!("{name:?} is not a plain folder name (no '/', '\\', '..' or control characters)"),
                ));
            }
        }
        let m = &s.material;
        if !(m.young.is_finite() && m.young > 0.0) {
            return Err(self.bad_key(
                "material.young",
                format!("E must be positive, got {}", m.young),
            ));
        }
        if !(m.poisson > -1.0 && m.poisson < 0.5) {
            return Err(self.bad_key(
                "material.poisson",
                format!("ν must lie in (-1, 0.5), got {}", m.poisson),
            ));
        }
        let st = &s.stabilisation;
        if !(st.k1.is_finite() && st.k1 > 0.0) {
            return Err(self.bad_key(
                "stabilisation.k1",
                format!("must be positive, got {}", st.k1),
            ));
        }
        if !(st.k2.is_finite() && st.k2 >= 0.0) {
            return Err(self.bad_key("stabilisation.k2", format!("must be ≥ 0, got {}", st.k2)));
        }
        if let Some(a) = st.a.filter(|a| !(0.0..1.0).contains(a)) {
            return Err(self.bad_key("stabilisation.A", format!("must lie in [0, 1), got {a}")));
        }
        let so = &s.solver;
        for (key, v) in [
            ("solver.rel_tol", so.rel_tol),
            ("solver.min_rel_tol", so.min_rel_tol),
            ("solver.fixed_point_tol", so.fixed_point_tol()),
            ("solver.inner_rel_tol", so.inner_rel_tol),
        ] {
            if !(v.is_finite() && v > 0.0 && v < 1.0) {
                return Err(self.bad_key(key, format!("must lie in (0, 1), got {v}")));
            }
        }
        if let Some(q) = &s.quadrature {
            if !(1..=12).contains(&q.points) {
                return Err(self.bad_key(
                    "quadrature.points",
                    format!("must lie in 1..=12, got {}", q.points),
                ));
            }
        }
        if so.max_iterations == 0 || so.max_fixed_point == 0 {
            return Err(self.bad_key("solver", "iteration limits must be at least 1".into()));
        }
        check_boundary(
            &self.file,
            "",
            &self.geometry,
            &s.dirichlet,
            &s.neumann,
            s.exact.is_some(),
            false,
        )?;
        if let Some(b) = &s.body_load {
            if b.value == FieldValue::Exact && s.exact.is_none() {
                return Err(self.bad_key("body_load.value", "\"exact\" needs [exact]".into()));
            }
        }
        Ok(())
    }

    /// The grid of the case at its level (or `level` when given).
    pub fn grid(&self, level: Option<u32>) -> Result<Grid> {
        grid_of(&self.file, "grid", &self.spec.grid, &self.geometry, level)
    }

    /// Refuses a grid whose memory estimate exceeds `budget_bytes` (the error
    /// names `grid.level` and the largest level that fits).
    pub fn check_memory(&self, grid: &Grid, budget_bytes: u64) -> Result<()> {
        grid.check_memory(self.spec.element, budget_bytes)
            .map_err(|e| self.bad_key("grid.level", e.to_string()))
    }

    /// Points per segment of the cut-cell rules.
    pub fn rule_points(&self) -> usize {
        match &self.spec.quadrature {
            Some(q) => q.points,
            None => cut_rule_points(self.spec.element),
        }
    }

    /// Classifies the grid against the case's solid with the element's rule;
    /// an empty or misplaced solid is reported against the case's keys.
    pub fn classify(&self, grid: &Grid) -> Result<Cells> {
        self.classify_with_progress(grid, &crate::progress::Silent)
    }

    /// [`Case::classify`], reporting the cut-cell rules built to `progress`.
    pub fn classify_with_progress(
        &self,
        grid: &Grid,
        progress: &dyn crate::progress::Progress,
    ) -> Result<Cells> {
        Cells::classify_with_progress(grid, &self.geometry, self.rule_points(), progress).map_err(
            |e| {
                let key = match e {
                    Error::GeometryOutsideGrid { .. } => "grid.box_min",
                    _ => "geometry",
                };
                self.bad_key(key, e.to_string())
            },
        )
    }

    fn bad_key(&self, key: &str, reason: String) -> Error {
        bad_key(&self.file, key, reason)
    }
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

/// Deserialises a parsed case; an error names the key path.
fn deserialize<T: serde::de::DeserializeOwned>(file: &str, table: toml::Table) -> Result<T> {
    serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
        let key = e.path().to_string();
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
