//! [`ExactSum`]: sums of `f64` values without rounding, so that a sum does
//! not depend on the order of its terms. The linear algebra's dot products,
//! the S-term's rigid-body fits, the error norms and the reactions add up
//! through it: the same terms give the same bits however they are split
//! into chunks, threads or ranks, so a run on P ranks repeats the one-rank
//! run exactly.
//!
//! The accumulator is a fixed-point number covering every finite `f64`:
//! `Σ limbs[i] 2^(64 i − 1074)`, each limb an `i128` so that 2^63 terms add
//! without a carry. A term's 53-bit significand, shifted to its exponent,
//! lands in two neighbouring limbs. [`ExactSum::value`] rounds the exact
//! sum once, to nearest (ties to even) for normal results. Infinities and
//! NaNs are added apart, as floating point would.

/// Limbs: the largest finite term's top bit is bit 2 097 above 2^−1074, so
/// 33 limbs of 64 bits hold every term, and one more takes the carries.
const LIMBS: usize = 34;

/// The exact sum of the `f64` values added to it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExactSum {
    limbs: [i128; LIMBS],
    /// The sum of the non-finite terms (0 when there are none).
    nonfinite: u64,
}

impl Default for ExactSum {
    fn default() -> Self {
        Self::new()
    }
}

/// Products per block of [`ExactSum::dot`]'s floating-point path: 2^13, so
/// that the block's level sums stay exact.
const BLOCK: usize = 1 << 13;
/// Independent partial sums in that path (for the vector units).
const LANES: usize = 4;
/// Extraction levels in that path.
const LEVELS: usize = 3;

/// Numbers per [`ExactSum`] in [`ExactSum::to_words`].
pub const WORDS: usize = 2 * LIMBS + 1;

/// Integers per [`ExactSum`] in [`ExactSum::to_integers`].
pub const INTEGERS: usize = 2 * LIMBS + 3;

impl ExactSum {
    /// The empty sum (zero).
    pub fn new() -> Self {
        ExactSum {
            limbs: [0; LIMBS],
            nonfinite: 0.0_f64.to_bits(),
        }
    }

    /// The sum of `values`.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Self {
        let mut s = Self::new();
        s.add_all(values);
        s
    }

    /// `Σ a_i b_i`, each product rounded as `a_i * b_i` is, then added
    /// exactly (blocks of [`BLOCK`] products by [`ExactSum::add_products`]).
    pub fn dot(a: &[f64], b: &[f64]) -> Self {
        let mut s = Self::new();
        for (x, y) in a.chunks(BLOCK).zip(b.chunks(BLOCK)) {
            s.add_products(x, y);
        }
        s
    }

    /// Adds the products `x_i y_i` of one block (at most [`BLOCK`]) exactly,
    /// in floating point where it can. With `σ_1` a power of two at least
    /// `2 n max|p|`, `q = (σ_k + r) − σ_k` splits a term `r` into a
    /// multiple of `2^−53 σ_k` and an exact remainder `r − q` of at most
    /// `2^−53 σ_k` (Rump, Ogita and Oishi's ExtractScalar), and the `q` of
    /// the block add up without rounding: every partial sum is such a
    /// multiple, below `σ_k`. Three levels, `σ_{k+1} = 2^−39 σ_k` (so that
    /// `n` remainders stay below `σ_{k+1} / 2`), take every bit of the
    /// products within 2^−64 of the largest; what is left of the others,
    /// and blocks with non-finite or extreme values, take the limbs'
    /// path.
    fn add_products(&mut self, x: &[f64], y: &[f64]) {
        let n = x.len().min(y.len());
        let (x, y) = (&x[..n], &y[..n]);
        let whole = n - n % LANES;
        // The largest product, and a probe that is NaN if any product is
        // not finite (0 · p is 0 for finite p, NaN otherwise).
        let (mut max, mut probe) = ([0.0_f64; LANES], [0.0_f64; LANES]);
        for (xs, ys) in x[..whole]
            .chunks_exact(LANES)
            .zip(y[..whole].chunks_exact(LANES))
        {
            let p: [f64; LANES] = std::array::from_fn(|l| xs[l] * ys[l]);
            for l in 0..LANES {
                let a = p[l].abs();
                max[l] = if a > max[l] { a } else { max[l] };
                probe[l] += 0.0 * p[l];
            }
        }
        for i in whole..n {
            let p = x[i] * y[i];
            max[0] = if p.abs() > max[0] { p.abs() } else { max[0] };
            probe[0] += 0.0 * p;
        }
        let max = max.iter().fold(0.0_f64, |m, &v| m.max(v));
        let top = ((max.to_bits() >> 52) & 0x7ff) as i32 - 1023;
        if max == 0.0 || probe.iter().any(|v| v.is_nan()) || !(-900..900).contains(&top) {
            self.add_all(x.iter().zip(y).map(|(a, b)| a * b));
            return;
        }
        let sigma: [f64; LEVELS] = std::array::from_fn(|k| power_of_two(top + 15 - 39 * k as i32));
        let mut sums = [[0.0_f64; LANES]; LEVELS];
        let mut left = [0.0_f64; LANES];
        for (xs, ys) in x[..whole]
            .chunks_exact(LANES)
            .zip(y[..whole].chunks_exact(LANES))
        {
            let mut r: [f64; LANES] = std::array::from_fn(|l| xs[l] * ys[l]);
            for k in 0..LEVELS {
                let q: [f64; LANES] = std::array::from_fn(|l| (sigma[k] + r[l]) - sigma[k]);
                for l in 0..LANES {
                    sums[k][l] += q[l];
                    r[l] -= q[l];
                }
            }
            for l in 0..LANES {
                left[l] += r[l].abs();
            }
        }
        for i in whole..n {
            let mut r = x[i] * y[i];
            for k in 0..LEVELS {
                let q = (sigma[k] + r) - sigma[k];
                sums[k][0] += q;
                r -= q;
            }
            left[0] += r.abs();
        }
        self.add_all(sums.iter().flatten().copied());
        if left.iter().any(|&v| v != 0.0) {
            // The bits below the third level, term by term.
            self.add_all(x.iter().zip(y).map(|(a, b)| {
                let mut r = a * b;
                for s in sigma {
                    r -= (s + r) - s;
                }
                r
            }));
        }
    }

    /// Adds `x` exactly.
    pub fn add(&mut self, x: f64) {
        self.add_all([x]);
    }

    /// Adds every value exactly. Terms of like size land in the same two
    /// limbs, so the limbs of the latest term are kept in registers until
    /// a term lands elsewhere.
    pub fn add_all(&mut self, values: impl IntoIterator<Item = f64>) {
        let mut at = usize::MAX;
        let (mut lo_sum, mut hi_sum) = (0_i128, 0_i128);
        for x in values {
            let bits = x.to_bits();
            let exponent = ((bits >> 52) & 0x7ff) as usize;
            if exponent == 0x7ff {
                self.add_nonfinite(x);
                continue;
            }
            let fraction = bits & ((1 << 52) - 1);
            // x = significand · 2^(shift − 1074).
            let (significand, shift) = match exponent {
                0 => (fraction, 0),
                e => (fraction | (1 << 52), e - 1),
            };
            let placed = (significand as u128) << (shift % 64);
            // All ones for a negative term: `(v ^ sign) - sign` is then
            // `-v` (no branch on the sign, which is random in a dot
            // product).
            let sign = -((bits >> 63) as i128);
            let (lo, hi) = ((placed as u64) as i128, (placed >> 64) as i128);
            if shift / 64 != at {
                self.flush(at, lo_sum, hi_sum);
                (at, lo_sum, hi_sum) = (shift / 64, 0, 0);
            }
            lo_sum += (lo ^ sign) - sign;
            hi_sum += (hi ^ sign) - sign;
        }
        self.flush(at, lo_sum, hi_sum);
    }

    /// Adds `lo` and `hi` to limbs `at` and `at + 1` (nothing when `at` is
    /// `usize::MAX`: no term yet).
    fn flush(&mut self, at: usize, lo: i128, hi: i128) {
        if at != usize::MAX {
            self.limbs[at] += lo;
            self.limbs[at + 1] += hi;
        }
    }

    /// Adds the terms of `other`.
    pub fn merge(&mut self, other: &ExactSum) {
        for (a, b) in self.limbs.iter_mut().zip(&other.limbs) {
            *a += b;
        }
        self.add_nonfinite(f64::from_bits(other.nonfinite));
    }

    fn add_nonfinite(&mut self, x: f64) {
        let s = f64::from_bits(self.nonfinite) + x;
        self.nonfinite = s.to_bits();
    }

    /// The limbs with the carries passed up: every limb but the last in
    /// `[0, 2^64)`, the last carrying the sign. One number has one such
    /// form.
    fn normalised(&self) -> [i128; LIMBS] {
        let mut l = self.limbs;
        for i in 0..LIMBS - 1 {
            let carry = l[i] >> 64;
            l[i] -= carry << 64;
            l[i + 1] += carry;
        }
        l
    }

    /// The sum, rounded once.
    pub fn value(&self) -> f64 {
        let nonfinite = f64::from_bits(self.nonfinite);
        if nonfinite != 0.0 || nonfinite.is_nan() {
            return nonfinite;
        }
        let l = self.normalised();
        if l[LIMBS - 1] < 0 {
            let negated = ExactSum {
                limbs: l.map(|x| -x),
                nonfinite: 0.0_f64.to_bits(),
            };
            return -magnitude(&negated.normalised());
        }
        magnitude(&l)
    }

    /// The sum as numbers that an `f64` transport carries exactly (each
    /// normalised limb in two 32-bit halves, then the non-finite part).
    pub fn to_words(&self) -> [f64; WORDS] {
        let mut w = [0.0; WORDS];
        for (i, limb) in self.normalised().iter().enumerate() {
            w[2 * i] = (limb & 0xffff_ffff) as f64;
            w[2 * i + 1] = (limb >> 32) as f64;
        }
        w[WORDS - 1] = f64::from_bits(self.nonfinite);
        w
    }

    /// The sum as integers that add up entry by entry: the normalised
    /// limbs in 32-bit halves, then how many of its non-finite terms'
    /// totals are +∞, −∞ and NaN. The entry-wise sum of the integers of up
    /// to 2^31 sums is the integers of their total
    /// ([`ExactSum::from_integers`]), so an integer sum in any order (an
    /// MPI reduction tree) adds exact sums exactly.
    pub fn to_integers(&self) -> [i64; INTEGERS] {
        let mut v = [0; INTEGERS];
        for (i, limb) in self.normalised().iter().enumerate() {
            v[2 * i] = (limb & 0xffff_ffff) as i64;
            v[2 * i + 1] = (limb >> 32) as i64;
        }
        let nonfinite = f64::from_bits(self.nonfinite);
        let at = 2 * LIMBS;
        match nonfinite {
            x if x.is_nan() => v[at + 2] = 1,
            f64::INFINITY => v[at] = 1,
            f64::NEG_INFINITY => v[at + 1] = 1,
            _ => {}
        }
        v
    }

    /// The sum whose [`ExactSum::to_integers`] (or an entry-wise sum of
    /// several) is `v`; the non-finite part as floating point adds its
    /// terms: NaN with a NaN or both infinities, else the infinity there is.
    pub fn from_integers(v: &[i64]) -> Self {
        let mut s = Self::new();
        for (i, limb) in s.limbs.iter_mut().enumerate() {
            *limb = i128::from(v[2 * i]) + (i128::from(v[2 * i + 1]) << 32);
        }
        let at = 2 * LIMBS;
        let (pos, neg, nan) = (v[at] > 0, v[at + 1] > 0, v[at + 2] > 0);
        let nonfinite = match (pos, neg, nan) {
            (_, _, true) | (true, true, _) => f64::NAN,
            (true, false, false) => f64::INFINITY,
            (false, true, false) => f64::NEG_INFINITY,
            (false, false, false) => 0.0,
        };
        s.nonfinite = nonfinite.to_bits();
        s
    }

    /// The sum that [`ExactSum::to_words`] gave `words`.
    pub fn from_words(words: &[f64]) -> Self {
        let mut s = Self::new();
        for (i, limb) in s.limbs.iter_mut().enumerate() {
            *limb = words[2 * i] as i128 + ((words[2 * i + 1] as i128) << 32);
        }
        s.nonfinite = words[WORDS - 1].to_bits();
        s
    }
}

/// The normalised, non-negative `l` as the nearest `f64`: its top 128
/// bits, with a sticky bit for anything below, scaled by a power of two.
fn magnitude(l: &[i128; LIMBS]) -> f64 {
    let Some(top) = (0..LIMBS).rev().find(|&i| l[i] != 0) else {
        return 0.0;
    };
    let low = top.saturating_sub(1);
    let mut head = (l[top] as u128) << (64 * (top - low));
    if top > low {
        head |= l[low] as u128;
    }
    // `head` has at least 65 significant bits when anything lies below
    // it, so its lowest bit is below the rounding position.
    if l[..low].iter().any(|&x| x != 0) {
        head |= 1;
    }
    scale(head as f64, 64 * low as i32 - 1074)
}

/// `2^k` for a normal exponent `k`.
fn power_of_two(k: i32) -> f64 {
    f64::from_bits(((1023 + k) as u64) << 52)
}

/// `x 2^k`, in steps whose factors are exact powers of two.
fn scale(mut x: f64, mut k: i32) -> f64 {
    while k != 0 {
        let step = k.clamp(-1000, 1000);
        x *= power_of_two(step);
        k -= step;
    }
    x
}

#[cfg(test)]
#[path = "exact_tests.rs"]
mod tests;
