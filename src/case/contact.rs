//! The `[[contact]]` pairs of a case: their spec, their sides resolved from
//! `body.tag`, and the check that the bodies do not overlap at the start.

use serde::Deserialize;

use super::Case;
use crate::error::Result;
use crate::spatial::Aabb;

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

impl Case {
    /// Resolves `body.tag` of every pair.
    pub(super) fn resolve_pairs(&self) -> Result<Vec<ContactPair>> {
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
    pub(super) fn check_overlap(&self) -> Result<()> {
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
                        &self.body_key(j, "geometry"),
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
