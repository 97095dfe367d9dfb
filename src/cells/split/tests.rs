use super::*;
use crate::cells::glued::tests::{classify_at as classify, slotted_bar};
use crate::element::ElementOrder;
use crate::geometry::Geometry;

/// Every piece of every split cell holds volume points, and those above
/// `z_min` lie on one side of the plane `x = x0` only.
fn pieces_lie_on_one_side(grid: &Grid, cells: &Cells, split: &Split, x0: f64, z_min: f64) {
    for s in &split.cells {
        let i = cells.cut_position(s.cell).unwrap();
        let points = cells.volume_points(i);
        for piece in 0..s.pieces.len() {
            let mine: Vec<_> = points
                .iter()
                .filter(|q| s.piece_of(q.x) == piece)
                .map(|q| q.x)
                .collect();
            assert!(!mine.is_empty(), "cell {} piece {piece} is empty", s.cell);
            let above: Vec<_> = mine.iter().filter(|x| x[2] > z_min).collect();
            let left = above.iter().filter(|x| x[0] < x0).count();
            assert!(
                left == 0 || left == above.len(),
                "cell {} ({:?}) piece {piece}: {left} of {} points left of {x0}",
                s.cell,
                grid.cell_ijk(s.cell),
                above.len()
            );
        }
    }
}

#[test]
fn a_slot_thinner_than_a_cell_splits_its_cells_into_the_walls() {
    for level in [3, 4, 5] {
        let g = slotted_bar(0.1);
        let (grid, cells) = classify(&g, level);
        let split = Split::new(&grid, &cells, &g);
        assert!(!split.is_empty(), "level {level}");
        assert!(!split.extra_nodes.is_empty(), "level {level}");
        // The copies are nodes within a cell of the slot, above the ligament
        // less a cell.
        for &v in &split.extra_nodes {
            let x = grid.node_position(ElementOrder::Q1, v);
            assert!((x[0] - 2.0).abs() < 0.05 + grid.h, "{x:?}");
            assert!(x[2] > 0.2 - grid.h, "{x:?}");
        }
        pieces_lie_on_one_side(&grid, &cells, &split, 2.0, 0.2);
        // Each split cell uses an extra copy.
        for s in &split.cells {
            assert!(s.pieces.iter().flatten().any(|&c| c != PRIMARY));
        }
    }
}

#[test]
fn cubes_a_slot_apart_get_copies_and_a_wide_slot_a_bar_and_a_sphere_none() {
    let a = Geometry::cuboid([0.0; 3], [1.0; 3]).unwrap();
    let b = Geometry::cuboid([1.1, 0.0, 0.0], [2.1, 1.0, 1.0]).unwrap();
    let g = a.union(b).unwrap();
    let (grid, cells) = classify(&g, 4);
    let split = Split::new(&grid, &cells, &g);
    assert!(!split.extra_nodes.is_empty());
    pieces_lie_on_one_side(&grid, &cells, &split, 1.05, f64::NEG_INFINITY);
    for g in [
        slotted_bar(0.6),
        Geometry::cuboid([0.0; 3], [4.0, 1.0, 1.0]).unwrap(),
        Geometry::sphere([0.0; 3], 1.0).unwrap(),
    ] {
        let (grid, cells) = classify(&g, 4);
        let split = Split::new(&grid, &cells, &g);
        assert!(split.is_empty() && split.extra_nodes.is_empty());
    }
}
