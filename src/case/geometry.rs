//! The `[geometry]` table of a case file: primitives, CSG and motions as a tree
//! of tables, each with a `type` key, built into a [`Geometry`].
//!
//! ```toml
//! [geometry]
//! type = "difference"
//! of = [
//!   { type = "cuboid", min = [-1, -1, -0.2], max = [1, 1, 0.2] },
//!   { type = "cylinder", start = [0, 0, -1], end = [0, 0, 1], radius = 0.3 },
//! ]
//! ```
//!
//! Types: `sphere {center, radius}`, `shell {center, inner_radius,
//! outer_radius}`, `cuboid {min, max}`, `half_space {point, normal}`,
//! `cylinder {start, end, radius}`, `annulus {start, end, inner_radius,
//! outer_radius}`, `torus {center, axis, major_radius, minor_radius}`;
//! `union {of}`, `intersection {of}`, `difference {of}` (the first minus all
//! others); `translate {by, of}`, `rotate {axis, angle_deg, of}` (about the
//! origin); `tag {name, of}` (every part of `of` renamed) and `retag {from, to,
//! of}`; `stl {path, scale, tag, parts}`, a solid bounded by a triangle mesh
//! ([`super::stl`]); `image {file, threshold, inside, spacing, origin,
//! smooth, tag}`, a solid cut out of a voxel image ([`super::image`]). Lengths are in the case's length unit; angles in degrees.

use serde::Deserialize;

use super::image::ImageSpec;
use super::stl::StlSpec;
use crate::error::{Error, Result};
use crate::geometry::Geometry;

/// One node of the geometry tree, as written in the case file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum GeometrySpec {
    Sphere {
        center: [f64; 3],
        radius: f64,
    },
    Shell {
        center: [f64; 3],
        inner_radius: f64,
        outer_radius: f64,
    },
    Cuboid {
        min: [f64; 3],
        max: [f64; 3],
    },
    HalfSpace {
        point: [f64; 3],
        normal: [f64; 3],
    },
    Cylinder {
        start: [f64; 3],
        end: [f64; 3],
        radius: f64,
    },
    Annulus {
        start: [f64; 3],
        end: [f64; 3],
        inner_radius: f64,
        outer_radius: f64,
    },
    Torus {
        center: [f64; 3],
        axis: [f64; 3],
        major_radius: f64,
        minor_radius: f64,
    },
    Union {
        of: Vec<GeometrySpec>,
    },
    Intersection {
        of: Vec<GeometrySpec>,
    },
    Difference {
        of: Vec<GeometrySpec>,
    },
    Translate {
        by: [f64; 3],
        of: Box<GeometrySpec>,
    },
    Rotate {
        axis: [f64; 3],
        angle_deg: f64,
        of: Box<GeometrySpec>,
    },
    Tag {
        name: String,
        of: Box<GeometrySpec>,
    },
    Retag {
        from: String,
        to: String,
        of: Box<GeometrySpec>,
    },
    Stl(StlSpec),
    Image(ImageSpec),
}

impl GeometrySpec {
    /// Builds the solid. Errors name the node by its path in the tree
    /// (`geometry.of[1].radius`) in [`Error::CaseFile`] form, with `file`.
    pub fn build(&self, file: &str) -> Result<Geometry> {
        self.build_at(file, "geometry")
    }

    fn build_at(&self, file: &str, path: &str) -> Result<Geometry> {
        let located = |e: Error| match e {
            Error::CaseFile { .. } => e,
            other => Error::CaseFile {
                file: file.into(),
                key: path.into(),
                reason: other.to_string(),
            },
        };
        let child = |i: usize, g: &GeometrySpec| g.build_at(file, &format!("{path}.of[{i}]"));
        let many = |of: &[GeometrySpec]| -> Result<Vec<Geometry>> {
            if of.is_empty() {
                return Err(Error::CaseFile {
                    file: file.into(),
                    key: format!("{path}.of"),
                    reason: "needs at least one solid".into(),
                });
            }
            of.iter().enumerate().map(|(i, g)| child(i, g)).collect()
        };
        let one = |of: &GeometrySpec| of.build_at(file, &format!("{path}.of"));
        match self {
            GeometrySpec::Sphere { center, radius } => Geometry::sphere(*center, *radius),
            GeometrySpec::Shell {
                center,
                inner_radius,
                outer_radius,
            } => Geometry::shell(*center, *inner_radius, *outer_radius),
            GeometrySpec::Cuboid { min, max } => Geometry::cuboid(*min, *max),
            GeometrySpec::HalfSpace { point, normal } => Geometry::half_space(*point, *normal),
            GeometrySpec::Cylinder { start, end, radius } => {
                Geometry::cylinder(*start, *end, *radius)
            }
            GeometrySpec::Annulus {
                start,
                end,
                inner_radius,
                outer_radius,
            } => Geometry::annulus(*start, *end, *inner_radius, *outer_radius),
            GeometrySpec::Torus {
                center,
                axis,
                major_radius,
                minor_radius,
            } => Geometry::torus(*center, *axis, *major_radius, *minor_radius),
            GeometrySpec::Union { of } => {
                let mut parts = many(of)?.into_iter();
                let first = parts.next().expect("non-empty");
                parts.try_fold(first, Geometry::union)
            }
            GeometrySpec::Intersection { of } => {
                let mut parts = many(of)?.into_iter();
                let first = parts.next().expect("non-empty");
                parts.try_fold(first, Geometry::intersection)
            }
            GeometrySpec::Difference { of } => {
                let mut parts = many(of)?.into_iter();
                let first = parts.next().expect("non-empty");
                parts.try_fold(first, Geometry::difference)
            }
            GeometrySpec::Translate { by, of } => one(of)?.translate(*by),
            GeometrySpec::Rotate {
                axis,
                angle_deg,
                of,
            } => one(of)?.rotate(*axis, angle_deg.to_radians()),
            GeometrySpec::Tag { name, of } => Ok(one(of)?.with_tag(name)),
            GeometrySpec::Retag { from, to, of } => one(of)?.retag(from, to),
            GeometrySpec::Stl(stl) => stl.build(file, path),
            GeometrySpec::Image(image) => image.build(file, path),
        }
        .map_err(located)
    }
}
