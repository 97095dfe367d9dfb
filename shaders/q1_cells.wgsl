// q1_cells: the cell products z_c = K_c x_c (24 entries each) that the
// boundary nodes of `q1_nodes` gather: cells 0 .. n_cut are the cut cells in
// slot order, their matrices packed (upper triangle, row-major, 300 entries)
// and stored entry-major, entry e of cell c at e n_cut + c, so that a warp's
// reads of one entry are contiguous; cells n_cut .. n_cells are the rim cells
// (inside cells with a boundary node), all with the packed inside matrix
// stored after them (entry e at 300 n_cut + e).
// One invocation per cell; the symmetric product is unrolled (generated at the
// marker):  z_r += K[r][m] u_m, m = 0 .. 23 in order, for every r.
// z holds a zero triple after the last cell, which no kernel writes.
// CPU mirror: `cgfem_gpu::gpu::mirror::q1_cells` (same name, same binding order).
// Written for `real = f64`; the host swaps the alias line to build the f32 twin.
alias real = f64;

// Keep in sync with `Q1Params` in src/gpu/kernels.rs.
struct Q1Params {
    n_segments: u32, n_boundary: u32, n_cut: u32, n_cells: u32,
    stride: u32, pad0: u32, pad1: u32, pad2: u32,
}

@group(0) @binding(0) var<uniform> prm: Q1Params;
@group(0) @binding(1) var<storage, read> cell_nodes: array<u32>;
@group(0) @binding(2) var<storage, read> k_cells: array<real>;
@group(0) @binding(3) var<storage, read> x: array<real>;
@group(0) @binding(4) var<storage, read_write> z: array<real>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = gid.x + gid.y * prm.stride;
    if (c >= prm.n_cells) { return; }
    // Entry e of this cell's matrix at k_cells[base + e step].
    var base = 300u * prm.n_cut;
    var step = 1u;
    if (c < prm.n_cut) {
        base = c;
        step = prm.n_cut;
    }
    // @gather
    // @product
    // @store
}
