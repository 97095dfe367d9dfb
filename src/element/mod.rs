//! Finite elements on the Cartesian grid: hex8 (Q1) and hex27 (Q2).
