//! Constructors of the primitive solids. Each validates its parameters and
//! names its boundary parts with default tags (documented per constructor).

use std::sync::Arc;

use super::surface::{Frame, Leaf, Shape};
use super::voxels::Voxels;
use super::{Geometry, Node};
use crate::error::{Error, Result};
use crate::spatial::vec3::{norm, normalize};
use crate::spatial::Aabb;

fn check_positive(what: &str, name: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidGeometry {
            what: what.into(),
            reason: format!("{name} must be a positive finite number, got {v}"),
        })
    }
}

fn check_point(what: &str, name: &str, p: [f64; 3]) -> Result<()> {
    if p.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(Error::InvalidGeometry {
            what: what.into(),
            reason: format!("{name} must be finite, got {p:?}"),
        })
    }
}

fn unit_axis(what: &str, name: &str, a: [f64; 3]) -> Result<[f64; 3]> {
    check_point(what, name, a)?;
    if norm(a) < 1e-300 {
        return Err(Error::InvalidGeometry {
            what: what.into(),
            reason: format!("{name} must be a non-zero vector"),
        });
    }
    Ok(normalize(a))
}

impl Geometry {
    /// A single-leaf geometry.
    fn leaf(shape: Shape, frame: Frame, tag: &str, bbox: Aabb) -> Geometry {
        Geometry {
            leaves: vec![Leaf {
                shape,
                frame,
                tag: 0,
            }],
            tags: vec![tag.to_string()],
            root: Node::Leaf(0),
            bbox,
        }
    }

    /// Ball of radius `r` about `center`; boundary tag `surface`.
    pub fn sphere(center: [f64; 3], r: f64) -> Result<Geometry> {
        check_positive("sphere", "radius", r)?;
        check_point("sphere", "center", center)?;
        let frame = Frame {
            t: center,
            ..Frame::IDENTITY
        };
        let bbox = Aabb::new(center.map(|c| c - r), center.map(|c| c + r));
        Ok(Geometry::leaf(Shape::Sphere { r }, frame, "surface", bbox))
    }

    /// Spherical shell `r_in < |x − c| < r_out`; tags `outer` and `inner`.
    pub fn shell(center: [f64; 3], r_in: f64, r_out: f64) -> Result<Geometry> {
        check_positive("shell", "inner radius", r_in)?;
        if r_out.is_nan() || r_out <= r_in {
            return Err(Error::InvalidGeometry {
                what: "shell".into(),
                reason: format!("outer radius {r_out} must exceed inner radius {r_in}"),
            });
        }
        let outer = Geometry::sphere(center, r_out)?.with_tag("outer");
        let inner = Geometry::sphere(center, r_in)?.with_tag("inner");
        outer.difference(inner)
    }

    /// The half-space `(x − point)·normal ≤ 0`; tag `plane`.
    pub fn half_space(point: [f64; 3], normal: [f64; 3]) -> Result<Geometry> {
        check_point("half_space", "point", point)?;
        let n = unit_axis("half_space", "normal", normal)?;
        let offset = n[0] * point[0] + n[1] * point[1] + n[2] * point[2];
        let shape = Shape::Plane { normal: n, offset };
        Ok(Geometry::leaf(
            shape,
            Frame::IDENTITY,
            "plane",
            Aabb::EVERYTHING,
        ))
    }

    /// Axis-aligned box `lo ≤ x ≤ hi`; tags `xmin, xmax, ymin, ymax, zmin, zmax`.
    pub fn cuboid(lo: [f64; 3], hi: [f64; 3]) -> Result<Geometry> {
        check_point("box", "min corner", lo)?;
        check_point("box", "max corner", hi)?;
        if (0..3).any(|i| hi[i] <= lo[i]) {
            return Err(Error::InvalidGeometry {
                what: "box".into(),
                reason: format!("max corner {hi:?} must exceed min corner {lo:?} on every axis"),
            });
        }
        let names = [["xmin", "xmax"], ["ymin", "ymax"], ["zmin", "zmax"]];
        let mut g: Option<Geometry> = None;
        for axis in 0..3 {
            for (side, name) in names[axis].iter().enumerate() {
                let mut n = [0.0; 3];
                n[axis] = if side == 0 { -1.0 } else { 1.0 };
                let p = if side == 0 { lo } else { hi };
                let h = Geometry::half_space(p, n)?.with_tag(name);
                g = Some(match g {
                    None => h,
                    Some(g) => g.intersection(h)?,
                });
            }
        }
        let mut g = g.expect("six faces");
        g.bbox = Aabb::new(lo, hi);
        Ok(g)
    }

    /// Solid cylinder of radius `r` from `p0` to `p1`; tags `side`, `bottom`
    /// (the `p0` end) and `top`.
    pub fn cylinder(p0: [f64; 3], p1: [f64; 3], r: f64) -> Result<Geometry> {
        check_positive("cylinder", "radius", r)?;
        check_point("cylinder", "start", p0)?;
        let d = [p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]];
        let axis = unit_axis("cylinder", "end − start", d)?;
        let frame = Frame::with_z_axis(p0, axis);
        let side = Geometry::leaf(Shape::Cylinder { r }, frame, "side", Aabb::EVERYTHING);
        let bottom = Geometry::half_space(p0, axis.map(|a| -a))?.with_tag("bottom");
        let top = Geometry::half_space(p1, axis)?.with_tag("top");
        let mut g = side.intersection(bottom)?.intersection(top)?;
        g.bbox = cylinder_bbox(p0, p1, axis, r);
        Ok(g)
    }

    /// Annulus (ring) `r_in < ρ < r_out` extruded from `p0` to `p1`; tags
    /// `outer`, `inner`, `bottom`, `top`.
    pub fn annulus(p0: [f64; 3], p1: [f64; 3], r_in: f64, r_out: f64) -> Result<Geometry> {
        check_positive("annulus", "inner radius", r_in)?;
        if r_out.is_nan() || r_out <= r_in {
            return Err(Error::InvalidGeometry {
                what: "annulus".into(),
                reason: format!("outer radius {r_out} must exceed inner radius {r_in}"),
            });
        }
        let outer = Geometry::cylinder(p0, p1, r_out)?.retag("side", "outer")?;
        let d = [p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]];
        let frame = Frame::with_z_axis(p0, normalize(d));
        let hole = Geometry::leaf(
            Shape::Cylinder { r: r_in },
            frame,
            "inner",
            Aabb::EVERYTHING,
        );
        let bbox = outer.bbox;
        let mut g = outer.difference(hole)?;
        g.bbox = bbox;
        Ok(g)
    }

    /// Solid torus about `axis` through `center`, major radius `big_r`, tube
    /// radius `r < big_r`; tag `surface`.
    pub fn torus(center: [f64; 3], axis: [f64; 3], big_r: f64, r: f64) -> Result<Geometry> {
        check_positive("torus", "tube radius", r)?;
        check_point("torus", "center", center)?;
        if big_r.is_nan() || big_r <= r {
            return Err(Error::InvalidGeometry {
                what: "torus".into(),
                reason: format!("major radius {big_r} must exceed tube radius {r}"),
            });
        }
        let axis = unit_axis("torus", "axis", axis)?;
        let frame = Frame::with_z_axis(center, axis);
        let half = [0, 1, 2].map(|i| {
            let s = (1.0 - axis[i] * axis[i]).max(0.0).sqrt();
            (big_r + r) * s + r * axis[i].abs()
        });
        let bbox = Aabb::new(
            [0, 1, 2].map(|i| center[i] - half[i]),
            [0, 1, 2].map(|i| center[i] + half[i]),
        );
        Ok(Geometry::leaf(
            Shape::Torus { big_r, r },
            frame,
            "surface",
            bbox,
        ))
    }
}

impl Geometry {
    /// The solid of a voxel image ([`Voxels`]): its first sample at
    /// `origin`, its axes along `axes` (unit, orthogonal: the image's
    /// sampling directions); tag `surface`.
    pub fn image(img: Voxels, origin: [f64; 3], axes: [[f64; 3]; 3]) -> Result<Geometry> {
        check_point("image", "origin", origin)?;
        for a in 0..3 {
            for b in 0..3 {
                let d: f64 = (0..3).map(|i| axes[a][i] * axes[b][i]).sum();
                let want = if a == b { 1.0 } else { 0.0 };
                if (d - want).abs() >= 1e-6 || d.is_nan() {
                    return Err(Error::InvalidGeometry {
                        what: "image".into(),
                        reason: format!("the sampling directions must be orthogonal, got {axes:?}"),
                    });
                }
            }
        }
        let frame = Frame { q: axes, t: origin };
        let (lo, hi) = img.material_box();
        let corners: Vec<[f64; 3]> = (0..8)
            .map(|k| {
                let p = [0, 1, 2].map(|i| if k >> i & 1 == 1 { hi[i] } else { lo[i] });
                [0, 1, 2]
                    .map(|i| origin[i] + axes[0][i] * p[0] + axes[1][i] * p[1] + axes[2][i] * p[2])
            })
            .collect();
        let bbox = Aabb::around(&corners);
        Ok(Geometry::leaf(
            Shape::Image(Arc::new(img)),
            frame,
            "surface",
            bbox,
        ))
    }
}

/// Tight box of a finite cylinder: per axis, the end discs' extents.
fn cylinder_bbox(p0: [f64; 3], p1: [f64; 3], axis: [f64; 3], r: f64) -> Aabb {
    let e = [0, 1, 2].map(|i| r * (1.0 - axis[i] * axis[i]).max(0.0).sqrt());
    Aabb::new(
        [0, 1, 2].map(|i| p0[i].min(p1[i]) - e[i]),
        [0, 1, 2].map(|i| p0[i].max(p1[i]) + e[i]),
    )
}
