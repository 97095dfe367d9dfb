//! The contact search's geometry (docs/method.md, *Contact*): the marching-tet
//! surface converges to the exact one at rate 2, the BVH equals brute force,
//! the ray-search gap on the curved (PN) master patches equals the analytic
//! ray–sphere distance to O(h²) (measured: 0.20–0.25 h² at levels 3–6,
//! where the flat facets gave 0.29–0.34 h²), a
//! rigid motion of the master equals the opposite motion of the slave, and
//! the current configuration (Q1 interpolation, Nanson) is exact for linear
//! displacement fields.

use cgfem_gpu::cells::{CellKind, Cells};
use cgfem_gpu::contact::search::deformation_gradient;
use cgfem_gpu::contact::{area_ratio, current_normal, slave_point, MasterSurface, Surface};
use cgfem_gpu::discrete::dofs::DofMap;
use cgfem_gpu::element::ElementOrder;
use cgfem_gpu::geometry::Geometry;
use cgfem_gpu::grid::Grid;
use cgfem_gpu::spatial::vec3::{cross, norm, normalize};
use cgfem_gpu::spatial::Bvh;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const OFFSET: [f64; 3] = [0.31, 0.17, 0.59];

fn sphere_surface(level: u32) -> (Grid, Geometry, Surface) {
    let g = Geometry::sphere([0.0; 3], 1.0).unwrap();
    let grid = Grid::new(&g.bounding_box(), level, OFFSET).unwrap();
    let s = Surface::whole_boundary(&grid, &g);
    (grid, g, s)
}

fn rates(errors: &[f64]) -> Vec<f64> {
    errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect()
}

fn random_unit(rng: &mut ChaCha8Rng) -> [f64; 3] {
    loop {
        let v = [0; 3].map(|_| rng.gen_range(-1.0..1.0));
        let n = norm(v);
        if n > 0.1 && n < 1.0 {
            return v.map(|c| c / n);
        }
    }
}

#[test]
fn sphere_area_converges_at_rate_two_with_vertices_on_the_zero_set() {
    let mut errors = Vec::new();
    for level in 2..=6 {
        let (grid, g, s) = sphere_surface(level);
        let max_phi = s
            .vertices
            .iter()
            .map(|x| g.phi(*x).abs())
            .fold(0.0, f64::max);
        assert!(max_phi < 1e-10, "level {level}: |φ| up to {max_phi}");
        let area = s.area(&s.vertices);
        let err = (area - 4.0 * std::f64::consts::PI).abs();
        eprintln!(
            "level {level}: h = {:.5}, {} triangles, area {area:.8}, error {err:.3e}, max |φ| at vertices {max_phi:.1e}",
            grid.h,
            s.num_triangles()
        );
        errors.push(err);
    }
    let r = rates(&errors);
    eprintln!("area rates {r:?}");
    for &rate in &r[1..] {
        assert!((1.8..2.2).contains(&rate), "rates {r:?}");
    }
}

#[test]
fn a_one_cell_slab_with_caps_on_node_planes_keeps_its_lateral_surfaces() {
    // Plane strain as a slab one cell thick (the annuli of cases/annuli_contact.toml): the caps lie on
    // node planes, so the combined level set has no node strictly inside.
    let h = 2.0 / 16.0;
    let g = Geometry::annulus([0.0, 0.0, -h / 2.0], [0.0, 0.0, h / 2.0], 0.6, 1.0).unwrap();
    let grid = Grid::new(&g.bounding_box(), 4, [0.0; 3]).unwrap();
    assert_eq!((grid.h, grid.n[2]), (h, 1));
    let order = ElementOrder::Q1;
    let inside_nodes = (0..grid.num_nodes(order))
        .filter(|&n| g.inside(grid.node_position(order, n)))
        .count();
    assert_eq!(inside_nodes, 0, "the degenerate case this test is about");
    let cells = Cells::classify(&grid, &g, 2).unwrap();
    for (tag, r, outward) in [("outer", 1.0, 1.0), ("inner", 0.6, -1.0)] {
        let s = Surface::from_level_set(&grid, &g, &[g.tag_id(tag).unwrap()]);
        let exact = 2.0 * std::f64::consts::PI * r * h;
        let area = s.area(&s.vertices);
        eprintln!(
            "slab {tag}: {} triangles, area {area:.6} vs {exact:.6}",
            s.num_triangles()
        );
        assert!(
            (area / exact - 1.0).abs() < h * h / (r * r),
            "{tag}: {area} vs {exact}"
        );
        for t in 0..s.num_triangles() {
            let n = s.normal(&s.vertices, t);
            let x = s.reference_corners(t)[0];
            let radial = normalize([x[0], x[1], 0.0]);
            let cos = outward * (n[0] * radial[0] + n[1] * radial[1]);
            assert!(
                cos > 0.99 && n[2].abs() < 1e-12,
                "{tag}: normal {n:?} at {x:?}"
            );
            assert_ne!(cells.kinds[s.triangles[t].cell], CellKind::Outside);
        }
    }
}

#[test]
fn bvh_equals_brute_force_on_random_rays() {
    // A torus and a sphere, deformed by a smooth non-affine field.
    let g = Geometry::torus([0.0; 3], [0.3, 0.2, 1.0], 0.8, 0.25)
        .unwrap()
        .union(Geometry::sphere([0.5, -0.4, 0.3], 0.5).unwrap())
        .unwrap();
    let grid = Grid::new(&g.bounding_box(), 4, OFFSET).unwrap();
    let s = Surface::whole_boundary(&grid, &g);
    let current = s.deformed(|_, x| {
        [
            0.1 * x[1] * x[1],
            0.05 * (3.0 * x[0]).sin(),
            -0.1 * x[0] * x[2],
        ]
    });
    let bvh = Bvh::new(
        (0..s.num_triangles())
            .map(|t| s.corners(&current, t))
            .collect(),
    );
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let mut hits = 0;
    for k in 0..3000 {
        let o = [0; 3].map(|_| rng.gen_range(-1.3..1.3));
        let d = random_unit(&mut rng);
        let radius = [0.05, 0.3, f64::INFINITY][k % 3];
        let fast = bvh.nearest_hit(o, d, radius);
        assert_eq!(fast, bvh.nearest_hit_linear(o, d, radius), "ray {k}");
        hits += fast.is_some() as usize;
    }
    eprintln!("{} triangles, {hits} of 3000 rays hit", s.num_triangles());
    assert!(hits > 400);
}

/// The root of `|x + t n − c|² = 1` of smallest `|t|`.
fn ray_sphere(x: [f64; 3], n: [f64; 3], c: [f64; 3]) -> f64 {
    let d = [0, 1, 2].map(|i| x[i] - c[i]);
    let b = n.iter().zip(&d).map(|(a, b)| a * b).sum::<f64>();
    let disc = (b * b - (norm(d).powi(2) - 1.0)).sqrt();
    let (t0, t1) = (-b - disc, -b + disc);
    if t0.abs() < t1.abs() {
        t0
    } else {
        t1
    }
}

/// Slave points around the sphere about `c` (some inside it), with normals
/// within 35° of the radial direction so that no ray grazes the sphere.
fn slave_points(c: [f64; 3], count: usize) -> Vec<([f64; 3], [f64; 3])> {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    (0..count)
        .map(|_| {
            let radial = random_unit(&mut rng);
            let rho = rng.gen_range(0.9..1.3);
            let x = [0, 1, 2].map(|i| c[i] + rho * radial[i]);
            let tilt = random_unit(&mut rng).map(|v| 0.5 * v);
            let sign = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
            let n = normalize([0, 1, 2].map(|i| sign * (radial[i] + tilt[i])));
            (x, n)
        })
        .collect()
}

#[test]
fn the_sphere_is_closed_and_its_vertex_normals_are_outward() {
    let (_, _, s) = sphere_surface(4);
    // Area-weighted vertex normals within a few degrees of the radius.
    for (x, n) in s.vertices.iter().zip(&s.normals) {
        let cos: f64 = (0..3).map(|i| x[i] * n[i]).sum::<f64>() / norm(*n);
        assert!(cos > 0.99, "{x:?} {n:?}");
    }
    // Closed: every edge is shared by exactly two triangles, in opposite
    // directions.
    for t in 0..s.num_triangles() {
        let around = s.triangles_around(t);
        assert!(around.contains(&t));
        for k in 0..3 {
            let v = s.triangles[t].vertices;
            let (a, b) = (v[k], v[(k + 1) % 3]);
            let sharing = around
                .iter()
                .filter(|&&o| {
                    let w = s.triangles[o].vertices;
                    (0..3).any(|j| w[j] == b && w[(j + 1) % 3] == a)
                })
                .count();
            assert_eq!(sharing, 1, "edge {a}-{b} of triangle {t}");
        }
    }
}

#[test]
fn gap_equals_the_analytic_ray_sphere_distance_to_second_order() {
    let c = [0.1, -0.2, 0.05];
    let points = slave_points(c, 400);
    // Largest gap error over h² per level: flat facets, curved patches.
    let mut errors = [Vec::new(), Vec::new()];
    for level in 3..=6 {
        let (grid, _, s) = sphere_surface(level);
        for (curved, bound) in [(false, 0.5), (true, 0.3)] {
            let master = MasterSurface::new(&s, s.deformed(|_, _| c), curved);
            let found = master.search_all(&points, 2.0);
            let mut max_err = 0.0f64;
            for (&(x, n), hit) in points.iter().zip(&found) {
                let hit = hit.expect("every ray meets the sphere");
                let err = (hit.gap - ray_sphere(x, n, c)).abs();
                max_err = max_err.max(err);
                // x2 lies on the line, on the master surface, near the sphere.
                let on_line = [0, 1, 2].map(|i| x[i] + hit.gap * n[i] - hit.x2[i]);
                assert!(norm(on_line) < 1e-12);
                let from_c = [0, 1, 2].map(|i| hit.x2[i] - c[i]);
                assert!((norm(from_c) - 1.0).abs() < grid.h.powi(2));
                let radial = normalize(from_c);
                let cos = (0..3)
                    .map(|i| radial[i] * hit.master_normal[i])
                    .sum::<f64>();
                assert!(cos > 1.0 - grid.h, "master normal {:?}", hit.master_normal);
                let back = [0, 1, 2].map(|i| hit.reference_x2[i] + c[i] - hit.x2[i]);
                assert!(norm(back) < 1e-12);
            }
            eprintln!(
                "level {level}, curved {curved}: h = {:.5}, max |g − g_exact| = {max_err:.3e}, / h² = {:.3}",
                grid.h,
                max_err / grid.h.powi(2)
            );
            assert!(max_err < bound * grid.h.powi(2), "level {level}: {max_err}");
            errors[usize::from(curved)].push(max_err);
        }
    }
    for e in &errors {
        let r = rates(e);
        eprintln!("gap rates {r:?}");
        assert!(r.iter().all(|&x| x > 1.6), "rates {r:?}");
    }
    // The curved patches are closer to the sphere at every level.
    assert!(
        errors[1].iter().zip(&errors[0]).all(|(c, f)| c < f),
        "{errors:?}"
    );
}

#[test]
fn translating_the_master_equals_moving_the_slave_back() {
    let (_, _, s) = sphere_surface(4);
    let u = [0.13, -0.07, 0.21];
    for curved in [false, true] {
        let moved_master = MasterSurface::new(&s, s.deformed(|_, _| u), curved);
        let still_master = MasterSurface::new(&s, s.vertices.clone(), curved);
        for (x, n) in slave_points([0.0; 3], 200) {
            let a = moved_master.search([0, 1, 2].map(|i| x[i] + u[i]), n, 1.0);
            let b = still_master.search(x, n, 1.0);
            match (a, b) {
                (Some(a), Some(b)) => {
                    assert_eq!(a.triangle, b.triangle);
                    assert!((a.gap - b.gap).abs() < 1e-12, "{} vs {}", a.gap, b.gap);
                    assert!((0..3).all(|i| (a.barycentric[i] - b.barycentric[i]).abs() < 1e-9));
                }
                (a, b) => assert_eq!(a.is_some(), b.is_some()),
            }
        }
    }
}

#[test]
fn a_linear_field_moves_vertices_and_slave_normals_exactly() {
    let (grid, g, s) = sphere_surface(3);
    let cells = Cells::classify(&grid, &g, 2).unwrap();
    let dofs = DofMap::new(&grid, &cells, ElementOrder::Q1);
    let a = [[0.3, -0.1, 0.2], [0.05, -0.2, 0.1], [0.4, 0.0, 0.25]];
    let c = [0.01, 0.02, -0.03];
    let exact = |x: [f64; 3]| [0, 1, 2].map(|i| c[i] + (0..3).map(|j| a[i][j] * x[j]).sum::<f64>());
    let mut u = vec![0.0; dofs.ndofs()];
    for (k, &node) in dofs.active_to_node.iter().enumerate() {
        let v = exact(grid.node_position(ElementOrder::Q1, node as usize));
        u[3 * k..3 * k + 3].copy_from_slice(&v);
    }
    let current = s.deformed_by_field(&grid, &dofs, &u);
    for (x, xc) in s.vertices.iter().zip(&current) {
        let e = exact(*x);
        assert!((0..3).all(|i| (xc[i] - x[i] - e[i]).abs() < 1e-13));
    }
    let f = deformation_gradient(&a);
    for (i, &cell) in cells.cut.iter().enumerate() {
        for p in cells.surface_points(i) {
            let sp = slave_point(&grid, &dofs, &u, cell, p.x, p.n);
            let e = exact(p.x);
            assert!((0..3).all(|k| (sp.x[k] - p.x[k] - e[k]).abs() < 1e-13));
            assert!((0..3).all(|k| (sp.normal[k] - current_normal(&f, p.n)[k]).abs() < 1e-12));
            assert!((sp.area_ratio - area_ratio(&f, p.n)).abs() < 1e-12);
        }
    }
}

#[test]
fn nanson_agrees_with_pushed_forward_tangents() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for _ in 0..100 {
        let mut f = [[0.0; 3]; 3];
        for (i, row) in f.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (i == j) as u8 as f64 + rng.gen_range(-0.4..0.4);
            }
        }
        let t1 = random_unit(&mut rng);
        let t2 = normalize(cross(random_unit(&mut rng), t1));
        let n_ref = cross(t1, t2);
        let push = |t: [f64; 3]| [0, 1, 2].map(|i| (0..3).map(|j| f[i][j] * t[j]).sum::<f64>());
        // The current area element spanned by F t1, F t2.
        let da = cross(push(t1), push(t2));
        let j = (0..3).map(|i| f[0][i] * cross(f[1], f[2])[i]).sum::<f64>();
        let expected = normalize(da.map(|v| v * j.signum()));
        let n = current_normal(&f, n_ref);
        assert!(
            (0..3).all(|i| (n[i] - expected[i]).abs() < 1e-12),
            "{n:?} vs {expected:?}"
        );
        assert!((area_ratio(&f, n_ref) - norm(da)).abs() < 1e-12);
    }
}
