//! Tests of the CPU backend: every kernel against a plain scalar loop, on both
//! the sequential and the parallel path, and the reproducibility of dot products.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{Backend, CpuBackend};

/// Not a multiple of the chunk length, and long enough for several chunks.
const N: usize = 3 * 8192 + 17;

fn random(n: usize, seed: u64, lo: f64, hi: f64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|_| rng.gen_range(lo..hi)).collect()
}

/// The always-sequential and the always-parallel backend.
fn both() -> [CpuBackend; 2] {
    [
        CpuBackend::with_parallel_min_len(usize::MAX),
        CpuBackend::with_parallel_min_len(0),
    ]
}

/// Compensated (Neumaier) sum of products: the reference for dot products.
fn neumaier_dot(x: &[f64], y: &[f64]) -> f64 {
    crate::cells::compensated_sum(x.iter().zip(y).map(|(a, b)| a * b))
}

fn assert_bits_eq(a: &[f64], b: &[f64], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert_eq!(x.to_bits(), y.to_bits(), "{what}: entry {i}: {x} vs {y}");
    }
}

#[test]
fn dot_is_deterministic_and_accurate() {
    let x = random(1_000_003, 1, 0.0, 1.0);
    let y = random(1_000_003, 2, 0.0, 1.0);
    let reference = neumaier_dot(&x, &y);
    let [seq, par] = both();
    let first = par.dot(&x, &y);
    for _ in 0..5 {
        assert_eq!(par.dot(&x, &y).to_bits(), first.to_bits(), "repeat");
    }
    assert_eq!(seq.dot(&x, &y).to_bits(), first.to_bits(), "seq vs par");
    let rel = (first - reference).abs() / reference.abs();
    assert!(
        rel <= 1e-14,
        "dot {first} vs compensated {reference}: {rel:e}"
    );
}

#[test]
fn dot2_matches_two_dots_bitwise() {
    let (x, y, z) = (
        random(N, 3, -1.0, 1.0),
        random(N, 4, -1.0, 1.0),
        random(N, 5, -1.0, 1.0),
    );
    for be in both() {
        let (xy, xz) = be.dot2(&x, &y, &z);
        assert_eq!(xy.to_bits(), be.dot(&x, &y).to_bits());
        assert_eq!(xz.to_bits(), be.dot(&x, &z).to_bits());
    }
}

#[test]
fn dot_of_empty_vectors_is_zero() {
    let be = CpuBackend::new();
    assert_eq!(be.dot(&vec![], &vec![]), 0.0);
}

#[test]
fn upload_download_zeros_copy() {
    let x = random(N, 6, -1.0, 1.0);
    for be in both() {
        let d = be.upload(&x);
        assert_bits_eq(&be.download(&d), &x, "roundtrip");
        let mut z = be.zeros(N);
        assert_eq!(be.len(&z), N);
        assert!(z.iter().all(|&v| v == 0.0));
        be.copy(&d, &mut z);
        assert_bits_eq(&z, &x, "copy");
    }
}

#[test]
fn single_vector_updates_match_scalar_loops() {
    let (x, y0) = (random(N, 7, -1.0, 1.0), random(N, 8, -1.0, 1.0));
    let (a, b) = (0.37, -1.25);
    let w = random(N, 9, -1.0, 1.0);
    for be in both() {
        let mut y = y0.clone();
        be.axpy(a, &x, &mut y);
        let want: Vec<f64> = (0..N).map(|i| y0[i] + a * x[i]).collect();
        assert_bits_eq(&y, &want, "axpy");

        let mut y = y0.clone();
        be.xpay(&x, a, &mut y);
        let want: Vec<f64> = (0..N).map(|i| x[i] + a * y0[i]).collect();
        assert_bits_eq(&y, &want, "xpay");

        let mut y = y0.clone();
        be.scale(a, &mut y);
        let want: Vec<f64> = (0..N).map(|i| a * y0[i]).collect();
        assert_bits_eq(&y, &want, "scale");

        let mut y = y0.clone();
        be.axpy2(a, &x, b, &w, &mut y);
        let want: Vec<f64> = (0..N).map(|i| y0[i] + (a * x[i] + b * w[i])).collect();
        assert_bits_eq(&y, &want, "axpy2");

        let mut z = be.zeros(N);
        be.pointwise_mul(&x, &y0, &mut z);
        let want: Vec<f64> = (0..N).map(|i| x[i] * y0[i]).collect();
        assert_bits_eq(&z, &want, "pointwise_mul");

        let mut p = y0.clone();
        be.bicgstab_update_p(a, b, &x, &w, &mut p);
        let want: Vec<f64> = (0..N).map(|i| x[i] + a * (y0[i] - b * w[i])).collect();
        assert_bits_eq(&p, &want, "bicgstab_update_p");
    }
}

#[test]
fn cgs_fused_updates_match_unfused() {
    let (r, q0, p0, v) = (
        random(N, 10, -1.0, 1.0),
        random(N, 11, -1.0, 1.0),
        random(N, 12, -1.0, 1.0),
        random(N, 13, -1.0, 1.0),
    );
    let (alpha, beta) = (0.8, 0.6);
    for be in both() {
        let (mut u, mut p) = (be.zeros(N), p0.clone());
        be.cgs_update_up(beta, &r, &q0, &mut u, &mut p);
        let want_u: Vec<f64> = (0..N).map(|i| r[i] + beta * q0[i]).collect();
        let want_p: Vec<f64> = (0..N)
            .map(|i| want_u[i] + beta * (q0[i] + beta * p0[i]))
            .collect();
        assert_bits_eq(&u, &want_u, "cgs_update_up: u");
        assert_bits_eq(&p, &want_p, "cgs_update_up: p");

        let (mut q, mut u2) = (q0.clone(), want_u.clone());
        be.cgs_update_qu(alpha, &v, &mut q, &mut u2);
        let want_q: Vec<f64> = (0..N).map(|i| want_u[i] - alpha * v[i]).collect();
        let want_u2: Vec<f64> = (0..N).map(|i| want_u[i] + want_q[i]).collect();
        assert_bits_eq(&q, &want_q, "cgs_update_qu: q");
        assert_bits_eq(&u2, &want_u2, "cgs_update_qu: u");
    }
}

#[test]
#[should_panic(expected = "vector lengths differ")]
fn length_mismatch_panics() {
    let be = CpuBackend::new();
    let mut y = vec![0.0; 3];
    be.axpy(1.0, &vec![1.0; 4], &mut y);
}
