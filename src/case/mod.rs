//! Case files (TOML): what to solve, read with every key checked. Unknown keys
//! are rejected, and every error names the file, the key path and the reason.
//!
//! This is the foundation's part of the format: the geometry, the grid and the
//! element order. The elasticity issue adds material, loads, stabilisation and
//! solver tables.

pub mod geometry;

use std::path::Path;

use serde::Deserialize;

use crate::cells::{cut_rule_points, Cells};
use crate::element::ElementOrder;
use crate::error::{Error, Result};
use crate::geometry::{Aabb, Geometry};
use crate::grid::Grid;
pub use geometry::GeometrySpec;

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
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io {
            path: file.clone(),
            reason: e.to_string(),
        })?;
        Case::from_str(&file, &text)
    }

    /// Parses and checks case text; `file` names it in errors.
    pub fn from_str(file: &str, text: &str) -> Result<Case> {
        let de = toml::Deserializer::new(text);
        let mut spec: CaseSpec = serde_path_to_error::deserialize(de).map_err(|e| {
            let key = e.path().to_string();
            Error::CaseFile {
                file: file.into(),
                key: if key == "." {
                    "(top level)".into()
                } else {
                    key
                },
                reason: e.into_inner().message().trim().to_string(),
            }
        })?;
        if spec.name.is_none() {
            let stem = Path::new(file)
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned());
            spec.name = stem;
        }
        let geometry = spec.geometry.build(file)?;
        Ok(Case {
            file: file.into(),
            spec,
            geometry,
        })
    }

    /// The grid of the case at its level (or `level` when given).
    pub fn grid(&self, level: Option<u32>) -> Result<Grid> {
        let g = &self.spec.grid;
        let bbox = match (g.box_min, g.box_max) {
            (Some(lo), Some(hi)) => Aabb::new(lo, hi),
            (None, None) => self.geometry.bounding_box(),
            _ => {
                return Err(self.bad_key(
                    "grid.box_min",
                    "give both grid.box_min and grid.box_max, or neither".into(),
                ))
            }
        };
        if !bbox.is_finite() {
            return Err(self.bad_key(
                "grid.box_min",
                "the geometry is unbounded: give grid.box_min and grid.box_max".into(),
            ));
        }
        Grid::new(&bbox, level.unwrap_or(g.level), g.offset).map_err(|e| match e {
            Error::InvalidGrid { what, reason } => self.bad_key(&format!("grid.{what}"), reason),
            other => other,
        })
    }

    /// Refuses a grid whose memory estimate exceeds `budget_bytes` (the error
    /// names `grid.level` and the largest level that fits).
    pub fn check_memory(&self, grid: &Grid, budget_bytes: u64) -> Result<()> {
        grid.check_memory(self.spec.element, budget_bytes)
            .map_err(|e| self.bad_key("grid.level", e.to_string()))
    }

    /// Classifies the grid against the case's solid with the element's rule;
    /// an empty or misplaced solid is reported against the case's keys.
    pub fn classify(&self, grid: &Grid) -> Result<Cells> {
        Cells::classify(grid, &self.geometry, cut_rule_points(self.spec.element)).map_err(|e| {
            let key = match e {
                Error::GeometryOutsideGrid { .. } => "grid.box_min",
                _ => "geometry",
            };
            self.bad_key(key, e.to_string())
        })
    }

    fn bad_key(&self, key: &str, reason: String) -> Error {
        Error::CaseFile {
            file: self.file.clone(),
            key: key.into(),
            reason,
        }
    }
}

#[cfg(test)]
mod tests;
