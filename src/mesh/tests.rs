//! Tests of mesh solids: cleaning, diagnostics, winding numbers, STL reading.

use super::stl::parse_stl;
use super::*;

#[test]
fn a_box_has_its_volume_area_and_no_open_edge() {
    let tris = box_triangles([0.0; 3], [1.0, 2.0, 3.0]);
    let m = MeshSolid::new(&tris, &[0; 12]).unwrap();
    let d = m.diagnostics();
    assert_eq!(
        (d.triangles, d.vertices, d.open_edges, d.non_manifold_edges),
        (12, 8, 0, 0)
    );
    assert_eq!(d.misoriented_edges, 0);
    assert!(!d.flipped);
    assert!((d.volume - 6.0).abs() < 1e-14 && (d.area - 22.0).abs() < 1e-13);
    assert!((m.winding_number([0.5, 1.0, 1.5]) - 1.0).abs() < 1e-12);
    assert!(m.winding_number([1.5, 1.0, 1.5]).abs() < 1e-12);
}

#[test]
fn an_inverted_mesh_is_flipped_and_degenerate_triangles_are_dropped() {
    let mut tris: Vec<_> = box_triangles([0.0; 3], [1.0; 3])
        .into_iter()
        .map(|t| [t[0], t[2], t[1]])
        .collect();
    tris.push([[0.0; 3], [1.0, 0.0, 0.0], [0.5, 0.0, 0.0]]);
    tris.push([[0.0; 3], [0.0; 3], [1.0, 1.0, 0.0]]);
    let m = MeshSolid::new(&tris, &[0; 14]).unwrap();
    let d = m.diagnostics();
    assert!(d.flipped);
    assert_eq!(d.degenerate_dropped, 2);
    assert!((d.volume - 1.0).abs() < 1e-14);
    assert!(m.phi([0.5; 3]) < 0.0 && m.phi([0.5, 0.5, 1.5]) > 0.0);
    // Removing one triangle opens three edges.
    let open = MeshSolid::new(&tris[1..12], &[0; 11]).unwrap();
    assert_eq!(open.diagnostics().open_edges, 3);
}

/// The sphere of `tessellated_sphere` about the origin.
pub(crate) fn sphere_triangles(r: f64, k: u32) -> Vec<[[f64; 3]; 3]> {
    super::tessellated_sphere([0.0; 3], r, k)
}

#[test]
fn the_far_field_winding_number_classifies_like_the_exact_sum() {
    let m = MeshSolid::new(&sphere_triangles(1.0, 5), &vec![0; 8192]).unwrap();
    assert!(!m.diagnostics().flipped);
    let mut worst: f64 = 0.0;
    for k in 0..200 {
        let t = k as f64;
        let p = [
            (0.37 * t).sin() * 1.3,
            (0.71 * t).cos() * 1.2,
            (0.13 * t).sin() * 1.4,
        ];
        let (w, exact) = (m.winding_number(p), winding::winding_number_exact(&m, p));
        worst = worst.max((w - exact).abs());
        assert_eq!(w > 0.5, exact > 0.5, "{p:?}");
        assert_eq!(exact > 0.5, norm(p) < 0.99, "{p:?}: {exact}");
    }
    assert!(worst < 0.02, "far field off by {worst}");
}

#[test]
fn stl_reading_names_solids_and_rejects_non_stl() {
    let ascii = "solid left\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 1 0\n  endloop\n endfacet\nendsolid left\nsolid\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 1\n   vertex 1 0 1\n   vertex 0 1 1\n  endloop\n endfacet\nendsolid\n";
    let solids = parse_stl(ascii.as_bytes()).unwrap();
    assert_eq!(solids.len(), 2);
    assert_eq!(
        (solids[0].name.as_str(), solids[1].name.as_str()),
        ("left", "")
    );
    assert_eq!(solids[1].triangles[0][1], [1.0, 0.0, 1.0]);
    // A binary file whose header begins with `solid`.
    let mut bin = b"solid but binary".to_vec();
    bin.resize(80, 0);
    bin.extend(1u32.to_le_bytes());
    for v in [
        0.0f32, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0, 0.0,
    ] {
        bin.extend(v.to_le_bytes());
    }
    bin.extend([0, 0]);
    let solids = parse_stl(&bin).unwrap();
    assert_eq!(
        solids[0].triangles,
        vec![[[0.0; 3], [2.0, 0.0, 0.0], [0.0, 3.0, 0.0]]]
    );
    let truncated = parse_stl(&bin[..bin.len() - 7]).unwrap_err();
    assert!(
        truncated.contains("announces 1 triangles (134 bytes) but the file has 127"),
        "{truncated}"
    );
    assert!(parse_stl(b"").unwrap_err().contains("empty"));
    assert!(parse_stl(&[7u8; 1000])
        .unwrap_err()
        .contains("not an STL file"));
    let unclosed = parse_stl(b"solid a\n facet normal 0 0 1\n").unwrap_err();
    assert!(unclosed.contains("no `endsolid`"), "{unclosed}");
}

/// A clean box is not dirty and has no irregular facet; a box with an
/// inside-out box through its x = 1 face is dirty, and exactly the facets
/// that do not separate w = 1 from w = 0 are irregular: those of the inner
/// box outside the cube (w −1 | 0) and of the cube inside the inner box
/// (w 0 | −1); the inner box's facets inside the cube (1 | 0) are regular.
#[test]
fn irregular_facets_are_those_that_do_not_separate_inside_from_outside() {
    let cube = box_triangles([0.0; 3], [1.0; 3]);
    let clean = MeshSolid::new(&cube, &[0; 12]).unwrap();
    assert!(!clean.is_dirty());
    assert!((0..12).all(|t| !clean.irregular(t)));
    let mut tris = cube.clone();
    let inner = box_triangles([0.8, 0.3, 0.3], [1.2, 0.7, 0.7]);
    tris.extend(inner.iter().map(|t| [t[0], t[2], t[1]]));
    let dirty = MeshSolid::new(&tris, &[0; 24]).unwrap();
    assert!(dirty.is_dirty());
    for t in 0..24 {
        let v = dirty.triangle(t);
        let c = [0, 1, 2].map(|i| (v[0][i] + v[1][i] + v[2][i]) / 3.0);
        let in_cube = (0..3).all(|i| c[i] > 1e-9 && c[i] < 1.0 - 1e-9);
        let in_inner = c[0] > 0.8 && (0.3..=0.7).contains(&c[1]) && (0.3..=0.7).contains(&c[2]);
        // Irregular: the cube's facets that the inner box crosses (those of
        // x = 1) and the inner box's facets through the cube's or outside it.
        let crosses_x1 = (v.iter().any(|p| p[0] < 1.0) && v.iter().any(|p| p[0] > 1.0))
            || (c[0] - 1.0).abs() < 1e-12;
        let expected = match t < 12 {
            true => in_inner || crosses_x1,
            false => !in_cube || crosses_x1,
        };
        assert_eq!(dirty.irregular(t), expected, "facet {t} at {c:?}");
    }
}
