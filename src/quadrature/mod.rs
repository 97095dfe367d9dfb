//! Quadrature: Gauss rules and cut-cell rules for implicitly defined domains.
mod branch;
mod crossings;
pub mod gauss;
mod lines;
pub mod mixed;
pub mod polyhedral;
pub mod repaired;
mod restricted;
mod roots;
pub mod saye;
