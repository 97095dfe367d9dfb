//! Linear elasticity on the immersed grid: dofs, the operator (matrix-free and
//! assembled), right-hand sides, the discrete field and its error norms.
pub mod assembled;
pub mod checks;
pub mod component_penalty;
pub mod cut_apply;
pub mod fast_apply;
pub mod flux_consistency;
pub mod level;
pub mod moment_fit;
pub mod operator;
pub mod problem;
pub mod q1_forms;
pub mod rhs;
pub mod rigid_resultant;
pub mod stencil;
