use super::*;

/// A reproducible pseudo-random sequence in [0, 1).
fn lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

fn noise(size: [usize; 3], seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..size.iter().product::<usize>())
        .map(|_| 100.0 * lcg(&mut s))
        .collect()
}

#[test]
fn the_pyramid_encloses_the_exact_range_within_the_samples_met() {
    let size = [80, 70, 60];
    let v = Voxels::new(size, &noise(size, 3), [1.0; 3], 50.0, Inside::Above).unwrap();
    let mut s = 9;
    for _ in 0..200 {
        // Boxes of 8 to 30 voxels a side: more breakpoints than the exact path takes.
        let r = [0, 1, 2].map(|a| {
            let w = 8.0 + 22.0 * lcg(&mut s);
            let lo = -2.0 + (size[a] as f64 + 2.0) * lcg(&mut s);
            (lo, lo + w)
        });
        let pyramid = v.range(r);
        // The exact range: ψ at every breakpoint tuple.
        let top = |a: usize| (v.n[a] - 1) as f64;
        let planes = [0, 1, 2].map(|a| {
            let (lo, hi) = (r[a].0.max(0.0), r[a].1.min(top(a)));
            let mut p = vec![lo, hi];
            p.extend((lo.ceil() as usize..=hi.floor() as usize).map(|i| i as f64));
            p
        });
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for &z in &planes[2] {
            for &y in &planes[1] {
                for &x in &planes[0] {
                    let p = v.value([x, y, z]);
                    (lo, hi) = (lo.min(p), hi.max(p));
                }
            }
        }
        if (0..3).any(|a| r[a].0 < 0.0 || r[a].1 > top(a)) {
            (lo, hi) = (lo.min(v.outside), hi.max(v.outside));
        }
        // Up to rounding: a sample reached by interpolation may be an ulp off.
        let tol = 1e-12 * v.outside;
        assert!(
            pyramid.lo <= lo + tol && pyramid.hi >= hi - tol,
            "{pyramid:?} misses [{lo}, {hi}]"
        );
        // Within the samples of the cells met, widened by at most one block.
        let (cells, _) = v.cells_met(r);
        let c = cells.unwrap();
        let grow =
            |a: usize, (x, y): (usize, usize)| (x.saturating_sub(32), (y + 33).min(v.n[a] - 1));
        let (slo, shi) = v.node_range([grow(0, c[0]), grow(1, c[1]), grow(2, c[2])]);
        let (slo, shi) = (slo.min(v.outside), shi.max(v.outside));
        assert!(
            pyramid.lo >= slo - tol && pyramid.hi <= shi + tol,
            "{pyramid:?} beyond [{slo}, {shi}]"
        );
    }
}

#[test]
fn slopes_are_the_interpolants_and_within_the_global_bounds() {
    let size = [6, 5, 7];
    let v = Voxels::new(size, &noise(size, 5), [0.5, 1.0, 2.0], 40.0, Inside::Below).unwrap();
    let m = v.slope_bounds();
    let mut s = 1;
    for _ in 0..500 {
        let u = [0, 1, 2].map(|a| 1.0 + (size[a] - 1) as f64 * lcg(&mut s));
        let slopes = <f64 as Scalar>::voxel_slopes(&v, u);
        for a in 0..3 {
            // ψ is linear along each axis inside a cell.
            let c = u[a].floor();
            let (mut lo, mut hi) = (u, u);
            lo[a] = c;
            hi[a] = c + 1.0;
            let want = v.value(hi) - v.value(lo);
            assert!(
                (slopes[a] - want).abs() <= 1e-12 * m[a].max(1.0),
                "∂{a}: {} against {want}",
                slopes[a]
            );
            assert!(slopes[a].abs() <= m[a]);
        }
    }
}

#[test]
fn smoothing_keeps_constants_and_mass() {
    let size = [9, 8, 7];
    assert!(gaussian(size, &vec![3.5; 504], 1.3)
        .iter()
        .all(|x| (x - 3.5).abs() < 1e-12));
    let mut delta = vec![0.0; 504];
    delta[4 + 9 * (4 + 8 * 3)] = 1.0;
    let g = gaussian(size, &delta, 0.8);
    let sum: f64 = g.iter().sum();
    assert!((sum - 1.0).abs() < 1e-12, "{sum}");
    assert!(g[4 + 9 * (4 + 8 * 3)] < 1.0 && g[5 + 9 * (4 + 8 * 3)] > 0.0);
    assert_eq!(gaussian(size, &delta, 0.0), delta);
}

#[test]
fn a_threshold_outside_the_values_is_refused() {
    let size = [2, 2, 2];
    let v = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];
    for (t, inside, what) in [
        (7.0, Inside::Above, "empty"),
        (0.0, Inside::Above, "the whole image"),
        (0.0, Inside::Below, "empty"),
    ] {
        match Voxels::new(size, &v, [1.0; 3], t, inside) {
            Err(Error::InvalidGeometry { reason, .. }) => {
                assert!(reason.contains(what), "{t}: {reason}")
            }
            other => panic!("{t}: {other:?}"),
        }
    }
    assert!(Voxels::new(size, &v, [1.0; 3], 3.5, Inside::Above).is_ok());
    assert!(Voxels::new([2, 2, 1], &v[..4], [1.0; 3], 1.5, Inside::Above).is_err());
    assert!(Voxels::new(size, &v[..7], [1.0; 3], 1.5, Inside::Above).is_err());
}
