//! Quadrature: Gauss rules and cut-cell rules for implicitly defined domains.
pub mod gauss;
mod lines;
mod roots;
pub mod saye;
