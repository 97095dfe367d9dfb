//! Contact: the search, the enforcement and its tangent, Newton on contact, grids that fall anywhere, friction, Hertz and Cattaneo–Mindlin, Q2 bodies, masters on STL parts.

mod enforce;
mod friction;
mod grids;
mod hertz;
mod mindlin;
mod multigrid;
mod newton;
mod q2;
mod search;
mod stl_master;
