//! Which way a CSG leaf faces where it is the body's boundary.

use super::scalar::Dual;
use super::surface::Leaf;
use super::Geometry;
use crate::spatial::vec3::{dot, normalize};

/// How a leaf enters the body's level set where it is the boundary.
pub enum Polarity {
    /// `φ = ψ` there: the outward normal is `∇ψ/|∇ψ|`.
    Added,
    /// `φ = −ψ` there (a difference's subtrahend): the outward normal is
    /// `−∇ψ/|∇ψ|`.
    Subtracted,
}

/// Whether the point of `leaf`'s zero set nearest `x` (one Newton step) is on
/// the body's boundary as this leaf, and with which polarity.
pub fn polarity_on_boundary(
    geometry: &Geometry,
    leaf: &Leaf,
    x: [f64; 3],
    h: f64,
) -> Option<Polarity> {
    let at = |x: [f64; 3]| leaf.eval([Dual::var(x[0], 0), Dual::var(x[1], 1), Dual::var(x[2], 2)]);
    let d = at(x);
    let g2 = dot(d.d, d.d);
    if g2 == 0.0 {
        return None;
    }
    let p = [0, 1, 2].map(|a| x[a] - d.v * d.d[a] / g2);
    let n = normalize(at(p).d);
    let q = [0, 1, 2].map(|a| p[a] + 1e-6 * h * n[a]);
    let (phi, psi) = (geometry.phi(q), leaf.eval(q));
    if phi == psi {
        Some(Polarity::Added)
    } else if phi == -psi {
        Some(Polarity::Subtracted)
    } else {
        None
    }
}
