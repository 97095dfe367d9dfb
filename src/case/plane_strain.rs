//! Plane strain: a body with `plane_strain = true` is solved as a slab one
//! cell thick. Its grid box spans the x–y extent of the grid box (or the
//! geometry's) and exactly `z ∈ [−h/2, h/2]` at every level (`h` from the x–y
//! extent and the level; the z offset must be 0), its solid is the geometry
//! clipped to that slab (see [`Case::solid`]: the two caps lie on the grid's
//! two node planes and are tagged [`PLANE_STRAIN_CAP`], traction free), and
//! the Newton path holds `u_z = 0` at every node (strongly). The geometry
//! must span the slab (z from −h/2 to h/2 at least); it is meant to be a
//! prism along z.

use super::{Case, PLANE_STRAIN_CAP};
use crate::case::GridSpec;
use crate::error::Result;
use crate::geometry::Geometry;
use crate::grid::Grid;
use crate::spatial::Aabb;

impl Case {
    /// The `[grid]` of plane-strain body `i`: its x–y box, `z ∈ [−h/2, h/2]`.
    pub(super) fn slab_grid_spec(&self, i: usize, level: Option<u32>) -> Result<GridSpec> {
        let b = &self.bodies[i];
        let g = &b.spec.grid;
        if g.offset[2] != 0.0 {
            return Err(self.bad(
                &self.body_key(i, "grid.offset"),
                "a plane-strain body's grid has no z offset (its slab is z ∈ [−h/2, h/2])".into(),
            ));
        }
        let bbox = match (g.box_min, g.box_max) {
            (Some(lo), Some(hi)) => Aabb::new(lo, hi),
            _ => b.geometry.bounding_box(),
        };
        let side = (0..2).map(|a| bbox.hi[a] - bbox.lo[a]).fold(0.0, f64::max);
        let h = side / (1u64 << level.unwrap_or(g.level).min(crate::grid::MAX_LEVEL)) as f64;
        if !(bbox.is_finite() && h.is_finite() && h > 0.0) {
            // Let the grid report the bad box.
            return Ok(g.clone());
        }
        Ok(GridSpec {
            box_min: Some([bbox.lo[0], bbox.lo[1], -0.5 * h]),
            box_max: Some([bbox.hi[0], bbox.hi[1], 0.5 * h]),
            ..g.clone()
        })
    }

    /// The solid of body `i` on its grid: the geometry, or for a plane-strain
    /// body the geometry clipped to the grid's slab, whose caps (tagged
    /// [`PLANE_STRAIN_CAP`]) then lie on the grid's two node planes.
    pub fn solid(&self, i: usize, grid: &Grid) -> Result<Geometry> {
        let b = &self.bodies[i];
        if !b.spec.plane_strain {
            return Ok(b.geometry.clone());
        }
        let gb = grid.bounding_box();
        let (lo, hi) = (gb.lo[2], gb.hi[2]);
        let own = b.geometry.bounding_box();
        if !(own.lo[2] <= lo && own.hi[2] >= hi) {
            return Err(self.bad(
                &self.body_key(i, "plane_strain"),
                format!(
                    "the geometry spans z ∈ [{}, {}]; a plane-strain body must span the slab \
                     z ∈ [{lo}, {hi}]",
                    own.lo[2], own.hi[2]
                ),
            ));
        }
        let pad = grid.h;
        let slab = Geometry::cuboid(
            [gb.lo[0] - pad, gb.lo[1] - pad, lo],
            [gb.hi[0] + pad, gb.hi[1] + pad, hi],
        )?
        .with_tag(PLANE_STRAIN_CAP);
        b.geometry
            .clone()
            .intersection(slab)
            .map_err(|e| self.bad(&self.body_key(i, "geometry"), e.to_string()))
    }
}
