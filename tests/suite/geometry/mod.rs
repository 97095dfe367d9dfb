//! Geometry and cut cells: quadrature, cut volumes, moment fitting, STL parts (clean, fuzzed, dirty), voxel images, pieces.

mod cut_volume;
mod dirty_meshes;
mod image;
mod image_fuzz;
mod image_shell;
mod moment_fit;
mod pieces;
mod quadrature;
mod robustness;
mod stl_fuzz;
mod stl_parts;
