//! Node reordering from the crate's lexicographic cell numbering to VTK's
//! node order for `VTK_HEXAHEDRON` (12) and `VTK_TRIQUADRATIC_HEXAHEDRON`
//! (29).
//!
//! Our cells number local node `(a, b, c)` (`a` along x) as `a + 2b + 4c`
//! (hex8, `a, b, c ∈ {0, 1}`) or `a + 3b + 9c` (hex27, 1D nodes at
//! `0, ½, 1`). VTK numbers the corners counter-clockwise, bottom face then
//! top; type 29 follows with the 12 edge midpoints on edges 0-1, 1-2, 2-3,
//! 3-0, 4-5, 5-6, 6-7, 7-4, 0-4, 1-5, 2-6, 3-7, then the face centres of
//! x = 0, x = 1, y = 0, y = 1, z = 0, z = 1, then the body centre. (The face
//! order is the one of `vtkTriQuadraticHexahedron::GetParametricCoords` and
//! its interpolation functions; the prose face list in that class's header
//! disagrees with them and is not what VTK computes with.)

/// VTK hexahedron node `i` is our lexicographic node `HEX8_VTK_TO_LEX[i]`.
const HEX8_VTK_TO_LEX: [usize; 8] = [0, 1, 3, 2, 4, 5, 7, 6];

/// VTK triquadratic hexahedron node `i` is our lexicographic node
/// `HEX27_VTK_TO_LEX[i]` (`a + 3b + 9c`).
const HEX27_VTK_TO_LEX: [usize; 27] = [
    // corners
    0, 2, 8, 6, 18, 20, 26, 24, //
    // edge midpoints: bottom face, top face, vertical edges
    1, 5, 7, 3, 19, 23, 25, 21, 9, 11, 17, 15, //
    // face centres: x-min, x-max, y-min, y-max, z-min, z-max
    12, 14, 10, 16, 4, 22, //
    // body centre
    13,
];

/// Reorders a hexahedron's per-node items (node indices, coordinates, ...)
/// from lexicographic order `a + 2b + 4c` to VTK_HEXAHEDRON order.
pub fn hex8_vtk_order_from_lexicographic<T: Copy>(lex: [T; 8]) -> [T; 8] {
    HEX8_VTK_TO_LEX.map(|i| lex[i])
}

/// Reorders a triquadratic hexahedron's per-node items from lexicographic
/// order `a + 3b + 9c` to VTK_TRIQUADRATIC_HEXAHEDRON order.
pub fn hex27_vtk_order_from_lexicographic<T: Copy>(lex: [T; 27]) -> [T; 27] {
    HEX27_VTK_TO_LEX.map(|i| lex[i])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// VTK_HEXAHEDRON reference coordinates (vtkHexahedron parametric coords).
    const VTK_HEX8: [[f64; 3]; 8] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
    ];

    /// VTK_TRIQUADRATIC_HEXAHEDRON reference coordinates, copied from
    /// `vtkTriQuadraticHexahedron::GetParametricCoords` (vtkQHexCellPCoords).
    const VTK_HEX27: [[f64; 3]; 27] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
        [0.5, 0.0, 0.0],
        [1.0, 0.5, 0.0],
        [0.5, 1.0, 0.0],
        [0.0, 0.5, 0.0],
        [0.5, 0.0, 1.0],
        [1.0, 0.5, 1.0],
        [0.5, 1.0, 1.0],
        [0.0, 0.5, 1.0],
        [0.0, 0.0, 0.5],
        [1.0, 0.0, 0.5],
        [1.0, 1.0, 0.5],
        [0.0, 1.0, 0.5],
        [0.0, 0.5, 0.5],
        [1.0, 0.5, 0.5],
        [0.5, 0.0, 0.5],
        [0.5, 1.0, 0.5],
        [0.5, 0.5, 0.0],
        [0.5, 0.5, 1.0],
        [0.5, 0.5, 0.5],
    ];

    /// Unit-cube coordinates of lexicographic node `a + n b + n² c`.
    fn lexicographic_nodes<const N: usize>(n: usize) -> [[f64; 3]; N] {
        let h = 1.0 / (n - 1) as f64;
        std::array::from_fn(|i| [i % n, (i / n) % n, i / (n * n)].map(|k| k as f64 * h))
    }

    #[test]
    fn hex8_reordering_gives_vtk_reference_coordinates() {
        let lex: [[f64; 3]; 8] = lexicographic_nodes(2);
        assert_eq!(hex8_vtk_order_from_lexicographic(lex), VTK_HEX8);
    }

    #[test]
    fn hex27_reordering_gives_vtk_reference_coordinates() {
        let lex: [[f64; 3]; 27] = lexicographic_nodes(3);
        assert_eq!(hex27_vtk_order_from_lexicographic(lex), VTK_HEX27);
    }

    #[test]
    fn reorderings_are_permutations_of_indices() {
        let mut p8 = hex8_vtk_order_from_lexicographic(std::array::from_fn(|i| i));
        p8.sort_unstable();
        assert_eq!(p8, std::array::from_fn::<usize, 8, _>(|i| i));
        let mut p27 = hex27_vtk_order_from_lexicographic(std::array::from_fn(|i| i));
        p27.sort_unstable();
        assert_eq!(p27, std::array::from_fn::<usize, 27, _>(|i| i));
    }

    #[test]
    fn hex27_corners_agree_with_hex8() {
        // Corner k of type 29 is corner k of type 12 (lex a+2b+4c ↦ 2a+6b+18c).
        let lex27: [usize; 27] = std::array::from_fn(|i| i);
        let corners27 = hex27_vtk_order_from_lexicographic(lex27);
        let lex8: [usize; 8] =
            std::array::from_fn(|i| 2 * (i % 2) + 6 * ((i / 2) % 2) + 18 * (i / 4));
        assert_eq!(corners27[..8], hex8_vtk_order_from_lexicographic(lex8));
    }
}
