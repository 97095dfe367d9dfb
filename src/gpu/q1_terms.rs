//! The unrolled bodies of the Q1 kernels (`shaders/q1_nodes.wgsl`,
//! `shaders/q1_cells.wgsl`): the structurally nonzero terms of the interior
//! stencil and the packed symmetric cell product, as term lists that the WGSL
//! generator ([`expand`]) and the CPU mirrors ([`super::mirror::q1_nodes`],
//! [`super::mirror::q1_cells`]) walk in the same order.

use crate::fem::stencil::coupled;

/// Interior nodes per segment (= the workgroup size of `q1_nodes`).
/// Keep in sync with `SEG` in q1_nodes.wgsl.
pub const SEG: usize = 64;
/// Words per segment: start, length, the 9 row bases, padding.
/// Keep in sync with `SEGMENT_WORDS` in q1_nodes.wgsl.
pub const SEGMENT_WORDS: usize = 12;
/// Entries of a packed symmetric 24 × 24 matrix.
pub const PACKED: usize = 300;
/// Stencil values in the uniform (`81 · 3`, padded to whole `vec4`s).
pub const STENCIL_LEN: usize = 244;

/// One stencil term: `y_i += S[k] · x[3 (bases[r] + t + shift) + j]`.
#[derive(Clone, Copy, Debug)]
pub struct StencilTerm {
    pub i: usize,
    /// `k = 3 (27 j + 3 r + shift) + i`.
    pub k: usize,
    pub j: usize,
    pub r: usize,
    pub shift: usize,
}

/// The terms of the interior stencil, `j`, `r`, `shift`, `i` from slowest.
pub fn stencil_terms() -> Vec<StencilTerm> {
    let mut out = Vec::with_capacity(153);
    for j in 0..3 {
        for r in 0..9 {
            for shift in 0..3 {
                for i in 0..3 {
                    if coupled(i, j, r, shift) {
                        let k = 3 * (27 * j + 3 * r + shift) + i;
                        out.push(StencilTerm { i, k, j, r, shift });
                    }
                }
            }
        }
    }
    out
}

/// Index of `(r, c)`, `r ≤ c`, in a packed symmetric 24 × 24 matrix (upper
/// triangle, row-major).
pub const fn packed_index(r: usize, c: usize) -> usize {
    r * 24 - r * (r + 1) / 2 + c
}

/// The packed upper triangle of a row-major 24 × 24 matrix.
pub fn pack(k: &[f64]) -> [f64; PACKED] {
    let mut out = [0.0; PACKED];
    for r in 0..24 {
        for c in r..24 {
            out[packed_index(r, c)] = k[r * 24 + c];
        }
    }
    out
}

/// The largest `|K[r][c] − K[c][r]|` of a row-major 24 × 24 matrix,
/// relative to its largest entry.
pub fn asymmetry(k: &[f64]) -> f64 {
    let scale = k.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut worst = 0.0f64;
    for r in 0..24 {
        for c in r + 1..24 {
            worst = worst.max((k[r * 24 + c] - k[c * 24 + r]).abs());
        }
    }
    if scale > 0.0 {
        worst / scale
    } else {
        worst
    }
}

/// The WGSL source `src` with its markers replaced by the generated code.
pub fn expand(src: &str) -> String {
    let mut out = String::with_capacity(src.len() + 32 * 1024);
    for line in src.lines() {
        match line.trim() {
            "// @stencil" => out.push_str(&interior_terms()),
            "// @bases" => out.push_str(&row_bases()),
            "// @product" => out.push_str(&cell_terms()),
            "// @gather" => out.push_str(&cell_gather()),
            "// @store" => out.push_str(&cell_store()),
            _ => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    out
}

fn interior_terms() -> String {
    stencil_terms()
        .iter()
        .map(|t| {
            format!(
                "    y{} += st({}u) * x[3u * (b{} + {}u) + {}u];\n",
                t.i, t.k, t.r, t.shift, t.j
            )
        })
        .collect()
}

fn row_bases() -> String {
    (0..9)
        .map(|r| format!("    let b{r} = segments[s + {}u] + t;\n", 2 + r))
        .collect()
}

fn cell_gather() -> String {
    let mut s = String::new();
    for m in 0..8 {
        s += &format!("    let n{m} = 3u * cell_nodes[8u * c + {m}u];\n");
        for j in 0..3 {
            s += &format!("    let u{} = x[n{m} + {j}u];\n", 3 * m + j);
        }
    }
    for r in 0..24 {
        s += &format!("    var z{r}: real = 0.0;\n");
    }
    s
}

fn cell_terms() -> String {
    let mut s = String::new();
    for r in 0..24 {
        for c in r..24 {
            let e = packed_index(r, c);
            s += &format!("    {{ let k = k_cells[base + {e}u * step]; z{r} += k * u{c};");
            if r != c {
                s += &format!(" z{c} += k * u{r};");
            }
            s += " }\n";
        }
    }
    s
}

fn cell_store() -> String {
    (0..24)
        .map(|r| format!("    z[24u * c + {r}u] = z{r};\n"))
        .collect()
}
