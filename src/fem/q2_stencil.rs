//! The constant stencils of the Q2 operator at interior nodes, and the kernel
//! that applies them along runs of such nodes.
//!
//! # The stencils
//! The Q2 node lattice has spacing `h/2`; a node's *type* is the parity of its
//! lattice coordinates, `τ = (I mod 2, J mod 2, K mod 2)`: even along an axis,
//! it lies on a cell face (the cells on both sides hold it, at local
//! coordinate 2 and 0), odd, inside one cell (local coordinate 1). A node all
//! of whose cells are inside sees only `h K_ref`; its neighbour at lattice
//! offset `d` is node `m = l + d` of the cell where it is local node `l`, so
//!
//! ```text
//! y_{n,i} = Σ_d Σ_j S^τ_d[i][j] x_{n+d, j},   S^τ_d[i][j] = Σ_{(c, l) ∋ n} K[3l+i, 3(l+d)+j],
//! ```
//! with `d` in `−2..=2` along an even axis and `−1..=1` along an odd one: 125,
//! 75, 45 or 27 neighbours. Entries that vanish (the coupling of `i ≠ j` where
//! `d_i = 0` or `d_j = 0`, and a few more of the vertex type) are dropped:
//! 849, 481, 271 and 153 terms remain.
//!
//! # Runs
//! Interior nodes `(I₀ … I₀+len−1, J, K)` with consecutive active indices form
//! a run; its nodes alternate between two types along `x`, so the kernel
//! takes the two halves (`I₀, I₀+2, …` and `I₀+1, I₀+3, …`) one after the
//! other, each with one stencil. `bases[r]` is the active index of
//! `(I₀, J+dy, K+dz)`, `r = (dy+2) + 5(dz+2)`; the neighbours of a run's
//! nodes lie in its rows, whose active indices are consecutive. `x` is read
//! de-interleaved and split by the parity of the active index
//! ([`position`]), so that every other node of a row, the neighbours of a
//! half at one offset, is a contiguous slice.
//!
//! # Kernel
//! Per half, the terms are grouped by the output components they feed (a
//! *source slice* `(j, dy, dz, dx)` feeds one to three); a tile of
//! [`TILE`] nodes loads each slice once into vectors of 4 and accumulates
//! `3 · TILE / 4` independent vectors; a half's last nodes go through tiles
//! of [`TAIL`] nodes.

use super::stencil::madd;

/// Nodes per main tile (register block) of the run kernel.
pub const TILE: usize = 12;
/// Nodes per tile at the end of a half-run.
const TAIL: usize = 4;
/// Entries `|v| ≤ ZERO · max |S|` are rounding residue.
const ZERO: f64 = 1e-14;
/// Neighbour offsets per type: `(dy, dz)` rows times `dx`, `5 · 25`.
const OFFSETS: usize = 125;

/// A run of interior Q2 nodes with consecutive active indices.
#[derive(Clone, Copy, Debug)]
pub struct Run {
    /// Active index of the first node.
    pub start: u32,
    pub len: u32,
    /// The first node's type, `(I₀ mod 2) + 2 (J mod 2) + 4 (K mod 2)`.
    pub parity: u32,
    /// Active index of `(I₀, J+dy, K+dz)`, `r = (dy+2) + 5(dz+2)`
    /// (`u32::MAX` for the rows no node of the run reads).
    pub bases: [u32; 25],
}

/// Where active node `a` sits in one component of the split, de-interleaved
/// `x` ([`Q2Stencil::apply_runs`]), `half` entries per parity.
#[inline(always)]
pub fn position(a: usize, half: usize) -> usize {
    (a % 2) * half + a / 2
}

/// One source slice: `src = 125 j + (dx+2) + 5((dy+2) + 5(dz+2))`, and its
/// coefficients per output component (zero where not fed).
#[derive(Clone, Copy, Debug)]
struct Term {
    src: u32,
    c: [f64; 3],
}

/// The stencil of one node type: its source slices grouped by the set of
/// output components they feed (`groups[mask − 1]`, bit `i` for component
/// `i`), and the neighbour offsets it reads.
#[derive(Clone, Debug, Default)]
struct TypeStencil {
    groups: [Vec<Term>; 7],
    offsets: Vec<u8>,
}

/// The interior stencils of the 8 node types.
#[derive(Clone, Debug)]
pub struct Q2Stencil {
    types: [TypeStencil; 8],
}

impl Q2Stencil {
    /// The stencils of the inside-cell matrix `k` (row-major 81 × 81).
    pub fn new(k: &[f64]) -> Q2Stencil {
        assert_eq!(k.len(), 81 * 81);
        let scale = k.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let types = std::array::from_fn(|t| {
            let parity = [t & 1, (t >> 1) & 1, t >> 2];
            // Per axis, the local coordinates of the node in its cells.
            let locals = parity.map(|p| if p == 1 { vec![1] } else { vec![2, 0] });
            // s[offset][j][i]
            let mut s = [[[0.0; 3]; 3]; OFFSETS];
            for &lz in &locals[2] {
                for &ly in &locals[1] {
                    for &lx in &locals[0] {
                        let l = lx + 3 * (ly + 3 * lz);
                        for m in 0..27 {
                            let nu = [m % 3, (m / 3) % 3, m / 9];
                            let o =
                                (nu[0] + 2 - lx) + 5 * ((nu[1] + 2 - ly) + 5 * (nu[2] + 2 - lz));
                            for (j, sj) in s[o].iter_mut().enumerate() {
                                for (i, v) in sj.iter_mut().enumerate() {
                                    *v += k[(3 * l + i) * 81 + 3 * m + j];
                                }
                            }
                        }
                    }
                }
            }
            let mut stencil = TypeStencil::default();
            for (o, so) in s.iter().enumerate() {
                let mut used = false;
                for (j, c) in so.iter().enumerate() {
                    let mask =
                        (0..3).fold(0, |m, i| m | (usize::from(c[i].abs() > ZERO * scale) << i));
                    if mask > 0 {
                        let c =
                            std::array::from_fn(|i| if mask >> i & 1 == 1 { c[i] } else { 0.0 });
                        let src = (OFFSETS * j + o) as u32;
                        stencil.groups[mask - 1].push(Term { src, c });
                        used = true;
                    }
                }
                if used {
                    stencil.offsets.push(o as u8);
                }
            }
            stencil
        });
        Q2Stencil { types }
    }

    /// Number of terms of type `t`'s stencil.
    pub fn terms(&self, t: usize) -> usize {
        let st = &self.types[t];
        st.groups
            .iter()
            .enumerate()
            .map(|(m, g)| g.len() * (m + 1).count_ones() as usize)
            .sum()
    }

    /// Bytes of stencil data.
    pub fn bytes(&self) -> usize {
        self.types
            .iter()
            .map(|t| {
                t.offsets.len()
                    + t.groups.iter().map(Vec::len).sum::<usize>() * std::mem::size_of::<Term>()
            })
            .sum()
    }

    /// `y[3 (a − lo) + i] = (A x)_{3a+i}` for the nodes `a` of `runs`, with
    /// `xs` the split de-interleaved `x`: component `j` of active node `a` at
    /// `xs[j stride + position(a, half)]`, each parity padded by at least
    /// [`TILE`] finite entries. `FMA` only where the CPU has AVX2 and FMA.
    #[inline(always)]
    pub fn apply_runs<const FMA: bool>(
        &self,
        runs: &[Run],
        xs: &[f64],
        (stride, half): (usize, usize),
        y: &mut [f64],
        lo: usize,
    ) {
        assert!(stride >= 2 * half);
        let mut src = [0usize; 3 * OFFSETS];
        for run in runs {
            for h in 0..2 {
                let count = (run.len as usize + 1 - h) / 2;
                if count == 0 {
                    continue;
                }
                let ty = &self.types[run.parity as usize ^ h];
                // Every tile reads `count` rounded up to `TAIL` entries.
                let extent = count.next_multiple_of(TAIL);
                for &o in &ty.offsets {
                    let (o, dx) = (o as usize, (o as usize % 5) as isize - 2);
                    let a = run.bases[o / 5] as isize + h as isize + dx;
                    let p = position(a as usize, half);
                    // Bounds of every read below (lanes past `count` are dropped).
                    assert!(
                        a >= 0 && p + extent + 2 * stride <= xs.len(),
                        "run reads past x"
                    );
                    for j in 0..3 {
                        src[OFFSETS * j + o] = j * stride + p;
                    }
                }
                let first = run.start as usize + h;
                let mut t0 = 0;
                while t0 + TILE <= count {
                    let out = tile::<FMA, { TILE / 4 }, TILE>(ty, &src, xs, t0);
                    store(&out, y, first + 2 * t0 - lo, TILE);
                    t0 += TILE;
                }
                while t0 < count {
                    let out = tile::<FMA, { TAIL / 4 }, TAIL>(ty, &src, xs, t0);
                    store(&out, y, first + 2 * t0 - lo, TAIL.min(count - t0));
                    t0 += TAIL;
                }
            }
        }
    }
}

/// The three output components of the tile of nodes `t0 .. t0 + T` of a
/// half-run (`T = 4 N`): `Σ_terms c[i] · xs[src + t0 ..][.. T]`.
#[inline(always)]
fn tile<const FMA: bool, const N: usize, const T: usize>(
    ty: &TypeStencil,
    src: &[usize; 3 * OFFSETS],
    xs: &[f64],
    t0: usize,
) -> [[[f64; 4]; N]; 3] {
    debug_assert_eq!(4 * N, T);
    let mut acc = [[[0.0; 4]; N]; 3];
    group::<FMA, N, 1>(&ty.groups[0], src, xs, t0, &mut acc);
    group::<FMA, N, 2>(&ty.groups[1], src, xs, t0, &mut acc);
    group::<FMA, N, 3>(&ty.groups[2], src, xs, t0, &mut acc);
    group::<FMA, N, 4>(&ty.groups[3], src, xs, t0, &mut acc);
    group::<FMA, N, 5>(&ty.groups[4], src, xs, t0, &mut acc);
    group::<FMA, N, 6>(&ty.groups[5], src, xs, t0, &mut acc);
    group::<FMA, N, 7>(&ty.groups[6], src, xs, t0, &mut acc);
    acc
}

/// The terms of one group (`MASK`: the output components they feed).
#[inline(always)]
fn group<const FMA: bool, const N: usize, const MASK: usize>(
    terms: &[Term],
    src: &[usize; 3 * OFFSETS],
    xs: &[f64],
    t0: usize,
    acc: &mut [[[f64; 4]; N]; 3],
) {
    for term in terms {
        let first = src[term.src as usize] + t0;
        // SAFETY: `apply_runs` checked that `xs` holds every tile's reads:
        // `first + 4 N ≤ p + extent ≤ xs.len()` for the term's source `p`.
        let x: [[f64; 4]; N] = std::array::from_fn(|v| unsafe {
            std::ptr::read_unaligned(xs.as_ptr().add(first + 4 * v).cast::<[f64; 4]>())
        });
        for (i, acc) in acc.iter_mut().enumerate() {
            if MASK >> i & 1 == 1 {
                let c = term.c[i];
                for (a, xv) in acc.iter_mut().zip(&x) {
                    for l in 0..4 {
                        a[l] = madd::<FMA>(c, xv[l], a[l]);
                    }
                }
            }
        }
    }
}

/// `y[3 (a0 + 2t) + i] = out[i][t]` for the first `count` nodes `t` of a tile
/// of a half-run.
#[inline(always)]
fn store<const N: usize>(out: &[[[f64; 4]; N]; 3], y: &mut [f64], a0: usize, count: usize) {
    for t in 0..count {
        for (i, o) in out.iter().enumerate() {
            y[3 * (a0 + 2 * t) + i] = o[t / 4][t % 4];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::reference::reference_stiffness;
    use crate::element::ElementOrder;

    #[test]
    fn the_stencils_keep_the_couplings_that_do_not_vanish() {
        let k = reference_stiffness(ElementOrder::Q2, 1000.0, 0.3) * 0.25;
        let k: Vec<f64> = (0..81 * 81).map(|e| k[(e / 81, e % 81)]).collect();
        let s = Q2Stencil::new(&k);
        // The couplings that do not vanish by symmetry (`i ≠ j` needs
        // `d_i ≠ 0` and `d_j ≠ 0`), by type; a few more vanish by accident.
        let structural = [855, 481, 481, 271, 481, 271, 271, 153];
        let terms: Vec<usize> = (0..8).map(|t| s.terms(t)).collect();
        for (t, (&n, &e)) in terms.iter().zip(&structural).enumerate() {
            assert!(n <= e && 100 * n >= 99 * e, "type {t}: {n} terms");
        }
    }
}
