//! Operator apply of the paper's sphere (Q1, f64): the fast matrix-free apply
//! (interior stencil + boundary gather), the generic node-centred gather, the
//! assembled faer CSC apply and the row-parallel CSR apply of the same
//! operator, at levels 5 and 6, in one run. Throughput is in dofs per second.
//! `cgfem-gpu bench` measures the same with thread counts and writes JSON.
//!
//! `cargo bench --bench elasticity_apply`

use cgfem_gpu::backend::LinearOperator;
use cgfem_gpu::bench::{csr_bytes, RayonCsr};
use cgfem_gpu::case::Case;
use cgfem_gpu::driver::setup::Setup;
use cgfem_gpu::fem::operator::AssembledOperator;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

fn apply(c: &mut Criterion) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/sphere.toml");
    let case = Case::from_file(&path).unwrap();
    let mut group = c.benchmark_group("sphere_apply");
    group.sample_size(10);
    for level in [5, 6] {
        let setup = Setup::new(&case, Some(level)).unwrap();
        let n = setup.op.nrows();
        let csr = AssembledOperator(setup.op.assemble());
        println!(
            "level {level}: {n} dofs; matrix-free data {:.1} bytes/dof, CSC {:.1} bytes/dof ({} nonzeros)",
            setup.op.bytes() as f64 / n as f64,
            csr_bytes(&csr) as f64 / n as f64,
            csr.0.compute_nnz()
        );
        let x: Vec<f64> = (0..n)
            .map(|i| ((i * 7919) % 1000) as f64 / 1000.0)
            .collect();
        let mut y = vec![0.0; n];
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::new("matrix_free", level), &level, |b, _| {
            b.iter(|| setup.op.apply(&x, &mut y))
        });
        group.bench_with_input(BenchmarkId::new("gather", level), &level, |b, _| {
            b.iter(|| setup.op.apply_gather(&x, &mut y))
        });
        group.bench_with_input(BenchmarkId::new("faer_csc", level), &level, |b, _| {
            b.iter(|| csr.apply(&x, &mut y))
        });
        let rayon_csr = RayonCsr(&csr);
        group.bench_with_input(BenchmarkId::new("rayon_csr", level), &level, |b, _| {
            b.iter(|| rayon_csr.apply(&x, &mut y))
        });
    }
    group.finish();
}

criterion_group!(benches, apply);
criterion_main!(benches);
