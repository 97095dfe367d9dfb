//! Tests of [`ExactSum`]: correct rounding against an `i128` reference,
//! independence of the order, cancellation across the whole exponent range,
//! the transport words and the non-finite terms.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::ExactSum;

/// Random multiples of 2^−60 below 2^60 in magnitude, of mixed signs and
/// sizes: their exact sum, scaled by 2^60, is an `i128`.
fn fixed_point_terms(n: usize, seed: u64) -> Vec<i128> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let bits = rng.gen_range(1..=53);
            let shift = rng.gen_range(0..=(119 - bits));
            let m: i128 = rng.gen_range(0..(1_i128 << bits));
            let v = m << shift;
            if rng.gen_bool(0.5) {
                v
            } else {
                -v
            }
        })
        .collect()
}

const TWO_60: f64 = (1u64 << 60) as f64;

#[test]
fn rounds_the_exact_sum_to_nearest() {
    for seed in 0..200 {
        let terms = fixed_point_terms(1 + seed as usize % 50, seed);
        let exact: i128 = terms.iter().sum();
        // `as f64` rounds an i128 to nearest, ties to even; the scaling is
        // by a power of two.
        let reference = exact as f64 / TWO_60;
        let values: Vec<f64> = terms.iter().map(|&t| t as f64 / TWO_60).collect();
        for (t, v) in terms.iter().zip(&values) {
            assert_eq!((v * TWO_60) as i128, *t, "terms are exact");
        }
        let got = ExactSum::of(values.iter().copied()).value();
        assert_eq!(got.to_bits(), reference.to_bits(), "seed {seed}");
    }
}

#[test]
fn does_not_depend_on_the_order_or_the_split() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut values: Vec<f64> = (0..10_000)
        .map(|_| rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-30..30)))
        .collect();
    let first = ExactSum::of(values.iter().copied());
    for _ in 0..5 {
        values.shuffle(&mut rng);
        let cut = rng.gen_range(0..values.len());
        let mut a = ExactSum::of(values[..cut].iter().copied());
        let b = ExactSum::of(values[cut..].iter().copied());
        a.merge(&b);
        assert_eq!(a.value().to_bits(), first.value().to_bits());
        assert_eq!(a.to_words(), first.to_words());
    }
}

#[test]
fn cancels_across_the_exponent_range() {
    let tiny = f64::from_bits(1);
    let cases: [(&[f64], f64); 7] = [
        (&[1e300, 1.0, -1e300], 1.0),
        (&[1.0, tiny, -1.0], tiny),
        (&[f64::MAX, f64::MAX, -f64::MAX], f64::MAX),
        (&[f64::MAX, f64::MAX], f64::INFINITY),
        (&[-3.5, 1.25, 2.25], 0.0),
        (&[-1e-300, -2e-300], -3e-300),
        // The exact sum (Python's math.fsum), not the rounded 5.55e-17.
        (&[0.1, 0.2, -0.3], 2.7755575615628914e-17),
    ];
    for (terms, want) in cases {
        let got = ExactSum::of(terms.iter().copied()).value();
        assert_eq!(got.to_bits(), want.to_bits(), "{terms:?}: {got:e}");
    }
}

#[test]
fn rounds_ties_to_even_and_honours_the_sticky_bits() {
    let half_ulp = 2f64.powi(-53);
    let one_up = 1.0 + 2f64.powi(-52);
    let cases: [(&[f64], f64); 4] = [
        (&[1.0, half_ulp], 1.0),
        (&[1.0, half_ulp, 2f64.powi(-200)], one_up),
        (&[one_up, half_ulp], 1.0 + 2f64.powi(-51)),
        (&[-1.0, -half_ulp, -2f64.powi(-200)], -one_up),
    ];
    for (terms, want) in cases {
        let got = ExactSum::of(terms.iter().copied()).value();
        assert_eq!(got.to_bits(), want.to_bits(), "{terms:?}: {got:e}");
    }
}

#[test]
fn words_carry_the_sum_exactly() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let values: Vec<f64> = (0..1000)
        .map(|_| rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-300..300)))
        .collect();
    let s = ExactSum::of(values.iter().copied());
    let back = ExactSum::from_words(&s.to_words());
    assert_eq!(back.to_words(), s.to_words());
    assert_eq!(back.value().to_bits(), s.value().to_bits());
    let mut neg = ExactSum::of(values.iter().map(|v| -v));
    assert_eq!(neg.value().to_bits(), (-s.value()).to_bits());
    neg.merge(&back);
    assert_eq!(neg.value(), 0.0);
}

#[test]
fn adds_infinities_and_nans_as_floating_point_does() {
    let inf = f64::INFINITY;
    assert_eq!(ExactSum::of([1.0, inf]).value(), inf);
    assert_eq!(ExactSum::of([-inf, 1.0]).value(), -inf);
    assert!(ExactSum::of([inf, -inf]).value().is_nan());
    assert!(ExactSum::of([2.0, f64::NAN]).value().is_nan());
    let mut s = ExactSum::of([1.0]);
    s.merge(&ExactSum::of([inf]));
    assert_eq!(
        ExactSum::from_words(&s.to_words()).value(),
        inf,
        "through the words"
    );
}

#[test]
fn a_dot_product_is_the_compensated_one_to_round_off() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let x: Vec<f64> = (0..100_003).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let y: Vec<f64> = (0..100_003).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let reference = crate::cells::compensated_sum(x.iter().zip(&y).map(|(a, b)| a * b));
    let got = ExactSum::dot(&x, &y).value();
    assert!((got - reference).abs() <= 2.0 * f64::EPSILON * reference.abs());
}

/// The floating-point path of [`ExactSum::dot`] gives the limbs' sum of
/// the same products, on data that takes every branch: one magnitude,
/// wide ranges (remainders below the third level), subnormals, huge
/// values, equal terms that fill a block, and non-finite products.
#[test]
fn a_dot_product_is_the_exact_sum_of_its_products() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut cases: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    for (n, spread) in [(20_000, 1), (20_000, 40), (9_000, 300), (100, 600)] {
        let v = |rng: &mut ChaCha8Rng| -> Vec<f64> {
            (0..n)
                .map(|_| rng.gen_range(-1.0..1.0) * 2f64.powi(rng.gen_range(-spread..=spread)))
                .collect()
        };
        let (a, b) = (v(&mut rng), v(&mut rng));
        cases.push((a, b));
    }
    let tiny = f64::from_bits(12345);
    cases.push((vec![1.99999999; 8192], vec![1.99999999; 8192]));
    cases.push((
        vec![tiny, 1e-300, 1.0, -1.0, 3e-310],
        vec![1.0, 1e-10, 1e-300, 2.5, 0.5],
    ));
    cases.push((vec![1e300, -1e300, 1.0], vec![1e10, 1e10, 1.0]));
    cases.push((vec![1.0, f64::INFINITY, 2.0], vec![1.0, 1.0, 2.0]));
    cases.push((vec![1.0, f64::NAN], vec![1.0, 1.0]));
    cases.push((vec![0.0; 10], vec![5.0; 10]));
    for (i, (a, b)) in cases.iter().enumerate() {
        let fast = ExactSum::dot(a, b);
        let limbs = ExactSum::of(a.iter().zip(b).map(|(x, y)| x * y));
        assert_eq!(
            fast.to_words().map(f64::to_bits),
            limbs.to_words().map(f64::to_bits),
            "case {i}"
        );
    }
}

/// The entry-wise integer sum of several sums' integers is their total,
/// in any order (what an MPI reduction tree does), non-finite parts
/// included.
#[test]
fn integers_add_up_to_the_total_in_any_order() {
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let parts: Vec<ExactSum> = (0..64)
        .map(|_| {
            ExactSum::of(
                (0..200).map(|_| rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-300..300))),
            )
        })
        .collect();
    let mut total = ExactSum::new();
    for p in &parts {
        total.merge(p);
    }
    let mut order: Vec<usize> = (0..parts.len()).collect();
    for _ in 0..3 {
        order.shuffle(&mut rng);
        let mut ints = [0_i64; super::INTEGERS];
        for &k in &order {
            for (a, b) in ints.iter_mut().zip(parts[k].to_integers()) {
                *a += b;
            }
        }
        let back = ExactSum::from_integers(&ints);
        assert_eq!(back.to_words(), total.to_words());
        assert_eq!(back.value().to_bits(), total.value().to_bits());
    }
    let inf = f64::INFINITY;
    let add = |sums: &[ExactSum]| {
        let mut ints = [0_i64; super::INTEGERS];
        for s in sums {
            for (a, b) in ints.iter_mut().zip(s.to_integers()) {
                *a += b;
            }
        }
        ExactSum::from_integers(&ints).value()
    };
    let one = ExactSum::of([1.0]);
    assert_eq!(
        add(&[one.clone(), ExactSum::of([inf]), ExactSum::of([inf])]),
        inf
    );
    assert_eq!(add(&[ExactSum::of([-inf]), one.clone()]), -inf);
    assert!(add(&[ExactSum::of([inf]), ExactSum::of([-inf])]).is_nan());
    assert!(add(&[ExactSum::of([f64::NAN]), one]).is_nan());
}
