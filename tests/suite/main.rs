//! The end-to-end and cross-module tests, in one binary (one link, and the
//! tests of every layer share the cores), grouped by the layer they
//! exercise, bottom first. Unit tests live beside their code in `src/`.
//!
//! `cargo test --release` runs the fast tier; `CGFEM_LONG=1` adds the
//! full-size sweeps. A group or a file alone: `cargo test --release --test
//! suite fem::patch_exact`.

mod common;

mod geometry;
mod fem;
mod contact;
mod hyper;
mod gpu;
mod runs;
