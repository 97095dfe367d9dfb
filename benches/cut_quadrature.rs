//! Classification and cut-cell quadrature of the unit sphere at levels 5–7
//! (2^21 cells at level 7), with the Q1 and Q2 rules. Throughput is in cut
//! cells per second, so the time per cut cell reads off directly; the cost
//! must follow the number of cut cells (~4× per level), not of cells (8×).
//!
//! `cargo bench --bench cut_quadrature`

use cgfem_gpu::cells::{cut_rule_points, Cells};
use cgfem_gpu::element::ElementOrder;
use cgfem_gpu::geometry::Geometry;
use cgfem_gpu::grid::Grid;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

fn classify_sphere(c: &mut Criterion) {
    let sphere = Geometry::sphere([0.0; 3], 1.0).unwrap();
    let mut group = c.benchmark_group("classify_sphere");
    group.sample_size(10);
    for order in [ElementOrder::Q1, ElementOrder::Q2] {
        for level in 5..=7 {
            let grid = Grid::new(&sphere.bounding_box(), level, [0.0; 3]).unwrap();
            let q = cut_rule_points(order);
            let cut = Cells::classify(&grid, &sphere, q).unwrap().cut.len();
            group.throughput(Throughput::Elements(cut as u64));
            let id = BenchmarkId::new(format!("{order:?}"), format!("level{level}_{cut}cut"));
            group.bench_with_input(id, &grid, |b, grid| {
                b.iter(|| Cells::classify(grid, &sphere, q).unwrap().cut.len())
            });
        }
    }
    group.finish();
}

criterion_group!(benches, classify_sphere);
criterion_main!(benches);
