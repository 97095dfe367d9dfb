//! cgfem-gpu: Cartesian grid finite elements for 3D solid mechanics.
//!
//! The foundation: implicit geometry ([`geometry`]), the Cartesian grid
//! ([`grid`]), cell classification and cut-cell quadrature ([`cells`],
//! [`quadrature`]) and the hex8/hex27 elements ([`element`]).
pub mod cells;
pub mod element;
pub mod error;
pub mod geometry;
pub mod grid;
pub mod quadrature;

pub use error::{Error, Result};
