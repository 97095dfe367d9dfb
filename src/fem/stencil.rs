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
//! (structure-of-arrays) copy `xs` of `x`. The kernel works on tiles of
//! [`TILE`] consecutive nodes, each stencil term one fused multiply-add over a
//! contiguous slice, accumulated in registers.

/// Nodes per tile (register block) of the run kernel.
pub const TILE: usize = 8;

/// Entries `|v| ≤ ZERO · max |S|` are structurally zero (rounding residue).
const ZERO: f64 = 1e-14;

/// One stencil entry: `src = 27 j + 3 r + (di+1)` picks the source slice of a
/// run (component `j`, neighbour row `r`, shift `di+1`), `v = S_d[i][j]`.
#[derive(Clone, Copy, Debug)]
struct Term {
    src: u8,
    v: f64,
}

/// A run of interior nodes with consecutive active indices.
#[derive(Clone, Copy, Debug)]
pub struct Run {
    /// Active index of the first node.
    pub start: u32,
    pub len: u32,
    /// Active index of node `(I₀−1, J+dj, K+dk)` for `r = (dj+1) + 3(dk+1)`.
    pub bases: [u32; 9],
}

/// The nonzero terms of the interior stencil, per output component.
#[derive(Clone, Debug)]
pub struct Stencil {
    terms: [Vec<Term>; 3],
}

impl Stencil {
    /// The stencil of the inside-cell matrix `k` (row-major 24 × 24).
    pub fn new(k: &[f64]) -> Stencil {
        debug_assert_eq!(k.len(), 24 * 24);
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
        let mut terms: [Vec<Term>; 3] = Default::default();
        for (d, sd) in s.iter().enumerate() {
            let (shift, row) = (d % 3, d / 3);
            for (i, si) in sd.iter().enumerate() {
                for (j, &v) in si.iter().enumerate() {
                    if v.abs() > ZERO * scale {
                        let src = (27 * j + 3 * row + shift) as u8;
                        terms[i].push(Term { src, v });
                    }
                }
            }
        }
        Stencil { terms }
    }

    /// Bytes of stencil data.
    pub fn bytes(&self) -> usize {
        let terms: usize = self.terms.iter().map(Vec::len).sum();
        terms * std::mem::size_of::<Term>()
    }

    /// `y[3 (a − lo) + i] = (A x)_{3a+i}` for the nodes `a` of `runs`, with
    /// `xs` the de-interleaved `x` (component `j` at `xs[j stride ..]`, padded
    /// by at least [`TILE`] entries after the last node).
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
            let src = sources(run, stride);
            let len = run.len as usize;
            for t0 in (0..len).step_by(TILE) {
                let out = self.tile::<FMA>(xs, &src, t0);
                let a0 = run.start as usize + t0 - lo;
                for l in 0..TILE.min(len - t0) {
                    for i in 0..3 {
                        y[3 * (a0 + l) + i] = out[i][l];
                    }
                }
            }
        }
    }

    /// The three output components of the tile of nodes `t0 .. t0 + TILE`.
    #[inline(always)]
    fn tile<const FMA: bool>(&self, xs: &[f64], src: &[usize; 81], t0: usize) -> [[f64; TILE]; 3] {
        let mut out = [[0.0; TILE]; 3];
        for (acc, terms) in out.iter_mut().zip(&self.terms) {
            for t in terms {
                let s = src[t.src as usize] + t0;
                let x = &xs[s..s + TILE];
                for l in 0..TILE {
                    acc[l] = madd::<FMA>(t.v, x[l], acc[l]);
                }
            }
        }
        out
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

/// The start in `xs` of every source slice of a run: `27 j + 3 r + shift ↦
/// j stride + bases[r] + shift`.
#[inline(always)]
fn sources(run: &Run, stride: usize) -> [usize; 81] {
    let mut src = [0; 81];
    for j in 0..3 {
        for r in 0..9 {
            for shift in 0..3 {
                src[27 * j + 3 * r + shift] = j * stride + run.bases[r] as usize + shift;
            }
        }
    }
    src
}
