//! cgfem-gpu: Cartesian grid finite elements for 3D solid mechanics.
//!
//! The foundation: implicit geometry ([`geometry`]), the Cartesian grid
//! ([`grid`]), cell classification and cut-cell quadrature ([`cells`],
//! [`quadrature`]) and the hex8/hex27 elements ([`element`]).
// Kernels are written with explicit index loops, to read side by side with
// their WGSL twins and the formulas they implement.
#![allow(clippy::needless_range_loop)]
// The docs are the developers' (`cargo doc --document-private-items`): a
// public item's doc may point at the private helper that does the work.
#![allow(rustdoc::private_intra_doc_links)]

pub mod backend;
pub mod bench;
pub mod bodies;
pub mod case;
pub mod cells;
pub mod condition;
pub mod contact;
pub mod discrete;
pub mod element;
pub mod error;
pub mod expr;
pub mod fem;
pub mod geometry;
pub mod gpu;
pub mod grid;
pub mod hyper;
pub mod inspect;
pub mod mesh;
pub mod multigrid;
pub mod output;
pub mod plot;
pub mod progress;
pub mod quadrature;
pub mod recovery;
pub mod report;
pub mod reproduce;
pub mod solver;
pub mod spatial;
pub mod vtu;

pub use error::{Error, Result};
