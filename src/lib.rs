//! cgfem-gpu: Cartesian grid finite elements for 3D solid mechanics.
pub mod element;
pub mod error;
pub mod geometry;
pub mod quadrature;

pub use error::{Error, Result};
