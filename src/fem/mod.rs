//! Linear elasticity on the immersed grid: the operator (matrix-free and
//! assembled), a level's operator with its pathological cells, the loads and
//! right-hand sides, and the cut cells' flux corrections. The dofs and fields
//! are in [`crate::discrete`]; the run that uses all this, in
//! [`crate::driver`].
pub mod assembled;
pub mod checks;
pub mod component_penalty;
pub mod cut_apply;
pub mod fast_apply;
mod fast_plan;
pub mod flux_consistency;
pub mod level;
pub mod moment_fit;
pub mod operator;
pub mod problem;
pub mod q1_forms;
pub mod q2_stencil;
pub mod rhs;
pub mod rigid_resultant;
pub mod split_elements;
pub mod stencil;
