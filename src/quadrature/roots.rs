//! Roots of a scalar function on a segment: safeguarded Newton inside a sign
//! bracket, for the height-function sweeps of the cut-cell quadrature.

/// Appends to `out` the roots of `f` on `[a, b]` (`f` returns value and
/// derivative). With `monotone`, `f` is known to have at most one root there;
/// otherwise the segment is scanned in `SCAN` pieces first (a fallback that can
/// miss a pair of roots closer than a piece, which only degrades accuracy).
pub fn roots_on_segment(
    f: &dyn Fn(f64) -> (f64, f64),
    a: f64,
    b: f64,
    monotone: bool,
    out: &mut Vec<f64>,
) {
    const SCAN: usize = 16;
    if monotone {
        bracket_root(f, a, b, f(a).0, f(b).0, true, out);
        return;
    }
    let mut xa = a;
    let mut fa = f(a).0;
    for i in 1..=SCAN {
        let xb = if i == SCAN {
            b
        } else {
            a + (b - a) * i as f64 / SCAN as f64
        };
        let fb = f(xb).0;
        // A zero at a scan point is reported by the piece on its left only.
        bracket_root(f, xa, xb, fa, fb, i == 1, out);
        xa = xb;
        fa = fb;
    }
}

/// One root in `[a, b]` given the end values; a zero at `b` is reported, a zero
/// at `a` only with `include_a`.
fn bracket_root(
    f: &dyn Fn(f64) -> (f64, f64),
    a: f64,
    b: f64,
    fa: f64,
    fb: f64,
    include_a: bool,
    out: &mut Vec<f64>,
) {
    if fa == 0.0 && include_a {
        out.push(a);
    }
    if fb == 0.0 {
        out.push(b);
        return;
    }
    if fa == 0.0 || (fa < 0.0) == (fb < 0.0) {
        return;
    }
    // Orient so that f(lo) < 0 < f(hi).
    let (mut lo, mut hi) = if fa < 0.0 { (a, b) } else { (b, a) };
    let (flo, fhi) = if fa < 0.0 { (fa, fb) } else { (fb, fa) };
    let tol = 4.0 * f64::EPSILON * (a.abs().max(b.abs()) + (b - a).abs());
    let mut x = lo + (hi - lo) * flo / (flo - fhi);
    for _ in 0..100 {
        let (fx, dfx) = f(x);
        if fx == 0.0 {
            break;
        }
        if fx < 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        let newton = x - fx / dfx;
        let inside = (newton - lo) * (newton - hi) <= 0.0;
        let next = if inside && dfx.is_finite() && dfx != 0.0 {
            newton
        } else {
            0.5 * (lo + hi)
        };
        let step = (next - x).abs();
        x = next;
        if step <= tol || (hi - lo).abs() <= tol {
            break;
        }
    }
    out.push(x.clamp(a.min(b), a.max(b)));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_monotone_root_to_round_off() {
        let f = |x: f64| (x * x * x - 0.2, 3.0 * x * x);
        let mut r = vec![];
        roots_on_segment(&f, 0.0, 1.0, true, &mut r);
        assert_eq!(r.len(), 1);
        assert!(
            (r[0] - 0.2f64.cbrt()).abs() < 2e-16,
            "{}",
            r[0] - 0.2f64.cbrt()
        );
    }

    #[test]
    fn finds_end_roots_and_several_roots() {
        let f = |x: f64| (x - 0.5, 1.0);
        let mut r = vec![];
        roots_on_segment(&f, 0.5, 1.0, true, &mut r);
        assert_eq!(r, vec![0.5]);
        let g = |x: f64| ((x - 0.2) * (x - 0.7), 2.0 * x - 0.9);
        let mut r = vec![];
        roots_on_segment(&g, 0.0, 1.0, false, &mut r);
        assert_eq!(r.len(), 2);
        assert!((r[0] - 0.2).abs() < 1e-15 && (r[1] - 0.7).abs() < 1e-15);
    }
}
