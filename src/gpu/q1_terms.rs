//! The unrolled bodies of the Q1 kernels (`shaders/q1_nodes.wgsl`,
//! `shaders/q1_cells.wgsl`): the structurally nonzero terms of the interior
//! stencil and the cell product from the factored forms of
//! [`crate::fem::q1_forms`], as term lists that the WGSL generator
//! ([`expand`]) and the CPU mirrors ([`super::mirror::q1_nodes`],
//! [`super::mirror::q1_cells`], through [`form_product`] and
//! [`mass_product`]) walk in the same order.

use crate::fem::q1_forms::{node, sym, t_index, MASS};
use crate::fem::stencil::coupled;

/// Interior nodes per segment (= the workgroup size of `q1_nodes`).
/// Keep in sync with `SEG` in q1_nodes.wgsl.
pub const SEG: usize = 64;
/// Words per segment: start, length, the 9 row bases, padding.
/// Keep in sync with `SEGMENT_WORDS` in q1_nodes.wgsl.
pub const SEGMENT_WORDS: usize = 12;
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

/// Numbers of a cell with a partial-mask penalty: its three component
/// masses, packed symmetric 8 × 8 ([`sym`]), component after component.
pub const PARTIAL_LEN: usize = 108;
/// `partial_of` of a cut cell without a partial-mask penalty.
pub const NO_PARTIAL: u32 = u32::MAX;

/// `dif[12 e + 4 j + β]`: the difference of component `j` along axis `e`
/// between the nodes `β` with coordinate 1 and 0 along it.
fn dif(e: usize, j: usize, beta: usize) -> usize {
    12 * e + 4 * j + beta
}

/// The stiffness part of a Q1 cell's product from its factored form
/// (`crate::fem::q1_forms`, whose module doc derives it): `z += K u`,
/// `t(k)` entry `k` of the form, in the order that `q1_cells`' generated
/// body ([`cell_terms`]) sums.
pub fn form_product(
    t: impl Fn(usize) -> f64,
    (lam, mu): (f64, f64),
    u: &[f64; 24],
    z: &mut [f64; 24],
) {
    let mut d = [0.0; 36];
    for e in 0..3 {
        for j in 0..3 {
            for beta in 0..4 {
                d[dif(e, j, beta)] = u[3 * node(e, beta, 1) + j] - u[3 * node(e, beta, 0) + j];
            }
        }
    }
    for dd in 0..3 {
        let mut p = [0.0; 4];
        for (alpha, p) in p.iter_mut().enumerate() {
            for e in 0..3 {
                for beta in 0..4 {
                    *p += t(t_index(dd, e, alpha, beta)) * d[dif(e, e, beta)];
                }
            }
        }
        for i in 0..3 {
            for alpha in 0..4 {
                let mut a = 0.0;
                for beta in 0..4 {
                    a += t(t_index(dd, i, alpha, beta)) * d[dif(i, dd, beta)];
                    a += t(t_index(dd, dd, alpha, beta)) * d[dif(dd, i, beta)];
                }
                let mut v = mu * a;
                if i == dd {
                    v += lam * p[alpha];
                }
                z[3 * node(dd, alpha, 1) + i] += v;
                z[3 * node(dd, alpha, 0) + i] -= v;
            }
        }
    }
}

/// `z_{a,i} += Σ_b m(i, k_ab) u_{b,i}` for the three components' packed
/// symmetric 8 × 8 masses, entry `k` of component `i`'s `m(i, k)`, in the
/// order of [`cell_terms`].
pub fn mass_product(m: impl Fn(usize, usize) -> f64, u: &[f64; 24], z: &mut [f64; 24]) {
    for i in 0..3 {
        for a in 0..8 {
            for b in a..8 {
                let k = m(i, sym(8, a, b));
                z[3 * a + i] += k * u[3 * b + i];
                if a != b {
                    z[3 * b + i] += k * u[3 * a + i];
                }
            }
        }
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

/// The body of [`form_product`], then the masses of [`mass_product`]
/// (the form's scalar mass for the cut cells, and the partial-mask
/// penalty's where a cut cell has one).
fn cell_terms() -> String {
    let mut s = String::new();
    let t = |k: usize| format!("k_cells[base + {k}u * step]");
    for e in 0..3 {
        for j in 0..3 {
            for beta in 0..4 {
                let (hi, lo) = (3 * node(e, beta, 1) + j, 3 * node(e, beta, 0) + j);
                s += &format!("    let d{} = u{hi} - u{lo};\n", dif(e, j, beta));
            }
        }
    }
    for dd in 0..3 {
        s += "    {\n";
        for alpha in 0..4 {
            s += &format!("        var p{alpha}: real = 0.0;\n");
            for e in 0..3 {
                for beta in 0..4 {
                    let k = t_index(dd, e, alpha, beta);
                    s += &format!("        p{alpha} += {} * d{};\n", t(k), dif(e, e, beta));
                }
            }
        }
        for i in 0..3 {
            for alpha in 0..4 {
                s += "        {\n            var a: real = 0.0;\n";
                for beta in 0..4 {
                    let (k1, k2) = (t_index(dd, i, alpha, beta), t_index(dd, dd, alpha, beta));
                    s += &format!("            a += {} * d{};\n", t(k1), dif(i, dd, beta));
                    s += &format!("            a += {} * d{};\n", t(k2), dif(dd, i, beta));
                }
                s += "            var v = mu * a;\n";
                if i == dd {
                    s += &format!("            v += lam * p{alpha};\n");
                }
                let (hi, lo) = (3 * node(dd, alpha, 1) + i, 3 * node(dd, alpha, 0) + i);
                s += &format!("            z{hi} += v;\n            z{lo} -= v;\n        }}\n");
            }
        }
        s += "    }\n";
    }
    s += "    if (c < prm.n_cut) {\n";
    s += &mass_terms(&|_, k| t(MASS + k));
    s += "        let pc = partial_of[c];\n        if (pc != NO_PARTIAL) {\n";
    s += "            let pb = partial_base + PARTIAL_LEN * pc;\n";
    s += &mass_terms(&|i, k| format!("k_cells[pb + {}u]", 36 * i + k));
    s += "        }\n    }\n";
    s
}

/// The WGSL of [`mass_product`], `m(i, k)` the expression of a mass entry.
fn mass_terms(m: &dyn Fn(usize, usize) -> String) -> String {
    let mut s = String::new();
    for i in 0..3 {
        for a in 0..8 {
            for b in a..8 {
                s += &format!("        {{ let k = {};", m(i, sym(8, a, b)));
                s += &format!(" z{} += k * u{};", 3 * a + i, 3 * b + i);
                if a != b {
                    s += &format!(" z{} += k * u{};", 3 * b + i, 3 * a + i);
                }
                s += " }\n";
            }
        }
    }
    s
}

fn cell_store() -> String {
    (0..24)
        .map(|r| format!("    z[24u * c + {r}u] = z{r};\n"))
        .collect()
}
