//! Geometric contact machinery: what the contact search
//! needs, independent of the mechanics that will use it.
//!
//! - [`surface`]: a body's boundary as a triangle mesh in the reference
//!   configuration, extracted from its level set on its Cartesian grid by
//!   marching tetrahedra ([`crate::discrete::marching`]) or, on an STL part,
//!   from the part's own triangles split on the grid, and mapped to the
//!   current configuration `x = X + u(X)`.
//! - the bounding-volume hierarchy over the current triangles, with
//!   nearest-hit line queries, is [`crate::spatial::Bvh`].
//! - [`patch`]: the curved (PN) master patches on those triangles, from the
//!   current vertex normals, and the ray–patch intersection.
//! - [`search`]: the ray-tracing search of the paper's eq. 2 — from a slave
//!   point `x1` along the current slave normal `n1` to the current master
//!   surface, the normal gap `g_N = (x2 − x1)·n1` — and the current normal by
//!   Nanson's formula.
//! - [`enforce`]: the contact residual and its exact tangent by the
//!   stabilised augmented Lagrangian, frictionless or with Coulomb friction,
//!   on the two bodies' dofs.
//! - [`report`]: the per-pair, per-step `contact` row of the report.

pub mod enforce;
mod enforce_dual;
mod enforce_gap;
mod enforce_law;
mod enforce_local;
mod enforce_normals;
mod enforce_tangent;
pub mod patch;
pub mod report;
pub mod search;
pub mod surface;
mod surface_mesh;

pub use enforce::{
    contact_residual, contact_residual_and_tangent, slave_points, ContactBody, ContactPairData,
    Enforcement, FrictionState, MasterPoint, PointHistory, PointState, SlaveQuadraturePoint,
};
pub use enforce_tangent::ContactTangent;
pub use report::{ContactPoints, ContactRow, SlaveSample};
pub use search::{
    area_ratio, current_normal, slave_point, ContactPoint, MasterSurface, SlavePoint,
};
pub use surface::{Surface, SurfaceTriangle};
