//! The `stl` node of the `[geometry]` table: a solid bounded by a triangle
//! mesh read from STL files, with its boundary parts.
//!
//! ```toml
//! [geometry]
//! type = "stl"
//! path = "parts/plate_holes.stl"   # relative to the case file; or a list
//! scale = 1.0                      # coordinates are multiplied by it
//! tag = "surface"                  # the part of facets nothing else names
//! parts = [
//!   { name = "clamped", box = { min = [0, 0, -1], max = [30, 304.8, 14] } },
//!   { name = "top", normal = { direction = [0, 0, 1], angle_deg = 5 } },
//!   { name = "end", plane = { point = [0, 0, 0], normal = [1, 0, 0], tolerance = 0.01 } },
//! ]
//! ```
//! Boundary parts come from, in increasing priority: the `tag` key (default
//! `surface`); the solid names of an ASCII file holding several solids, or
//! the file stems when `path` lists several files (one closed surface given
//! in pieces); the `parts` selectors in order, a later one winning. A
//! selector takes the facets whose centroid lies in its `box`, whose centroid
//! lies within `tolerance` of its `plane`, and whose normal is within
//! `angle_deg` of its `normal.direction`, all of those it gives (at least
//! one); a selector that takes no facet is an error naming it.

use std::path::Path;

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::mesh::stl::read_stl;
use crate::mesh::MeshSolid;

/// Largest share of ambiguous winding numbers ([`MeshSolid::ambiguity`]) a
/// mesh may have: a closed surface has none (measured: the STL parts of
/// `cases/parts/`, T-junctions included), a surface with one facet in 24
/// removed 10%, a triangle soup 63%.
const MAX_AMBIGUITY: f64 = 0.2;

/// One file or several.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum StlPaths {
    One(String),
    Many(Vec<String>),
}

/// A box selector.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BoxSelector {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

/// A plane selector: centroids within `tolerance` of the plane.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PlaneSelector {
    pub point: [f64; 3],
    pub normal: [f64; 3],
    pub tolerance: f64,
}

/// A cone of normals.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NormalSelector {
    pub direction: [f64; 3],
    pub angle_deg: f64,
}

/// One boundary part chosen by region.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PartSelector {
    pub name: String,
    #[serde(default, rename = "box")]
    pub in_box: Option<BoxSelector>,
    #[serde(default)]
    pub plane: Option<PlaneSelector>,
    #[serde(default)]
    pub normal: Option<NormalSelector>,
}

/// The `stl` node as written.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct StlSpec {
    pub path: StlPaths,
    #[serde(default)]
    pub scale: Option<f64>,
    #[serde(default)]
    pub tag: Option<String>,
    #[serde(default)]
    pub parts: Vec<PartSelector>,
}

impl StlSpec {
    /// Reads the files (relative to the case file `file`) and builds the
    /// solid; errors name `file` and the key under `path`.
    pub fn build(&self, file: &str, path: &str) -> Result<Geometry> {
        let err = |key: &str, reason: String| Error::CaseFile {
            file: file.into(),
            key: format!("{path}.{key}"),
            reason,
        };
        let scale = self.scale.unwrap_or(1.0);
        if !(scale.is_finite() && scale > 0.0) {
            return Err(err(
                "scale",
                format!("must be positive and finite, got {scale}"),
            ));
        }
        let base = Path::new(file).parent().unwrap_or(Path::new(""));
        let names: Vec<&String> = match &self.path {
            StlPaths::One(p) => vec![p],
            StlPaths::Many(ps) if ps.is_empty() => {
                return Err(err("path", "needs at least one file".into()))
            }
            StlPaths::Many(ps) => ps.iter().collect(),
        };
        let mut tags = vec![self.tag.clone().unwrap_or_else(|| "surface".into())];
        let mut triangles = Vec::new();
        let mut tri_tags = Vec::new();
        for name in &names {
            let full = base.join(name);
            let solids = read_stl(&full).map_err(|e| err("path", e.to_string()))?;
            let several = solids.len() > 1;
            for solid in solids {
                // Several files: the file stem; several named solids: the name.
                let label = if names.len() > 1 {
                    full.file_stem().map(|s| s.to_string_lossy().to_string())
                } else {
                    Some(solid.name.clone()).filter(|n| several && !n.is_empty())
                };
                let tag = label.map_or(0, |l| tag_index(&mut tags, &l));
                tri_tags.extend(std::iter::repeat_n(tag, solid.triangles.len()));
                triangles.extend(
                    solid
                        .triangles
                        .iter()
                        .map(|t| t.map(|p| p.map(|v| v * scale))),
                );
            }
        }
        let mesh = MeshSolid::new(&triangles, &tri_tags)
            .ok_or_else(|| err("path", "every triangle is degenerate (no area)".into()))?;
        let ambiguity = mesh.ambiguity();
        if ambiguity > MAX_AMBIGUITY {
            return Err(err(
                "path",
                format!(
                    "{}: not a solid: the winding number is neither 0 nor 1 at {:.0}% of the points of its box (a triangle soup, or overlapping shells); mesh: {}",
                    names.iter().map(|n| base.join(n).display().to_string()).collect::<Vec<_>>().join(", "),
                    100.0 * ambiguity,
                    mesh.diagnostics().summary()
                ),
            ));
        }
        let (tri_tags, tags) = self.select_parts(&mesh, tags, &err)?;
        Ok(Geometry::from_mesh(mesh.with_tags(tri_tags), tags))
    }

    /// Applies the `parts` selectors.
    fn select_parts(
        &self,
        mesh: &MeshSolid,
        mut tags: Vec<String>,
        err: &dyn Fn(&str, String) -> Error,
    ) -> Result<(Vec<u16>, Vec<String>)> {
        let mut per_triangle: Vec<u16> = (0..mesh.num_triangles()).map(|t| mesh.tag(t)).collect();
        for (i, part) in self.parts.iter().enumerate() {
            let key = format!("parts[{i}]");
            if part.in_box.is_none() && part.plane.is_none() && part.normal.is_none() {
                return Err(err(
                    &key,
                    "gives no selector: give box, plane or normal".into(),
                ));
            }
            let unit_at = |v: [f64; 3], at: String| {
                unit(v).ok_or_else(|| err(&at, "must be a non-zero vector".into()))
            };
            let plane = (part.plane.as_ref())
                .map(|p| unit_at(p.normal, format!("{key}.plane.normal")).map(|n| (p, n)))
                .transpose()?;
            let cone = (part.normal.as_ref())
                .map(|c| {
                    let d = unit_at(c.direction, format!("{key}.normal.direction"))?;
                    Ok::<_, Error>((d, c.angle_deg.to_radians().cos()))
                })
                .transpose()?;
            let id = tag_index(&mut tags, &part.name);
            let mut taken = 0;
            for (t, tag) in per_triangle.iter_mut().enumerate() {
                let v = mesh.triangle(t);
                let c = [0, 1, 2].map(|k| (v[0][k] + v[1][k] + v[2][k]) / 3.0);
                let in_box = part
                    .in_box
                    .as_ref()
                    .is_none_or(|b| (0..3).all(|k| b.min[k] <= c[k] && c[k] <= b.max[k]));
                let on_plane = plane.is_none_or(|(p, n)| {
                    ((0..3).map(|k| (c[k] - p.point[k]) * n[k]).sum::<f64>()).abs() <= p.tolerance
                });
                let facing = cone.is_none_or(|(d, cos)| {
                    let n = mesh.normal(t);
                    (0..3).map(|k| n[k] * d[k]).sum::<f64>() >= cos
                });
                if in_box && on_plane && facing {
                    *tag = id;
                    taken += 1;
                }
            }
            if taken == 0 {
                return Err(err(
                    &key,
                    format!(
                        "the selector of part '{}' takes no facet of the mesh",
                        part.name
                    ),
                ));
            }
        }
        Ok((per_triangle, tags))
    }
}

/// The id of tag `name`, added if new.
fn tag_index(tags: &mut Vec<String>, name: &str) -> u16 {
    match tags.iter().position(|t| t == name) {
        Some(i) => i as u16,
        None => {
            tags.push(name.to_string());
            (tags.len() - 1) as u16
        }
    }
}

/// `v / |v|`, or `None` for a zero or non-finite vector.
fn unit(v: [f64; 3]) -> Option<[f64; 3]> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (n.is_finite() && n > 0.0).then(|| v.map(|c| c / n))
}
