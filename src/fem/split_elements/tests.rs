use crate::backend::LinearOperator;
use crate::case::Case;
use crate::driver::setup::Setup;
use crate::multigrid::tests::{scrambled, slotted_bar};

/// Two unit cubes 0.1 apart along x (less than a cell at level 4), with no
/// condition and no S-term (whose mass holds translations): the set-up of
/// an operator only.
fn two_cubes() -> Case {
    let text = "[geometry]\ntype = \"union\"\nof = [\n\
        { type = \"cuboid\", min = [0, 0, 0], max = [1, 1, 1] },\n\
        { type = \"cuboid\", min = [1.1, 0, 0], max = [2.1, 1, 1] },\n]\n\
        [grid]\nlevel = 4\noffset = [0.3, 0.6, 0.45]\n\
        [material]\nyoung = 1000.0\npoisson = 0.3\n\
        [solver]\npreconditioner = \"jacobi\"\n[stabilisation]\nk2 = 0\n";
    Case::from_str("two_cubes.toml", text).unwrap()
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// Moving the second cube alone (its nodes and copies translated, the first
/// cube's at rest) costs no energy: `A u = 0` to round-off. With the nodes
/// shared (no copies) the same motion strains the cells of the gap.
#[test]
fn one_of_two_cubes_closer_than_a_cell_translates_freely() {
    let setup = Setup::new(&two_cubes(), None).unwrap();
    let op = &setup.op;
    assert!(op.dofs.has_copies());
    assert_eq!(setup.pieces.count, 2);
    // The active nodes of the second cube's elements: its cells' and pieces'.
    let mut second = vec![false; op.dofs.num_active()];
    let mut first = vec![false; op.dofs.num_active()];
    let mut nodes = [0usize; 8];
    for c in 0..op.grid.num_cells() {
        if setup.cells.kinds[c] == crate::cells::CellKind::Outside {
            continue;
        }
        let b = op.grid.cell_box(c);
        let centre = [0, 1, 2].map(|a| 0.5 * (b.lo[a] + b.hi[a]));
        let pieces: Vec<(usize, bool)> = match op.dofs.split.cell(c) {
            Some(s) => {
                let i = setup.cells.cut_position(c).unwrap();
                (0..s.pieces.len())
                    .map(|p| {
                        let q = setup
                            .cells
                            .volume_points(i)
                            .iter()
                            .find(|q| s.piece_of(q.x) == p);
                        (p, q.unwrap().x[0] > 1.05)
                    })
                    .collect()
            }
            None => vec![(usize::MAX, centre[0] > 1.05)],
        };
        for (p, is_second) in pieces {
            match op.dofs.split.cell(c) {
                Some(s) => op.dofs.piece_active_nodes(&op.grid, s, p, &mut nodes),
                None => op.dofs.cell_active_nodes(&op.grid, c, &mut nodes),
            }
            for &a in &nodes {
                match is_second {
                    true => second[a] = true,
                    false => first[a] = true,
                }
            }
        }
    }
    assert!(
        first.iter().zip(&second).all(|(a, b)| !(a & b)),
        "a node in both cubes"
    );
    let n = op.nrows();
    let u: Vec<f64> = (0..n)
        .map(|i| {
            if second[i / 3] && i % 3 == 0 {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    let mut au = vec![0.0; n];
    op.apply(&u, &mut au);
    let scale = max_abs(&op.diagonal());
    assert!(
        max_abs(&au) <= 1e-12 * scale,
        "|A u| = {:e} of {scale:e}",
        max_abs(&au)
    );
}

/// The fast apply, the node-centred gather and the assembled matrix agree
/// on an operator with copies.
#[test]
fn apply_gather_and_assembly_agree_with_copies() {
    let setup = Setup::new(&slotted_bar(), Some(5)).unwrap();
    let op = &setup.op;
    assert!(op.dofs.has_copies());
    let n = op.nrows();
    let x = scrambled(n, 1);
    let (mut fast, mut gather, mut assembled) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    op.apply(&x, &mut fast);
    op.apply_gather(&x, &mut gather);
    let a = op.assemble();
    for j in 0..n {
        for (&i, v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
            assembled[i] += v * x[j];
        }
    }
    let scale = max_abs(&fast);
    for (name, other) in [("gather", &gather), ("assembled", &assembled)] {
        let d: Vec<f64> = fast.iter().zip(other).map(|(p, q)| p - q).collect();
        assert!(max_abs(&d) <= 1e-13 * scale, "{name}: {:e}", max_abs(&d));
    }
    let diagonal = op.diagonal();
    for i in 0..n {
        let own = a
            .row_idx_of_col_raw(i)
            .iter()
            .position(|&r| r == i)
            .unwrap();
        assert!(
            (a.val_of_col(i)[own] - diagonal[i]).abs() <= 1e-13 * scale,
            "dof {i}"
        );
    }
}
