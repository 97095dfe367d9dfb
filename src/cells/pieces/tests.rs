use super::*;
use crate::cells::cut_rule_points;
use crate::element::ElementOrder;
use crate::geometry::Geometry;

/// Two unit cubes along x with their near faces `gap` apart, on a level-4
/// grid over their box (h = (2 + gap)/16) shifted off the faces.
fn two_cubes(gap: f64) -> (Grid, Cells) {
    let a = Geometry::cuboid([0.0; 3], [1.0; 3]).unwrap();
    let b = Geometry::cuboid([1.0 + gap, 0.0, 0.0], [2.0 + gap, 1.0, 1.0]).unwrap();
    let g = a.union(b).unwrap();
    let grid = Grid::new(&g.bounding_box(), 4, [0.3, 0.6, 0.45]).unwrap();
    let cells = Cells::classify(&grid, &g, cut_rule_points(ElementOrder::Q1)).unwrap();
    (grid, cells)
}

/// The held points of the cut cells' surface points for which `mask` says
/// which components are held (`None`: not held).
fn held(cells: &Cells, mask: impl Fn([f64; 3]) -> Option<[f64; 3]>) -> Vec<HeldPoint> {
    let mut out = Vec::new();
    for (i, &cell) in cells.cut.iter().enumerate() {
        for q in cells.surface_points(i) {
            if let Some(mask) = mask(q.x) {
                out.push(HeldPoint {
                    cell,
                    x: q.x,
                    w: q.w,
                    mask,
                });
            }
        }
    }
    out
}

#[test]
fn cubes_a_cell_apart_are_two_pieces_and_each_has_its_volume() {
    let (grid, cells) = two_cubes(0.5);
    let pieces = Pieces::new(&grid, &cells);
    assert_eq!(pieces.count, 2);
    let s = pieces.summaries(&grid, &cells);
    for (p, lo) in s.iter().zip([0.0, 1.5]) {
        assert!((p.volume - 1.0).abs() < 1e-12, "volume {}", p.volume);
        assert!(p.cells_box.lo[0] <= lo && p.cells_box.lo[0] > lo - grid.h);
    }
    // Every cell that meets the body is in a piece, and only those.
    for (c, k) in cells.kinds.iter().enumerate() {
        assert_eq!(*k == CellKind::Outside, pieces.of_cell[c] == NO_PIECE);
    }
}

#[test]
fn cubes_closer_than_a_cell_share_nodes_and_are_one_piece() {
    let (grid, cells) = two_cubes(0.05);
    assert!(0.05 < grid.h);
    assert_eq!(Pieces::new(&grid, &cells).count, 1);
}

#[test]
fn clamping_one_cube_leaves_the_other_free_in_all_six_motions() {
    let (grid, cells) = two_cubes(0.5);
    let pieces = Pieces::new(&grid, &cells);
    let s = pieces.summaries(&grid, &cells);
    let clamp = held(&cells, |x| (x[0].abs() < 1e-12).then_some([1.0; 3]));
    let free = free_motions(&pieces, &s, clamp.iter().copied());
    assert!(free[0].is_empty(), "{:?}", free[0]);
    assert_eq!(free[1].len(), 6);
    // Both clamped: both held.
    let both = held(&cells, |x| {
        (x[0].abs() < 1e-12 || (x[0] - 2.5).abs() < 1e-12).then_some([1.0; 3])
    });
    let free = free_motions(&pieces, &s, both);
    assert!(free.iter().all(|f| f.is_empty()));
}

#[test]
fn a_roller_face_leaves_two_translations_and_one_rotation() {
    let (grid, cells) = two_cubes(0.5);
    let pieces = Pieces::new(&grid, &cells);
    let s = pieces.summaries(&grid, &cells);
    // u_x held on x = 0: the first cube may slide in y and z and spin about
    // the x axis.
    let roller = held(&cells, |x| (x[0].abs() < 1e-12).then_some([1.0, 0.0, 0.0]));
    let free = free_motions(&pieces, &s, roller);
    let first = &free[0];
    assert_eq!(first.len(), 3, "{first:?}");
    let rotations: Vec<&FreeMotion> = first.iter().filter(|m| norm(m.rotation) > 0.0).collect();
    assert_eq!(rotations.len(), 1);
    let r = rotations[0];
    let axis = r.rotation.map(|c| c / norm(r.rotation));
    assert!((axis[0].abs() - 1.0).abs() < 1e-9, "{axis:?}");
    for m in first.iter().filter(|m| norm(m.rotation) == 0.0) {
        assert!(m.translation[0].abs() < 1e-9, "{m:?}");
    }
    assert!(r.to_string().starts_with("rotation about the axis"));
}

#[test]
fn a_motion_is_split_into_its_axis_and_the_slide_along_it() {
    // u = t + ω × (x − c) with ω = e_z, c = 0 and t = (0, 2, 3): the axis is
    // x = (−2, 0, ·) (where ω × x = (0, −2, 0) cancels t's y) with a slide of 3.
    let m = motion([0.0, 2.0, 3.0], [0.0, 0.0, 1.0], [0.0; 3]);
    assert_eq!(m.point, [-2.0, 0.0, 0.0]);
    assert_eq!(m.translation, [0.0, 0.0, 3.0]);
    let t = motion([0.0, 0.0, 2.0], [0.0; 3], [1.0; 3]);
    assert_eq!(t.to_string(), "translation along (0.000, 0.000, 1.000)");
}
