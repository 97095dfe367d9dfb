//! The discretisation layer, below the physics and the contact: the active
//! nodes and their dof numbering ([`dofs`]), a discrete field's values and
//! gradients in a cell ([`field`]), and the boundary as triangle meshes
//! ([`boundary_mesh`], [`marching`]).

pub mod boundary_mesh;
pub mod dofs;
pub mod field;
pub mod marching;
