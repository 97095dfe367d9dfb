//! Tests of the geometry: signs, exact normals, boxes, CSG, motions, tags, errors.

use super::*;
use crate::error::Error;

fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() <= tol)
}

#[test]
fn sphere_sign_normal_and_box() {
    let g = Geometry::sphere([0.1, 0.2, 0.3], 0.5).unwrap();
    assert!(g.inside([0.1, 0.2, 0.3]));
    assert!(!g.inside([0.7, 0.2, 0.3]));
    let p = [0.1 + 0.3, 0.2 + 0.4, 0.3];
    assert!(g.phi(p).abs() < 1e-15);
    assert!(close(g.normal(p), [0.6, 0.8, 0.0], 1e-14));
    assert_eq!(
        g.bounding_box(),
        Aabb::new([-0.4, -0.3, -0.2], [0.6, 0.7, 0.8])
    );
}

#[test]
fn shell_tags_and_inner_normal_points_into_the_hole() {
    let g = Geometry::shell([0.0; 3], 0.5, 1.0).unwrap();
    assert_eq!(g.tag_names(), &["outer".to_string(), "inner".to_string()]);
    assert!(g.inside([0.75, 0.0, 0.0]));
    assert!(!g.inside([0.25, 0.0, 0.0]));
    assert!(!g.inside([1.25, 0.0, 0.0]));
    // Outward normal of the solid on the inner sphere points to the centre.
    assert!(close(g.normal([0.0, 0.5, 0.0]), [0.0, -1.0, 0.0], 1e-14));
    assert!(close(g.normal([0.0, 0.0, 1.0]), [0.0, 0.0, 1.0], 1e-14));
}

#[test]
fn cuboid_cylinder_annulus_torus_membership() {
    let b = Geometry::cuboid([0.0; 3], [1.0, 2.0, 3.0]).unwrap();
    assert!(b.inside([0.5, 1.0, 1.5]) && !b.inside([0.5, 2.1, 1.5]));
    assert!(close(b.normal([0.5, 2.0, 1.5]), [0.0, 1.0, 0.0], 0.0));
    assert_eq!(b.tag_names().len(), 6);

    let c = Geometry::cylinder([0.0; 3], [0.0, 0.0, 2.0], 0.5).unwrap();
    assert!(c.inside([0.3, 0.3, 1.0]) && !c.inside([0.3, 0.3, 2.1]) && !c.inside([0.4, 0.4, 1.0]));
    assert!(close(c.normal([0.5, 0.0, 1.0]), [1.0, 0.0, 0.0], 1e-14));
    assert!(close(c.normal([0.1, 0.0, 2.0]), [0.0, 0.0, 1.0], 1e-14));
    assert_eq!(
        c.bounding_box(),
        Aabb::new([-0.5, -0.5, 0.0], [0.5, 0.5, 2.0])
    );

    let a = Geometry::annulus([0.0; 3], [0.0, 0.0, 1.0], 0.6, 1.0).unwrap();
    assert!(a.inside([0.8, 0.0, 0.5]) && !a.inside([0.3, 0.0, 0.5]));
    assert!(close(a.normal([0.0, 0.6, 0.5]), [0.0, -1.0, 0.0], 1e-14));
    for t in ["outer", "inner", "bottom", "top"] {
        assert!(a.tag_id(t).is_some(), "{t}");
    }

    let t = Geometry::torus([0.0; 3], [0.0, 0.0, 1.0], 1.0, 0.25).unwrap();
    assert!(t.inside([1.0, 0.0, 0.0]) && !t.inside([0.0; 3]) && !t.inside([1.0, 0.0, 0.3]));
    assert!(close(t.normal([1.25, 0.0, 0.0]), [1.0, 0.0, 0.0], 1e-14));
    assert!(close(t.normal([0.0, 1.0, 0.25]), [0.0, 0.0, 1.0], 1e-14));
}

#[test]
fn rotation_and_translation_move_the_solid() {
    let c = Geometry::cylinder([0.0; 3], [0.0, 0.0, 2.0], 0.25).unwrap();
    // Quarter turn about y maps +z to +x; then shift by (0, 1, 0).
    let m = c
        .rotate([0.0, 1.0, 0.0], std::f64::consts::FRAC_PI_2)
        .unwrap()
        .translate([0.0, 1.0, 0.0])
        .unwrap();
    assert!(m.inside([1.5, 1.0, 0.0]) && !m.inside([-0.5, 1.0, 0.0]));
    assert!(close(m.normal([2.0, 1.0, 0.1]), [1.0, 0.0, 0.0], 1e-14));
    let bb = m.bounding_box();
    assert!(close(bb.lo, [0.0, 0.75, -0.25], 1e-14) && close(bb.hi, [2.0, 1.25, 0.25], 1e-14));
}

#[test]
fn csg_combines_signs_and_tags() {
    let a = Geometry::sphere([0.0; 3], 1.0).unwrap().with_tag("a");
    let b = Geometry::sphere([1.0, 0.0, 0.0], 1.0)
        .unwrap()
        .with_tag("b");
    let u = a.clone().union(b.clone()).unwrap();
    let i = a.clone().intersection(b.clone()).unwrap();
    let d = a.difference(b).unwrap();
    let p_only_a = [-0.5, 0.0, 0.0];
    let p_both = [0.5, 0.0, 0.0];
    assert!(u.inside(p_only_a) && u.inside(p_both));
    assert!(!i.inside(p_only_a) && i.inside(p_both));
    assert!(d.inside(p_only_a) && !d.inside(p_both));
    assert_eq!(d.tag_names(), &["a".to_string(), "b".to_string()]);
    // On the carved face of the difference the normal points into b.
    assert!(close(d.normal([0.0, 0.0, 0.0]), [1.0, 0.0, 0.0], 1e-14));
    let r = d.retag("b", "a").unwrap();
    assert_eq!(r.tag_names(), &["a".to_string()]);
    assert!(r.leaves().iter().all(|l| l.tag == 0));
}

#[test]
fn interval_bounds_enclose_samples() {
    let g = Geometry::torus([0.1, 0.0, 0.0], [1.0, 1.0, 0.0], 0.8, 0.3)
        .unwrap()
        .union(Geometry::cuboid([-0.2; 3], [0.4; 3]).unwrap())
        .unwrap();
    let b = Aabb::new([0.2, -0.1, 0.0], [0.45, 0.2, 0.3]);
    let r = g.bounds(&b);
    for k in 0..1000 {
        let t = [
            (k % 10) as f64 / 9.0,
            (k / 10 % 10) as f64 / 9.0,
            (k / 100) as f64 / 9.0,
        ];
        let p = [0, 1, 2].map(|i| b.lo[i] + t[i] * (b.hi[i] - b.lo[i]));
        let v = g.phi(p);
        assert!(v >= r.lo - 1e-12 && v <= r.hi + 1e-12);
    }
}

#[test]
fn bad_parameters_are_typed_errors() {
    assert!(matches!(
        Geometry::sphere([0.0; 3], -1.0),
        Err(Error::InvalidGeometry { .. })
    ));
    assert!(matches!(
        Geometry::sphere([0.0; 3], f64::NAN),
        Err(Error::InvalidGeometry { .. })
    ));
    assert!(matches!(
        Geometry::shell([0.0; 3], 1.0, 0.5),
        Err(Error::InvalidGeometry { .. })
    ));
    assert!(matches!(
        Geometry::cylinder([0.0; 3], [0.0; 3], 1.0),
        Err(Error::InvalidGeometry { .. })
    ));
    assert!(matches!(
        Geometry::torus([0.0; 3], [0.0, 0.0, 1.0], 0.2, 0.3),
        Err(Error::InvalidGeometry { .. })
    ));
    let a = Geometry::sphere([0.0; 3], 1.0).unwrap();
    let far = Geometry::sphere([5.0, 0.0, 0.0], 1.0).unwrap();
    assert!(matches!(
        a.clone().intersection(far),
        Err(Error::EmptyGeometry { .. })
    ));
    let big = Geometry::sphere([0.0; 3], 3.0).unwrap();
    assert!(matches!(
        a.clone().difference(big),
        Err(Error::EmptyGeometry { .. })
    ));
    assert!(matches!(
        a.retag("nope", "x"),
        Err(Error::UnknownTag { .. })
    ));
}

/// The cube `[0, 1]³` as 12 outward triangles, every tag 0.
fn unit_cube_mesh() -> crate::mesh::MeshSolid {
    let mut tris = Vec::new();
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for side in [0.0, 1.0] {
            let p = |u: f64, v: f64| {
                let mut x = [side; 3];
                x[b] = u;
                x[c] = v;
                x
            };
            let (q0, q1, q2, q3) = (p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0), p(0.0, 1.0));
            if side == 1.0 {
                tris.extend([[q0, q1, q2], [q0, q2, q3]]);
            } else {
                tris.extend([[q0, q2, q1], [q0, q3, q2]]);
            }
        }
    }
    crate::mesh::MeshSolid::new(&tris, &[0; 12]).unwrap()
}

fn cube_box(c: [f64; 3], half: f64) -> Aabb {
    Aabb::new(c.map(|v| v - half), c.map(|v| v + half))
}

#[test]
fn a_mesh_leaf_combines_with_analytic_leaves_and_keeps_its_tags() {
    let hole = Geometry::cylinder([0.5, 0.5, -1.0], [0.5, 0.5, 2.0], 0.2)
        .unwrap()
        .with_tag("hole");
    let block = Geometry::from_mesh(unit_cube_mesh(), vec!["block".into()]);
    // The mesh comes second: its triangles' tag is renumbered into the
    // combined names.
    let g = hole
        .union(Geometry::cuboid([5.0; 3], [6.0; 3]).unwrap())
        .unwrap();
    let g = g.union(block).unwrap().retag("block", "faces").unwrap();
    assert_eq!(g.tag_id("faces"), Some(7));
    assert!(g.mesh().is_none() && g.meshes().len() == 1);
    assert!((0..12).all(|t| g.meshes()[0].tag(t) == 7));
    let drilled = Geometry::from_mesh(unit_cube_mesh(), vec!["block".into()])
        .difference(Geometry::cylinder([0.5, 0.5, -1.0], [0.5, 0.5, 2.0], 0.2).unwrap())
        .unwrap()
        .translate([10.0, 0.0, 0.0])
        .unwrap();
    assert!(drilled.inside([10.1, 0.1, 0.5]) && !drilled.inside([10.5, 0.5, 0.5]));
    assert!(!drilled.inside([0.1, 0.1, 0.5]) && !drilled.inside([11.1, 0.1, 0.5]));
}

#[test]
fn over_a_box_a_tree_with_a_mesh_reduces_to_what_crosses_it() {
    // The unit cube notched by a cylinder along z through its face x = 0.
    let g = Geometry::from_mesh(unit_cube_mesh(), vec!["block".into()])
        .difference(Geometry::cylinder([0.0, 0.5, -1.0], [0.0, 0.5, 2.0], 0.2).unwrap())
        .unwrap();
    let kind = |c: [f64; 3]| match g.local(&cube_box(c, 0.03)) {
        LocalSolid::Analytic(local) => {
            let b = local.bounds(&cube_box(c, 0.03));
            if b.hi < 0.0 {
                "inside"
            } else if b.lo > 0.0 {
                "outside"
            } else {
                "analytic"
            }
        }
        LocalSolid::Mesh(_) => "mesh",
        LocalSolid::MeshOutside(_) => "cavity",
        LocalSolid::Mixed { meshes, leaves } => {
            assert_eq!((meshes.len(), leaves.len()), (1, 1));
            "mixed"
        }
    };
    assert_eq!(kind([0.5, 0.5, 0.5]), "inside");
    assert_eq!(kind([0.5, 0.5, 1.2]), "outside");
    assert_eq!(kind([0.1, 0.5, 0.5]), "outside");
    assert_eq!(kind([0.5, 0.0, 0.5]), "mesh");
    assert_eq!(kind([0.2, 0.5, 0.5]), "analytic");
    // The hole through the face z = 1: that face is a plane leaf there.
    assert_eq!(kind([0.2, 0.5, 1.0]), "analytic");
    // The hole across the cube's edge (x = 0, z = 1).
    assert_eq!(kind([0.0, 0.3, 1.0]), "mixed");
    // The cube as a cavity in a block.
    let block = Geometry::cuboid([-1.0; 3], [2.0; 3])
        .unwrap()
        .difference(Geometry::from_mesh(unit_cube_mesh(), vec!["cavity".into()]))
        .unwrap();
    let face = cube_box([0.5, 0.0, 0.5], 0.03);
    assert!(matches!(block.local(&face), LocalSolid::MeshOutside(_)));
}

#[test]
fn a_box_where_a_surface_crosses_a_mesh_edge_gets_nearly_the_analytic_twins_rule() {
    // Measured: volume 1.2e-5 of the box's apart, area 1.0e-4 of its face.
    use crate::quadrature::saye::box_rule;
    let cylinder = || Geometry::cylinder([0.0, 0.5, -1.0], [0.0, 0.5, 2.0], 0.2).unwrap();
    let mixed = Geometry::from_mesh(unit_cube_mesh(), vec!["block".into()])
        .difference(cylinder())
        .unwrap();
    let analytic = Geometry::cuboid([0.0; 3], [1.0; 3])
        .unwrap()
        .difference(cylinder())
        .unwrap();
    let b = cube_box([0.0, 0.3, 1.0], 0.03);
    let (m, a) = (
        box_rule(&mixed, &b, &[0, 1, 2], 2),
        box_rule(&analytic, &b, &[0, 1, 2], 2),
    );
    let volume = |r: &crate::quadrature::saye::BoxRule| r.volume.iter().map(|p| p.w).sum::<f64>();
    let area = |r: &crate::quadrature::saye::BoxRule| r.surface.iter().map(|p| p.w).sum::<f64>();
    let cell = 0.06f64;
    assert!((volume(&m) - volume(&a)).abs() < 1e-4 * cell.powi(3));
    assert!((area(&m) - area(&a)).abs() < 1e-3 * cell.powi(2));
    // Every boundary point faces out of the solid.
    for p in &m.surface {
        let out = [0, 1, 2].map(|i| p.x[i] + 1e-6 * p.n[i]);
        let inn = [0, 1, 2].map(|i| p.x[i] - 1e-6 * p.n[i]);
        assert!(!mixed.inside(out) && mixed.inside(inn), "{p:?}");
    }
}
