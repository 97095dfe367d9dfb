//! Hyperelasticity and the Newton path: one body, the S-term, several bodies.

mod bodies;
mod one_body;
mod s_term;
