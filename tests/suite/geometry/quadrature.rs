//! Cut-cell quadrature against exact values: convergence on the sphere, exact
//! moments of the ball, and the divergence theorem cell by cell.

use cgfem_gpu::cells::{cut_rule_points, Cells};
use cgfem_gpu::element::ElementOrder;
use cgfem_gpu::geometry::Geometry;
use cgfem_gpu::grid::Grid;
use cgfem_gpu::quadrature::saye::box_rule;
use cgfem_gpu::spatial::Aabb;
use std::f64::consts::PI;

fn unit_sphere_errors(order: ElementOrder, level: u32) -> (f64, f64) {
    let g = Geometry::sphere([0.0; 3], 1.0).unwrap();
    let grid = Grid::new(&g.bounding_box(), level, [0.0; 3]).unwrap();
    let cells = Cells::classify(&grid, &g, cut_rule_points(order)).unwrap();
    let v = 4.0 / 3.0 * PI;
    let a = 4.0 * PI;
    (
        (cells.volume(&grid) - v).abs() / v,
        (cells.boundary_area() - a).abs() / a,
    )
}

/// The area's convergence rates between consecutive levels 3–6 (the volume's
/// are in `tests/suite/geometry/cut_volume.rs`: its rule takes more points where a height
/// function's branch point is near, so its errors fall irregularly).
fn check_area_rates(order: ElementOrder, min_rate: f64) -> Vec<(f64, f64)> {
    let errors: Vec<(f64, f64)> = (3..=6).map(|l| unit_sphere_errors(order, l)).collect();
    for (l, w) in errors.windows(2).enumerate() {
        let ra = (w[0].1 / w[1].1).log2();
        println!(
            "{order:?} levels {}-{}: volume errors {:.2e}, {:.2e}, area rate {ra:.2}",
            l + 3,
            l + 4,
            w[0].0,
            w[1].0
        );
        assert!(
            ra >= min_rate,
            "{order:?} area rate {ra} at level {}",
            l + 4
        );
    }
    errors
}

#[test]
fn sphere_area_converges_q1() {
    check_area_rates(ElementOrder::Q1, 2.0);
}

#[test]
fn sphere_area_converges_q2() {
    let errors = check_area_rates(ElementOrder::Q2, 3.0);
    assert!(errors[2].0 < 1e-6, "level 5 volume error {}", errors[2].0);
}

/// `∫_{|x|<1} x^a y^b z^c = 2 Γ(α)Γ(β)Γ(γ) / (Γ(α+β+γ) (a+b+c+3))`,
/// `α = (a+1)/2`…, zero when an exponent is odd.
fn ball_moment(a: u32, b: u32, c: u32) -> f64 {
    if a % 2 == 1 || b % 2 == 1 || c % 2 == 1 {
        return 0.0;
    }
    // Γ at half-integers and integers: Γ(n/2) by recurrence from Γ(1/2), Γ(1).
    fn gamma_half(n: u32) -> f64 {
        if n == 1 {
            PI.sqrt()
        } else if n == 2 {
            1.0
        } else {
            (n as f64 / 2.0 - 1.0) * gamma_half(n - 2)
        }
    }
    let (ga, gb, gc) = (gamma_half(a + 1), gamma_half(b + 1), gamma_half(c + 1));
    2.0 * ga * gb * gc / (gamma_half(a + b + c + 3) * (a + b + c + 3) as f64)
}

#[test]
fn exact_moments_of_the_ball() {
    assert!((ball_moment(0, 0, 0) - 4.0 / 3.0 * PI).abs() < 1e-14);
    assert!((ball_moment(2, 0, 0) - 4.0 / 15.0 * PI).abs() < 1e-14);
    let g = Geometry::sphere([0.0; 3], 1.0).unwrap();
    // An offset grid so that no symmetry hides errors.
    let grid = Grid::new(&g.bounding_box(), 5, [0.31, 0.47, 0.13]).unwrap();
    let order = ElementOrder::Q2;
    let cells = Cells::classify(&grid, &g, cut_rule_points(order)).unwrap();
    let mut worst: f64 = 0.0;
    for a in 0..=4u32 {
        for b in 0..=(4 - a) {
            for c in 0..=(4 - a - b) {
                let mut sum = 0.0;
                cells.for_each_volume_point(&grid, 3, |x, w| {
                    sum += w * x[0].powi(a as i32) * x[1].powi(b as i32) * x[2].powi(c as i32)
                });
                let exact = ball_moment(a, b, c);
                let err = (sum - exact).abs() / ball_moment(0, 0, 0);
                worst = worst.max(err);
                assert!(err < 1e-9, "moment ({a},{b},{c}): {sum} vs {exact}");
            }
        }
    }
    println!("worst moment error relative to the volume: {worst:.2e}");
}

/// `F = (x²y + z³ + 1, y²z − xz, xyz + z² + y³)`, `∇·F = 3xy + 2yz + 2z`.
fn field(x: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = x;
    [
        x * x * y + z * z * z + 1.0,
        y * y * z - x * z,
        x * y * z + z * z + y * y * y,
    ]
}

fn divergence(x: [f64; 3]) -> f64 {
    3.0 * x[0] * x[1] + 2.0 * x[1] * x[2] + 2.0 * x[2]
}

/// Σ over cut cells of `∫_{c∩Ω} ∇·F − ∫_{c∩∂Ω} F·n − ∫_{∂c∩Ω} F·n_c`,
/// relative to the summed magnitudes of the flux terms.
fn divergence_defect(g: &Geometry, level: u32, offset: [f64; 3], q: usize) -> f64 {
    let grid = Grid::new(&g.bounding_box(), level, offset).unwrap();
    let cells = Cells::classify(&grid, g, q).unwrap();
    let mut defect = 0.0;
    let mut scale = 0.0;
    for (i, &c) in cells.cut.iter().enumerate() {
        let vol: f64 = cells
            .volume_points(i)
            .iter()
            .map(|p| p.w * divergence(p.x))
            .sum();
        let surf: f64 = cells
            .surface_points(i)
            .iter()
            .map(|p| {
                let f = field(p.x);
                p.w * (f[0] * p.n[0] + f[1] * p.n[1] + f[2] * p.n[2])
            })
            .sum();
        let b = grid.cell_box(c);
        let mut faces = 0.0;
        let mut face_abs = 0.0;
        for axis in 0..3 {
            let free: Vec<usize> = (0..3).filter(|&a| a != axis).collect();
            for (sign, v) in [(-1.0, b.lo[axis]), (1.0, b.hi[axis])] {
                let mut fb = b;
                fb.lo[axis] = v;
                fb.hi[axis] = v;
                let rule = box_rule(g, &fb, &free, q);
                let flux: f64 = rule
                    .volume
                    .iter()
                    .map(|p| p.w * sign * field(p.x)[axis])
                    .sum();
                faces += flux;
                face_abs += flux.abs();
            }
        }
        defect += (vol - surf - faces).abs();
        scale += surf.abs() + face_abs;
        if std::env::var("SHOW").is_ok()
            && (vol - surf - faces).abs() > 1e-9 * (surf.abs() + face_abs)
        {
            println!(
                "cell {:?} frac {:.3e} nv {} ns {} rel {:.2e} abs {:.2e}",
                b,
                cells.fraction[i],
                cells.volume_points(i).len(),
                cells.surface_points(i).len(),
                (vol - surf - faces).abs() / (surf.abs() + face_abs),
                (vol - surf - faces).abs()
            );
        }
    }
    defect / scale
}

#[test]
fn divergence_theorem_on_cut_cells_q2_rule() {
    let sphere = Geometry::sphere([0.0; 3], 1.0).unwrap();
    for (level, offset) in [(5, [0.0; 3]), (5, [0.37, 0.11, 0.73])] {
        let d = divergence_defect(&sphere, level, offset, cut_rule_points(ElementOrder::Q2));
        println!("sphere level {level}: relative defect {d:.2e}");
        assert!(d < 1e-10, "sphere level {level}: {d}");
    }
    let torus = Geometry::torus([0.0; 3], [0.3, 0.0, 1.0], 0.7, 0.3).unwrap();
    let d = divergence_defect(
        &torus,
        6,
        [0.5, 0.25, 0.125],
        cut_rule_points(ElementOrder::Q2),
    );
    // The quartic torus is resolved by ~10 cells per tube diameter at level 6
    // (the sphere by 32 per radius at level 5): 1e-9 there.
    println!("torus level 6: relative defect {d:.2e}");
    assert!(d < 1e-9, "torus: {d}");
}

#[test]
fn surface_points_carry_exact_normals_and_tags() {
    let g = Geometry::shell([0.1, 0.0, -0.2], 0.4, 1.0).unwrap();
    let grid = Grid::new(&g.bounding_box(), 4, [0.2, 0.6, 0.9]).unwrap();
    let cells = Cells::classify(&grid, &g, 3).unwrap();
    let (outer, inner) = (g.tag_id("outer").unwrap(), g.tag_id("inner").unwrap());
    let mut area = [0.0; 2];
    for p in &cells.surface {
        let exact = g.normal(p.x);
        assert!((0..3).all(|i| (p.n[i] - exact[i]).abs() < 1e-12), "{p:?}");
        assert!(g.phi(p.x).abs() < 1e-13);
        area[if p.tag == outer {
            0
        } else {
            assert_eq!(p.tag, inner);
            1
        }] += p.w;
    }
    assert!(
        (area[0] - 4.0 * PI).abs() < 1e-6 * 4.0 * PI,
        "outer area {}",
        area[0]
    );
    assert!(
        (area[1] - 4.0 * PI * 0.16).abs() < 1e-5 * 4.0 * PI * 0.16,
        "inner area {}",
        area[1]
    );
}

#[test]
fn face_aligned_box_is_exact() {
    // Box faces on grid planes: every boundary cell is cut with fraction 1 and
    // the faces are integrated once, from the inside.
    let g = Geometry::cuboid([-1.0, -1.0, -0.5], [1.0, 1.0, 0.5]).unwrap();
    let grid = Grid::new(&Aabb::new([-1.0; 3], [1.0; 3]), 3, [0.0; 3]).unwrap();
    let cells = Cells::classify(&grid, &g, 2).unwrap();
    assert!((cells.volume(&grid) - 4.0).abs() < 1e-13);
    assert!((cells.boundary_area() - 16.0).abs() < 1e-13);
    assert!(cells.fraction.iter().all(|&f| (f - 1.0).abs() < 1e-13));
    for p in &cells.surface {
        let n = g.normal(p.x);
        assert!((0..3).all(|i| (p.n[i] - n[i]).abs() < 1e-15));
    }
}

/// A cell's rule does not depend on where the cell lies: the same cut moved
/// far from the origin (up to 2¹⁶ cells, as a part in mm at level 7 and
/// beyond) keeps its surface points, with the same total weight and volume.
/// Before the line sweep's tolerance followed the coordinates' ulps, the
/// cells of a bolt hole 112 cells from the origin lost every surface point
/// (a quarter of the bracket's clamped surface at level 7).
#[test]
fn rules_are_invariant_under_large_translations() {
    let h = 0.625;
    let rule = |shift: f64| {
        let g = Geometry::cylinder([shift, 20.0, -5.0], [shift, 20.0, 15.0], 6.0).unwrap();
        let lo = [shift + 4.1875, 15.25, 0.96875];
        let b = Aabb::new(lo, [lo[0] + h, lo[1] + h, lo[2] + h]);
        let r = box_rule(&g, &b, &[0, 1, 2], 4);
        let area: f64 = r.surface.iter().map(|p| p.w).sum();
        let volume: f64 = r.volume.iter().map(|p| p.w).sum();
        (area, volume, r.surface.len())
    };
    let (area, volume, points) = rule(0.0);
    assert!(
        points > 0 && area > 0.1 * h * h,
        "{points} points, area {area}"
    );
    for cells in [16.0, 112.0, 1000.0, 65536.0] {
        let (a, v, n) = rule(cells * h);
        assert_eq!(n, points, "shift of {cells} cells");
        assert!(
            (a - area).abs() <= 1e-9 * area,
            "shift of {cells} cells: area {a} vs {area}"
        );
        assert!(
            (v - volume).abs() <= 1e-9 * volume,
            "shift of {cells} cells: volume {v} vs {volume}"
        );
    }
}

/// The bracket of `cases/bracket.toml` at level 7 (h = 0.625 mm, the far
/// bolt hole 112 cells from the origin): every boundary part has its exact
/// area. Before the line sweep's fix a quarter of the bolt holes (564.4
/// against 754.0 mm²) and the whole `xmax` face of the base were missing.
#[test]
fn the_level_7_bracket_keeps_every_boundary_part() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/bracket.toml");
    let case = cgfem_gpu::case::Case::from_file_with(&path, &[]).unwrap();
    let grid = case.grid(Some(7)).unwrap();
    let cells = case.classify(&grid).unwrap();
    let g = &case.body().geometry;
    let area = |name: &str| -> f64 {
        let tag = g.tag_id(name).unwrap();
        (0..cells.cut.len())
            .flat_map(|i| cells.surface_points(i))
            .filter(|p| p.tag == tag)
            .map(|p| p.w)
            .sum()
    };
    let holes = 2.0 * 2.0 * PI * 6.0 * 10.0;
    let got = area("bolt_holes");
    assert!(
        (got - holes).abs() <= 1e-5 * holes,
        "bolt holes {got} mm² against {holes}"
    );
    // x = 80 (the base, 40 × 10) and x = 10 (the upright above the base,
    // 40 × 50); x = 0 (both, 40 × 60).
    let xmin = area("xmin");
    let xmax = area("xmax");
    assert!(
        (xmax - 400.0 - 2000.0).abs() <= 1e-9 * 2400.0,
        "xmax {xmax}"
    );
    assert!((xmin - 2400.0).abs() <= 1e-9 * 2400.0, "xmin {xmin}");
}

/// A CSG cut on a grid plane that meets a curved part: the quarter of a
/// plate with a hole, cut by the half-spaces x ≥ 0 and y ≥ 0 on cell faces,
/// gets in every cell the rule of the uncut plate (volume, hole area). The
/// cut's plane touches the cells along x = 0 only on a face, where the
/// hole's level set is not monotone along x; its boundary points now come
/// from a sweep along x with scanned roots. Before, no sweep plan existed,
/// the cell was halved down to the last resort, and the hole lost 3% of its
/// area in the two cells where it meets the planes.
#[test]
fn a_cut_on_a_cell_face_keeps_the_curved_part_it_meets() {
    let plate = Geometry::cuboid([-1.0, -1.0, -0.125], [1.0, 1.0, 0.125])
        .unwrap()
        .difference(
            Geometry::cylinder([0.0, 0.0, -1.0], [0.0, 0.0, 1.0], 0.3)
                .unwrap()
                .retag("side", "hole")
                .unwrap(),
        )
        .unwrap();
    let quarter = plate
        .clone()
        .intersection(Geometry::half_space([0.0; 3], [-1.0, 0.0, 0.0]).unwrap())
        .unwrap()
        .intersection(Geometry::half_space([0.0; 3], [0.0, -1.0, 0.0]).unwrap())
        .unwrap();
    let h = 0.25;
    let measures = |g: &Geometry, b: &Aabb| {
        let rule = box_rule(g, b, &[0, 1, 2], 2);
        let hole = g.tag_id("hole").unwrap();
        let area: f64 = rule
            .surface
            .iter()
            .filter(|p| p.tag == hole)
            .map(|p| p.w)
            .sum();
        (rule.volume.iter().map(|p| p.w).sum::<f64>(), area)
    };
    let mut hole_area = 0.0;
    for i in 0..4 {
        for j in 0..4 {
            let lo = [i as f64 * h, j as f64 * h, -0.125];
            let b = Aabb::new(lo, [lo[0] + h, lo[1] + h, 0.125]);
            let (vp, ap) = measures(&plate, &b);
            let (vq, aq) = measures(&quarter, &b);
            assert!(
                (vq - vp).abs() <= 1e-14,
                "cell {i} {j}: volume {vq} against {vp}"
            );
            assert!(
                (aq - ap).abs() <= 1e-14,
                "cell {i} {j}: hole area {aq} against {ap}"
            );
            hole_area += aq;
        }
    }
    // The quarter hole, 2π r t / 4, to the rule's accuracy.
    let exact = 0.5 * PI * 0.3 * 0.25;
    assert!(
        (hole_area - exact).abs() < 1e-3 * exact,
        "{hole_area} against {exact}"
    );
}
