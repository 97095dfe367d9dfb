//! Large-deformation (total Lagrangian) hyperelasticity of one immersed body
//! (without contact): the foundation that the contact problems of
//! the paper's Problem 2 build on.
//!
//! - [`material`]: compressible neo-Hookean and St Venant–Kirchhoff, `P(F)` and
//!   the tangent `A = ∂P/∂F`.
//! - [`points`]: quadrature points stored flat, the element's nodes per cell
//!   as the stride.
//! - [`problem`]: the body on its grid (Q1 or Q2): quadrature points of inside
//!   and cut cells, Dirichlet penalty points with per-component masks
//!   (rollers), dead loads.
//! - [`residual`]: `R(u) = Σ ∫ Bᵀ P(F(u)) dV + (β/h) ∫_ΓD Nᵀ M (u − t g) dA − t f_ext`
//!   and the potential energy it derives from.
//! - [`tangent`]: `K_T(u) = ∂R/∂u` matrix-free (a [`crate::backend::LinearOperator`]),
//!   its diagonal, and assembled (faer).
//! - [`stabilisation`]: the S-term of the pathological cells, `R_S` and
//!   `K_S` with the recovered displacement held fixed between Newton passes.
//! - [`newton`]: load steps, Newton–Raphson with a line search, step cutting.
//! - [`convergence`]: the observed order of a step's last Newton iterations.
//! - [`mirror`]: the GPU kernel of the inside-cell tangent (`shaders/hyper_tangent.wgsl`),
//!   its data and its CPU mirror.
//!
//! The Dirichlet condition is the penalty part of the stabilised multiplier
//! (`β = k1 E`, the term `(β/h) ∫ N (u − g)`); at `u = 0` the
//! tangent is exactly the linear operator `K + K_p` of [`crate::fem::operator`]
//! (tested). The recovered traction of the linear path is not added on Dirichlet
//! parts (pure penalty there); the contact's recovered normal traction is, by
//! [`crate::bodies::traction`], through the passes of [`newton`] ("Recovered
//! terms").
//!
//! Typical use (what a `run` of a hyperelastic case does):
//! ```no_run
//! # use cgfem_gpu::hyper::{problem::*, material::Material, newton::*};
//! # fn f(grid: &cgfem_gpu::grid::Grid, cells: &cgfem_gpu::cells::Cells,
//! #      dirichlet: &[DirichletCondition]) -> cgfem_gpu::Result<()> {
//! let order = cgfem_gpu::element::ElementOrder::Q1;
//! let problem = HyperProblem::new(grid, cells, order, Material::neo_hookean(1000.0, 0.3),
//!                                 30.0 * 1000.0, dirichlet, &Loads::default())?;
//! let opts = NewtonOptions { steps: 5, ..NewtonOptions::default() };
//! let mut solution = HyperSolution::zero(&problem);
//! solve_load_steps(&problem, &opts, &mut CpuTangentSolver::default(),
//!                  &cgfem_gpu::progress::Silent, &mut solution)?;
//! # Ok(()) }
//! ```
pub mod convergence;
pub mod gpu;
pub mod material;
pub mod mirror;
pub mod newton;
pub mod points;
pub mod problem;
pub mod residual;
pub mod stabilisation;
pub mod tangent;
