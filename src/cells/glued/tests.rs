use super::*;
use crate::cells::cut_rule_points;
use crate::element::ElementOrder;
use crate::geometry::Geometry;

/// `geometry` on a level-4 grid over its box, shifted off the grid planes.
fn classify(g: &Geometry) -> (Grid, Cells) {
    classify_at(g, 4)
}

/// `geometry` on a level-`level` grid over its box, shifted off the grid
/// planes.
pub(crate) fn classify_at(g: &Geometry, level: u32) -> (Grid, Cells) {
    let grid = Grid::new(&g.bounding_box(), level, [0.3, 0.6, 0.45]).unwrap();
    let cells = Cells::classify(&grid, g, cut_rule_points(ElementOrder::Q1)).unwrap();
    (grid, cells)
}

/// A 4 × 1 × 1 bar with a slot `width` wide across it at x = 2, down to a
/// ligament 0.2 thick at z = 0 (h = 0.25 at level 4).
pub(crate) fn slotted_bar(width: f64) -> Geometry {
    let bar = Geometry::cuboid([0.0; 3], [4.0, 1.0, 1.0]).unwrap();
    let slot = Geometry::cuboid(
        [2.0 - width / 2.0, -1.0, 0.2],
        [2.0 + width / 2.0, 2.0, 2.0],
    )
    .unwrap();
    bar.difference(slot).unwrap()
}

#[test]
fn a_slot_thinner_than_a_cell_glues_nodes_at_the_slot_only() {
    let (grid, cells) = classify(&slotted_bar(0.1));
    assert!(grid.h > 0.1, "h = {}", grid.h);
    let glued = glued_nodes(&grid, &cells, &slotted_bar(0.1));
    assert!(!glued.is_empty());
    let b = nodes_box(&grid, &glued).unwrap();
    // The nodes within a cell of the slot along x (their cells within two),
    // above the ligament.
    assert!(
        b.lo[0] >= 1.95 - 2.0 * grid.h && b.hi[0] <= 2.05 + 2.0 * grid.h,
        "{b:?}"
    );
    assert!(b.hi[2] > 0.5 && b.lo[2] >= 0.2 - 2.0 * grid.h, "{b:?}");
}

#[test]
fn a_wide_slot_a_solid_bar_and_a_sphere_glue_nothing() {
    for g in [
        slotted_bar(0.6),
        Geometry::cuboid([0.0; 3], [4.0, 1.0, 1.0]).unwrap(),
        Geometry::sphere([0.0; 3], 1.0).unwrap(),
    ] {
        let (grid, cells) = classify(&g);
        assert_eq!(glued_nodes(&grid, &cells, &g), Vec::<usize>::new());
    }
}

#[test]
fn cubes_closer_than_a_cell_are_glued_and_a_cell_apart_are_not() {
    for (gap, glued) in [(0.05, true), (0.1, true), (0.5, false)] {
        let a = Geometry::cuboid([0.0; 3], [1.0; 3]).unwrap();
        let b = Geometry::cuboid([1.0 + gap, 0.0, 0.0], [2.0 + gap, 1.0, 1.0]).unwrap();
        let g = a.union(b).unwrap();
        let (grid, cells) = classify(&g);
        let nodes = glued_nodes(&grid, &cells, &g);
        assert_eq!(!nodes.is_empty(), glued, "gap {gap}: {} nodes", nodes.len());
        if glued {
            let b = nodes_box(&grid, &nodes).unwrap();
            assert!(b.lo[0] > 1.0 - 2.0 * grid.h && b.hi[0] < 1.0 + gap + 2.0 * grid.h);
        }
    }
}

#[test]
fn a_plate_thinner_than_a_cell_is_one_piece() {
    // Both faces of the plate in one cell: facing normals, one body.
    let g = Geometry::cuboid([0.0; 3], [2.0, 2.0, 0.07]).unwrap();
    let (grid, cells) = classify(&g);
    assert!(grid.h > 0.07);
    assert_eq!(glued_nodes(&grid, &cells, &g), Vec::<usize>::new());
}
