// q1_cells: the cell products z_c = K_c x_c (24 entries each) that the
// boundary nodes of `q1_nodes` gather, from the factored Q1 forms of
// src/fem/q1_forms.rs (114 numbers a cell: the 4 × 4 blocks T^{de} and the
// scalar mass M). k_cells holds, in order:
// - the cut cells' forms (cells 0 .. n_cut, slot order), stored entry-major,
//   entry k of cell c at k n_cut + c, so that a warp's reads of one entry are
//   contiguous;
// - the whole cell's form (entry k at 114 n_cut + k), which the rim cells
//   (cells n_cut .. n_cells: inside cells with a boundary node) share; it has
//   no mass;
// - λ and μ;
// - the partial-mask penalties (rollers, symmetry planes): 108 numbers per
//   cut cell that has one (three packed symmetric 8 × 8 masses, one per
//   component), the p-th at partial_base + 108 p, p = partial_of[c].
// One invocation per cell; the product is unrolled (generated at the marker):
// the differences of x along each axis, then per direction d the terms of
// E_{d,i}, then the masses.
// z holds a zero triple after the last cell, which no kernel writes.
// CPU mirror: `cgfem_gpu::gpu::mirror::q1_cells` (same name, same binding order).
// Written for `real = f64`; the host swaps the alias line to build the f32 twin.
alias real = f64;

// Keep in sync with `Q1Params` in src/gpu/kernels.rs.
struct Q1Params {
    n_segments: u32, n_boundary: u32, n_cut: u32, n_cells: u32,
    stride: u32, pad0: u32, pad1: u32, pad2: u32,
}
// Keep in sync with `FORM_LEN` in src/fem/q1_forms.rs, `PARTIAL_LEN` and
// `NO_PARTIAL` in src/gpu/q1_terms.rs.
const FORM_LEN: u32 = 114u;
const PARTIAL_LEN: u32 = 108u;
const NO_PARTIAL: u32 = 0xffffffffu;

@group(0) @binding(0) var<uniform> prm: Q1Params;
@group(0) @binding(1) var<storage, read> cell_nodes: array<u32>;
@group(0) @binding(2) var<storage, read> partial_of: array<u32>;
@group(0) @binding(3) var<storage, read> k_cells: array<real>;
@group(0) @binding(4) var<storage, read> x: array<real>;
@group(0) @binding(5) var<storage, read_write> z: array<real>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = gid.x + gid.y * prm.stride;
    if (c >= prm.n_cells) { return; }
    // Entry k of this cell's form at k_cells[base + k step].
    let shared_form = FORM_LEN * prm.n_cut;
    var base = shared_form;
    var step = 1u;
    if (c < prm.n_cut) {
        base = c;
        step = prm.n_cut;
    }
    let lam = k_cells[shared_form + FORM_LEN];
    let mu = k_cells[shared_form + FORM_LEN + 1u];
    let partial_base = shared_form + FORM_LEN + 2u;
    // @gather
    // @product
    // @store
}
