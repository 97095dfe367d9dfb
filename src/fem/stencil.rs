//! The constant 27-point stencil of the Q1 operator at interior nodes, and the
//! vectorised kernel that applies it along runs of such nodes.
//!
//! # The stencil
//! A node whose 8 surrounding cells are all inside sees only `h K_ref`. Write
//! `ν(l) = (l mod 2, ⌊l/2⌋ mod 2, ⌊l/4⌋)` for the lattice position of local node
//! `l` in its cell. The node is local node `l` of exactly one of its 8 cells for
//! each `l`, and that cell's node `m` is the neighbour at offset
//! `d = ν(m) − ν(l) ∈ {−1, 0, 1}³`, so its rows of the operator are
//!
//! ```text
//! y_{n,i} = Σ_d Σ_j S_d[i][j] x_{n+d, j},   S_d[i][j] = Σ_{l,m: ν(m)−ν(l)=d} K[3l+i, 3m+j].
//! ```
//!
//! Of the `27 · 9` entries, those that vanish (the coupling of components
//! `i ≠ j` is odd in `d_i` and `d_j`) are dropped: about 150 remain.
//!
//! # Runs
//! Active nodes are numbered in lattice order, so a run of interior nodes
//! `(I₀ … I₀+len−1, J, K)` has consecutive active indices, and so has each of
//! its 9 neighbour rows `(I₀−1 … I₀+len, J+dj, K+dk)` (all of whose nodes are
//! active). With `bases[r]` the active index of `(I₀−1, J+dj, K+dk)`,
//! `r = (dj+1) + 3(dk+1)`, node `t` of the run reads component `j` of its
//! neighbour `d` at `xs[j][bases[r] + (di+1) + t]` in the de-interleaved
//! (structure-of-arrays) copy `xs` of `x`.
//!
//! # Kernel
//! The zero pattern is fixed (`S_d[i][j]` for `i ≠ j` needs `d_i ≠ 0` and
//! `d_j ≠ 0`: 81 + 72 = 153 terms), so the kernel is unrolled at compile time
//! over the 81 source slices `(j, r, shift)`: each slice of a tile is loaded
//! once and feeds the (one to three) output components it couples to. A tile
//! of [`TILE`] nodes keeps `3 · TILE / 4` independent accumulator vectors in
//! registers, which hides the latency of the fused multiply-adds; a run's
//! last nodes go through tiles of [`TAIL`] nodes.

/// Nodes per main tile (register block) of the run kernel.
pub const TILE: usize = 12;
/// Nodes per tile at the end of a run.
const TAIL: usize = 4;

/// Entries `|v| ≤ ZERO · max |S|` are rounding residue.
const ZERO: f64 = 1e-14;

/// A run of interior nodes with consecutive active indices.
#[derive(Clone, Copy, Debug)]
pub struct Run {
    /// Active index of the first node.
    pub start: u32,
    pub len: u32,
    /// Active index of node `(I₀−1, J+dj, K+dk)` for `r = (dj+1) + 3(dk+1)`.
    pub bases: [u32; 9],
}

/// Invokes `$m!(j, r, shift)` for every source slice, `j` slowest.
macro_rules! each_slice {
    ($m:ident) => {
        each_slice!(@j $m 0);
        each_slice!(@j $m 1);
        each_slice!(@j $m 2);
    };
    (@j $m:ident $j:literal) => {
        each_slice!(@r $m $j 0);
        each_slice!(@r $m $j 1);
        each_slice!(@r $m $j 2);
        each_slice!(@r $m $j 3);
        each_slice!(@r $m $j 4);
        each_slice!(@r $m $j 5);
        each_slice!(@r $m $j 6);
        each_slice!(@r $m $j 7);
        each_slice!(@r $m $j 8);
    };
    (@r $m:ident $j:literal $r:literal) => {
        $m!($j, $r, 0);
        $m!($j, $r, 1);
        $m!($j, $r, 2);
    };
}

/// Whether `S_d[i][j]` is structurally nonzero, with `d = (shift, r mod 3,
/// r / 3) − 1`: always for `i = j`, else when `d_i ≠ 0` and `d_j ≠ 0`.
pub const fn coupled(i: usize, j: usize, r: usize, shift: usize) -> bool {
    let d = [shift, r % 3, r / 3];
    i == j || (d[i] != 1 && d[j] != 1)
}

/// The interior stencil: `values[27 j + 3 r + shift][i] = S_d[i][j]`, zero
/// where not [`coupled`].
#[derive(Clone, Debug)]
pub struct Stencil {
    values: [[f64; 3]; 81],
}

impl Stencil {
    /// The stencil of the inside-cell matrix `k` (row-major 24 × 24, an
    /// isotropic material on a cube, whose stencil has the zero pattern of
    /// [`coupled`]; panics otherwise).
    pub fn new(k: &[f64]) -> Stencil {
        assert_eq!(k.len(), 24 * 24);
        let nu = |l: usize| [l & 1, (l >> 1) & 1, l >> 2];
        // s[d][i][j], d = (di+1) + 3 (dj+1) + 9 (dk+1).
        let mut s = [[[0.0; 3]; 3]; 27];
        for l in 0..8 {
            for m in 0..8 {
                let (p, q) = (nu(l), nu(m));
                let d = (q[0] + 1 - p[0]) + 3 * (q[1] + 1 - p[1]) + 9 * (q[2] + 1 - p[2]);
                for i in 0..3 {
                    for j in 0..3 {
                        s[d][i][j] += k[(3 * l + i) * 24 + 3 * m + j];
                    }
                }
            }
        }
        let scale = s
            .iter()
            .flatten()
            .flatten()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        let mut values = [[0.0; 3]; 81];
        for (d, sd) in s.iter().enumerate() {
            let (shift, r) = (d % 3, d / 3);
            for (i, si) in sd.iter().enumerate() {
                for (j, &v) in si.iter().enumerate() {
                    if coupled(i, j, r, shift) {
                        values[27 * j + 3 * r + shift][i] = v;
                    } else if v.abs() > ZERO * scale {
                        // (Non-finite entries are left to the operator's checks.)
                        panic!("S_{d}[{i}][{j}] = {v} is not zero");
                    }
                }
            }
        }
        Stencil { values }
    }

    /// `values()[27 j + 3 r + shift][i] = S_d[i][j]`, `d = (shift, r mod 3,
    /// r / 3) − 1`; zero where not [`coupled`].
    pub fn values(&self) -> &[[f64; 3]; 81] {
        &self.values
    }

    /// Bytes of stencil data.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(&self.values)
    }

    /// `y[3 (a − lo) + i] = (A x)_{3a+i}` for the nodes `a` of `runs`, with
    /// `xs` the de-interleaved `x` (component `j` at `xs[j stride ..]`, padded
    /// by at least [`TILE`] entries after the last node). `FMA` (the AVX2/FMA
    /// kernel) only where the CPU has them.
    #[inline(always)]
    pub fn apply_runs<const FMA: bool>(
        &self,
        runs: &[Run],
        xs: &[f64],
        stride: usize,
        y: &mut [f64],
        lo: usize,
    ) {
        for run in runs {
            let len = run.len as usize;
            // Tiles end at most at `len` rounded up to `TAIL`; a tile reads
            // up to 2 entries past its end (shift).
            let extent = len.next_multiple_of(TAIL) + 2;
            let rows: [&[f64]; 27] = std::array::from_fn(|q| {
                let (j, r) = (q / 9, q % 9);
                let first = j * stride + run.bases[r] as usize;
                &xs[first..first + extent]
            });
            let mut t0 = 0;
            while t0 + TILE <= len {
                let out = self.tile::<FMA, { TILE / 4 }, TILE>(&rows, t0);
                store(&out, y, run.start as usize + t0 - lo, TILE);
                t0 += TILE;
            }
            while t0 < len {
                let out = self.tile::<FMA, { TAIL / 4 }, TAIL>(&rows, t0);
                store(&out, y, run.start as usize + t0 - lo, TAIL.min(len - t0));
                t0 += TAIL;
            }
        }
    }

    /// The three output components of the tile of nodes `t0 .. t0 + T`
    /// (`T = 4 N`), reading `rows[9 j + r][t0 + shift ..][.. T]`.
    #[inline(always)]
    fn tile<const FMA: bool, const N: usize, const T: usize>(
        &self,
        rows: &[&[f64]; 27],
        t0: usize,
    ) -> [[f64; T]; 3] {
        debug_assert_eq!(4 * N, T);
        for row in rows {
            assert!(t0 + T + 2 <= row.len(), "tile past its rows");
        }
        #[cfg(target_arch = "x86_64")]
        if FMA {
            // SAFETY: `FMA` is set only where the CPU has AVX2 and FMA; the
            // rows hold `t0 + T + 2` entries (asserted above).
            return unsafe { self.tile_avx::<N, T>(rows, t0) };
        }
        self.tile_portable::<T>(rows, t0)
    }

    /// [`Self::tile`] with AVX2/FMA vectors: `N` per output component.
    ///
    /// # Safety
    /// The CPU has AVX2 and FMA, and `t0 + T + 2 ≤ rows[q].len()` for all `q`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn tile_avx<const N: usize, const T: usize>(
        &self,
        rows: &[&[f64]; 27],
        t0: usize,
    ) -> [[f64; T]; 3] {
        use std::arch::x86_64::*;
        let mut acc = [[_mm256_setzero_pd(); N]; 3];
        macro_rules! slice {
            ($j:literal, $r:literal, $shift:literal) => {{
                let p = rows[9 * $j + $r].as_ptr().add(t0 + $shift);
                // In bounds: `t0 + $shift + 4 N ≤ t0 + T + 2 ≤ len` (safety).
                let x: [__m256d; N] = std::array::from_fn(|v| _mm256_loadu_pd(p.add(4 * v)));
                let vals = &self.values[27 * $j + 3 * $r + $shift];
                for (i, acc) in acc.iter_mut().enumerate() {
                    if coupled(i, $j, $r, $shift) {
                        let c = _mm256_set1_pd(vals[i]);
                        for (a, xv) in acc.iter_mut().zip(&x) {
                            *a = _mm256_fmadd_pd(c, *xv, *a);
                        }
                    }
                }
            }};
        }
        each_slice!(slice);
        let mut out = [[0.0; T]; 3];
        for (o, a) in out.iter_mut().zip(&acc) {
            for (v, av) in a.iter().enumerate() {
                _mm256_storeu_pd(o[4 * v..4 * v + 4].as_mut_ptr(), *av);
            }
        }
        out
    }

    /// [`Self::tile`] in portable code (the same terms, unfused).
    #[inline(always)]
    fn tile_portable<const T: usize>(&self, rows: &[&[f64]; 27], t0: usize) -> [[f64; T]; 3] {
        let mut acc = [[0.0; T]; 3];
        macro_rules! slice {
            ($j:literal, $r:literal, $shift:literal) => {{
                let x = &rows[9 * $j + $r][t0 + $shift..t0 + $shift + T];
                let vals = &self.values[27 * $j + 3 * $r + $shift];
                for (i, acc) in acc.iter_mut().enumerate() {
                    if coupled(i, $j, $r, $shift) {
                        for (a, xv) in acc.iter_mut().zip(x) {
                            *a += vals[i] * xv;
                        }
                    }
                }
            }};
        }
        each_slice!(slice);
        acc
    }
}

/// `y[3 (a0 + l) + i] = out[i][l]` for the first `count` nodes of a tile.
#[inline(always)]
fn store<const T: usize>(out: &[[f64; T]; 3], y: &mut [f64], a0: usize, count: usize) {
    for (l, yl) in y[3 * a0..3 * (a0 + count)].chunks_exact_mut(3).enumerate() {
        for (i, yi) in yl.iter_mut().enumerate() {
            *yi = out[i][l];
        }
    }
}

/// `a b + c`, fused when `FMA` (only where the CPU has it).
#[inline(always)]
pub fn madd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// Asks the CPU to fetch the cache line of `x[0]` (for scattered reads,
/// which the hardware prefetchers do not foresee); a no-op elsewhere.
#[inline(always)]
pub fn prefetch(x: &[f64]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: SSE is part of the x86_64 baseline; a prefetch changes
        // nothing the program sees (and this address is inside `x`).
        unsafe { _mm_prefetch::<_MM_HINT_T0>(x.as_ptr().cast()) };
    }
}
