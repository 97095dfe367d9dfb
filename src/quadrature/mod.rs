//! Quadrature: Gauss rules and cut-cell rules for implicitly defined domains.
mod branch;
pub mod gauss;
mod lines;
pub mod polyhedral;
mod roots;
pub mod saye;
