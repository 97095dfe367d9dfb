//! The GPU backend on wgpu/WGSL: adapter selection and the device
//! ([`context`]), the kernels of `shaders/` ([`kernels`]) and their CPU mirrors
//! ([`mirror`]; the device-scalar Krylov kernels' in [`mirror_krylov`]), the [`crate::backend::Backend`] implementation with the
//! operator resident on the device ([`backend`], [`operator`]), the
//! device-scalar CG/CGS/BiCGStab ([`device_krylov`]; CG's iteration in four
//! dispatches, [`fused_cg`]), the multigrid V-cycle
//! ([`multigrid`], its kernels' mirrors in [`mirror_multigrid`]), f32 inner solves inside f64 defect
//! correction ([`defect`]), the linear solver the fixed-point loop calls
//! ([`linear`]), and the windows that bind arrays larger than one storage
//! binding ([`windows`]).

pub mod backend;
pub mod context;
pub mod defect;
pub mod device_krylov;
mod entries;
pub mod fused_cg;
pub mod kernels;
pub mod linear;
pub mod mirror;
pub mod mirror_krylov;
#[cfg(test)]
mod mirror_krylov_tests;
pub mod mirror_multigrid;
pub mod multigrid;
#[cfg(test)]
mod multigrid_tests;
pub mod operator;
pub mod q1_operator;
pub mod q1_terms;
mod record;
mod staging;
#[cfg(test)]
mod tests;
pub mod windows;

pub use backend::{GpuBackend, GpuVector};
pub use context::{list_adapters, BackendChoice, GpuContext, Precision, PrecisionChoice};
pub use operator::GpuOperator;

/// For tests that need a device: the context, or `None` after printing
/// "skipped: no GPU adapter". With `CI=true` a missing adapter panics instead,
/// so that CI cannot pass without running the GPU tests.
pub fn context_or_skip(precision: PrecisionChoice) -> Option<std::sync::Arc<GpuContext>> {
    match GpuContext::new(None, precision) {
        Ok(ctx) => Some(std::sync::Arc::new(ctx)),
        Err(e) => {
            if std::env::var("CI").is_ok_and(|v| v == "true") {
                panic!("CI=true but no GPU adapter: {e}");
            }
            eprintln!("skipped: no GPU adapter ({e})");
            None
        }
    }
}
