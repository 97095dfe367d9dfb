//! The GPU backend on a real adapter (lavapipe in CI): kernels against their mirrors, whole solves against the CPU.

mod bodies;
mod hyper;
mod q2;
mod solves;
