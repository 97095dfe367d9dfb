//! Case text shared by the end-to-end tests of the binary: the paper's sphere
//! (Problem 1) split into its geometry and its physics, so that tests can
//! edit one part or insert a `[grid]` table between them; running the binary
//! on such text ([`cli`]).

/// The unit sphere at the origin, as the `[geometry]` table.
pub const SPHERE: &str = "[geometry]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\n";

/// The physics of the paper's sphere (material, exact field, Dirichlet data
/// from it, CG with Jacobi), appended after the geometry and grid.
pub const PHYSICS: &str = r#"
[material]
young = 1000.0
poisson = 0.3
[exact]
displacement = ["x + x^2 - 2*x*y + x^3 - 3*x*y^2 + x^2*y", "-y - 2*x*y - 3*x^2*y + y^3 - x*y^2", "0"]
[dirichlet.surface]
value = "exact"
[solver]
method = "cg"
preconditioner = "jacobi"
"#;

/// `text` followed by the sphere's physics.
pub fn with_physics(text: &str) -> String {
    format!("{text}{PHYSICS}")
}

pub mod cli;
pub mod patch_check;
#[cfg(unix)]
pub mod sigint;
