//! cgfem-gpu: Cartesian grid finite elements for 3D solid mechanics.
pub mod element;
pub mod quadrature;
