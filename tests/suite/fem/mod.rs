//! The linear-elastic discretisation and its driver: patch tests, convergence, boundary conditions, the stabilisation, the Q1 fast kernels, Q2, the multigrid and the outer iteration.

mod boundary_conditions;
mod elasticity;
mod fast_apply;
mod flux_consistency;
mod multigrid_fixed_point;
mod outer_fgmres;
mod patch_exact;
mod q2;
mod stabilisation;
mod symmetry;
