//! Several hyperelastic bodies solved together: the
//! Newton path of `cgfem-gpu run` ([`crate::case::SolutionPath`]).
//!
//! - [`problem`]: the stacked problem `[u_1; u_2; …]` — each body's total
//!   Lagrangian residual and matrix-free tangent on its block, the coupling
//!   term of [`problem::Coupling`] (contact plugs in there), held dofs.
//! - [`contact`]: the case's contact pairs as that coupling (the enforcement
//!   of [`crate::contact::enforce`], with the recovered normal traction).
//! - [`traction`]: the slave body's recovered Cauchy stress (SPR) and
//!   `T̂_N = n1 · σ̂ n1`.
//! - [`multigrid`]: the bodies' coarse levels, preconditioning the Newton
//!   tangents (`preconditioner = "multigrid"`).
//! - [`setup`]: a [`crate::case::Case`] mapped to that problem.
//! - [`output`]: the ParaView series (`solution.pvd`, one `<body>_<step>.vtu`
//!   per body and converged load step).
//! - [`symmetry`]: symmetry planes, their normal displacement held.
//! - [`run`]: the load steps with the outputs written as steps converge, and
//!   the report rows.
pub mod contact;
pub mod multigrid;
pub mod output;
pub mod problem;
pub mod run;
pub mod setup;
pub mod symmetry;
pub mod traction;
