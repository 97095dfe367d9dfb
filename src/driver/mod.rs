//! The linear run's driver, above the physics ([`crate::fem`]) and the
//! multigrid ([`crate::multigrid`]): the whole set-up of a case ([`setup`]),
//! the recovery-based stabilisation's passes ([`stabilisation`], with the
//! recovery adapter [`recovery`]), the outer strategies around the Krylov
//! solve ([`fixed_point`], [`outer_krylov`], [`solve`], [`linear`]) and the
//! output of a solution ([`output`], [`surface_output`]).

pub mod fixed_point;
pub mod linear;
pub mod outer_krylov;
pub mod output;
pub mod recovery;
pub mod setup;
pub mod share;
pub mod solve;
pub mod stabilisation;
pub mod surface_output;
