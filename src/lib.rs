//! cgfem-gpu: Cartesian grid finite elements for 3D solid mechanics.
//!
//! The modules are declared in layer order, bottom first: each imports only
//! modules declared above it (`python3 scripts/layers.py` checks it, and CI
//! runs it). docs/ARCHITECTURE.md walks through the layers and a run.
//!
//! | layer | modules |
//! |---|---|
//! | utilities | [`error`], [`progress`], [`exact`], [`comm`] |
//! | geometry utilities and writers | [`spatial`], [`output`], [`vtu`], [`plot`], [`expr`] |
//! | geometry and cut cells | [`mesh`], [`geometry`], [`quadrature`], [`element`], [`grid`], [`cells`], [`recovery`] |
//! | discretisation | [`discrete`] |
//! | linear algebra | [`backend`], [`solver`], [`condition`] |
//! | the case model | [`case`] |
//! | physics | [`fem`], [`contact`], [`multigrid`] |
//! | drivers and devices | [`driver`], [`gpu`], [`hyper`] |
//! | runs and reports | [`report`], [`distributed`], [`bodies`], [`run`], [`inspect`], [`bench`], [`reproduce`] |
// Kernels are written with explicit index loops, to read side by side with
// their WGSL twins and the formulas they implement.
#![allow(clippy::needless_range_loop)]
// The docs are the developers' (`cargo doc --document-private-items`): a
// public item's doc may point at the private helper that does the work.
#![allow(rustdoc::private_intra_doc_links)]

pub mod error;
pub mod progress;
pub mod exact;
pub mod comm;

pub mod spatial;
pub mod output;
pub mod vtu;
pub mod plot;
pub mod expr;

pub mod mesh;
pub mod geometry;
pub mod quadrature;
pub mod element;
pub mod grid;
pub mod cells;
pub mod recovery;

pub mod discrete;

pub mod backend;
pub mod solver;
pub mod condition;

pub mod case;

pub mod fem;
pub mod contact;
pub mod multigrid;

pub mod driver;
pub mod gpu;
pub mod hyper;

pub mod report;
pub mod distributed;
pub mod bodies;
pub mod run;
pub mod inspect;
pub mod bench;
pub mod reproduce;

pub use error::{Error, Result};
