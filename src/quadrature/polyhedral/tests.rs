//! Tests of the polyhedral cut-cell rules: totals against the mesh's own
//! volume, area and moments, and the divergence theorem cell by cell.

use super::*;
use crate::mesh::MeshSolid;

/// A convex polyhedron with slanted faces (an octahedron refined once and
/// pushed to the sphere: 32 triangles), moved off the grid.
fn polyhedron() -> MeshSolid {
    let tris = crate::mesh::tests::sphere_triangles(0.8, 1);
    let shifted: Vec<_> = tris
        .iter()
        .map(|t| t.map(|p| [p[0] + 0.013, p[1] - 0.021, p[2] + 0.007]))
        .collect();
    MeshSolid::new(&shifted, &vec![0; shifted.len()]).unwrap()
}

/// The cells of side `h` covering the mesh, from a lattice offset by `off`.
fn cells(m: &MeshSolid, h: f64, off: f64) -> Vec<Aabb> {
    let b = m.bounding_box();
    let lo = b.lo.map(|v| v - h + off);
    let n = [0, 1, 2].map(|i| ((b.hi[i] + h - lo[i]) / h).ceil() as usize);
    let mut out = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let c = [i, j, k].map(|v| v as f64);
                let cl = [0, 1, 2].map(|a| lo[a] + c[a] * h);
                out.push(Aabb::new(cl, cl.map(|v| v + h)));
            }
        }
    }
    out
}

fn monomial(x: [f64; 3], e: [i32; 3]) -> f64 {
    (0..3).map(|i| x[i].powi(e[i])).product()
}

/// `∫_Ω x^e` from the whole triangles: `∮ x^{e+1}/(e_x+1) … n_x` by a rule
/// exact on each triangle.
fn mesh_moment(m: &MeshSolid, e: [i32; 3]) -> f64 {
    let rule = collapsed_rule(8);
    let mut s = 0.0;
    for t in 0..m.num_triangles() {
        let n = m.normal(t);
        for_each_polygon_point(m.triangle(t), &rule, |x, w| {
            s += w * n[0] * monomial(x, [e[0] + 1, e[1], e[2]]) / f64::from(e[0] + 1);
        });
    }
    s
}

#[test]
fn cell_rules_add_up_to_the_meshs_volume_area_and_moments() {
    let m = polyhedron();
    for (q, h) in [(2, 0.3), (4, 0.23), (2, 0.11)] {
        let rules: Vec<BoxRule> = cells(&m, h, 0.031)
            .iter()
            .map(|b| mesh_box_rule(&m, b, &[0, 1, 2], q))
            .collect();
        let vol: f64 = rules.iter().flat_map(|r| &r.volume).map(|p| p.w).sum();
        let area: f64 = rules.iter().flat_map(|r| &r.surface).map(|p| p.w).sum();
        let d = m.diagnostics();
        assert!(
            (vol - d.volume).abs() < 1e-13 * d.volume,
            "q {q} h {h}: {vol} vs {}",
            d.volume
        );
        assert!(
            (area - d.area).abs() < 1e-13 * d.area,
            "{area} vs {}",
            d.area
        );
        for e in [[1, 0, 0], [0, 2, 1], [2, 2, 2], [q as i32, 1, q as i32]] {
            let exact = mesh_moment(&m, e);
            let by_cells: f64 = rules
                .iter()
                .flat_map(|r| &r.volume)
                .map(|p| p.w * monomial(p.x, e))
                .sum();
            assert!(
                (by_cells - exact).abs() < 1e-13 * d.volume,
                "q {q} {e:?}: {by_cells} vs {exact}"
            );
        }
    }
}

#[test]
fn every_cell_satisfies_the_divergence_theorem_in_every_direction() {
    let m = polyhedron();
    let (q, h) = (4, 0.19);
    let mut checked = 0;
    for b in cells(&m, h, 0.017) {
        let rule = mesh_box_rule(&m, &b, &[0, 1, 2], q);
        if rule.surface.is_empty() {
            continue;
        }
        checked += 1;
        for j in 0..3 {
            let free: Vec<usize> = (0..3).filter(|&a| a != j).collect();
            let face = |side: f64| {
                let mut f = b;
                if side > 0.0 {
                    f.lo[j] = b.hi[j];
                } else {
                    f.hi[j] = b.lo[j];
                }
                mesh_box_rule(&m, &f, &free, q).volume
            };
            let (hi, lo) = (face(1.0), face(-1.0));
            // In Q_4 with total degree ≤ 2q − 2 = 6: what the boundary rule integrates
            // exactly (the volume and face rules are exact on all of Q_4).
            for e in [[1, 1, 1], [2, 0, 3], [2, 2, 2], [0, 3, 2], [1, 1, 4]] {
                let mut de = e;
                de[j] -= 1;
                let dv = |x: [f64; 3]| {
                    if e[j] == 0 {
                        0.0
                    } else {
                        f64::from(e[j]) * monomial(x, de)
                    }
                };
                let c = [0, 1, 2].map(|i| 0.5 * (b.lo[i] + b.hi[i]));
                let f = |x: [f64; 3]| monomial([0, 1, 2].map(|i| (x[i] - c[i]) / h), e);
                let df = |x: [f64; 3]| dv([0, 1, 2].map(|i| (x[i] - c[i]) / h)) / h;
                let volume: f64 = rule.volume.iter().map(|p| p.w * df(p.x)).sum();
                let boundary: f64 = rule.surface.iter().map(|p| p.w * p.n[j] * f(p.x)).sum();
                let faces: f64 = hi.iter().map(|p| p.w * f(p.x)).sum::<f64>()
                    - lo.iter().map(|p| p.w * f(p.x)).sum::<f64>();
                let defect = volume - boundary - faces;
                assert!(
                    defect.abs() < 1e-12 * h * h,
                    "axis {j} {e:?}: defect {defect:e}"
                );
            }
        }
    }
    assert!(checked > 50, "{checked}");
}

#[test]
fn faces_on_grid_planes_are_counted_once() {
    // A box whose faces lie on the planes of the lattice, and one whose faces
    // lie inside cells, in the same lattice.
    for (lo, hi) in [([0.0; 3], [1.0, 0.75, 0.5]), ([0.0; 3], [0.9, 0.75, 0.3])] {
        let tris = crate::mesh::box_triangles(lo, hi);
        let m = MeshSolid::new(&tris, &[0; 12]).unwrap();
        let h = 0.25;
        let mut vol = 0.0;
        let mut area = 0.0;
        for k in -1..5 {
            for j in -1..5 {
                for i in -1..5 {
                    let cl = [i, j, k].map(|v| f64::from(v) * h);
                    let b = Aabb::new(cl, cl.map(|v| v + h));
                    let r = mesh_box_rule(&m, &b, &[0, 1, 2], 2);
                    vol += r.volume.iter().map(|p| p.w).sum::<f64>();
                    area += r.surface.iter().map(|p| p.w).sum::<f64>();
                }
            }
        }
        let d = m.diagnostics();
        assert!(
            (vol - d.volume).abs() < 1e-14,
            "{hi:?}: volume {vol} vs {}",
            d.volume
        );
        assert!(
            (area - d.area).abs() < 1e-14,
            "{hi:?}: area {area} vs {}",
            d.area
        );
    }
}
