// apply: y = A x for the elasticity operator, node-centred gather (one
// invocation per active node a, no atomics):
//     y[3a + i] = Σ_{cells c ∋ node(a)} Σ_m Σ_j K_c[(3l + i) ne + 3m + j] x[3 act(c, m) + j]
// with l the node's local index in c, act(c, m) the active index of c's m-th
// node, and K_c the shared inside matrix (slot = INSIDE) or the cell's own matrix
// (cut cells, S-penalty folded in). Own matrices may not fit one storage binding:
// the host dispatches once per chunk of slots [own_lo, own_hi); the first pass
// (first = 1) also adds the inside cells and overwrites y, later passes add to it.
// Arrays beyond one binding are bound as windows (src/gpu/windows.rs): y and
// active_to_node from the window's first active node, x from active node
// x_base, node_to_active from lattice node lattice_base, slots from cell
// cell_base; indices are global, less the base.
// CPU mirror: `cgfem_gpu::gpu::mirror::apply` (same name, same binding order).
// Written for `real = f64`; the host swaps the alias line to build the f32 twin.
alias real = f64;

// Keep in sync with `ApplyParams` in src/gpu/kernels.rs.
struct ApplyParams {
    n_active: u32, stride: u32, ncx: u32, ncy: u32,
    ncz: u32, degree: u32, ne: u32, own_lo: u32,
    own_hi: u32, first: u32, x_base: u32, lattice_base: u32,
    cell_base: u32, pad0: u32, pad1: u32, pad2: u32,
}
// Keep in sync with `OUTSIDE`, `INSIDE` in src/fem/operator.rs.
const OUTSIDE: u32 = 0xffffffffu;
const INSIDE: u32 = 0xfffffffeu;

@group(0) @binding(0) var<uniform> prm: ApplyParams;
@group(0) @binding(1) var<storage, read> active_to_node: array<u32>;
@group(0) @binding(2) var<storage, read> node_to_active: array<u32>;
@group(0) @binding(3) var<storage, read> slots: array<u32>;
@group(0) @binding(4) var<storage, read> k_inside: array<real>;
@group(0) @binding(5) var<storage, read> k_own: array<real>;
@group(0) @binding(6) var<storage, read> x: array<real>;
@group(0) @binding(7) var<storage, read_write> y: array<real>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
    let a = g.x + g.y * prm.stride;
    if (a >= prm.n_active) { return; }
    let p = prm.degree;
    let np = p + 1u;
    let nc = array<u32, 3>(prm.ncx, prm.ncy, prm.ncz);
    let m0 = p * prm.ncx + 1u;
    let m1 = p * prm.ncy + 1u;
    let node = active_to_node[a];
    let ijk = array<u32, 3>(node % m0, (node / m0) % m1, node / (m0 * m1));
    // Per axis: up to two (cell index, local coordinate) choices.
    var cell_of: array<array<u32, 2>, 3>;
    var local_of: array<array<u32, 2>, 3>;
    var count: array<u32, 3>;
    for (var ax = 0u; ax < 3u; ax++) {
        let q = ijk[ax] / p;
        let r = ijk[ax] % p;
        var k = 0u;
        if (r == 0u) {
            if (q > 0u) { cell_of[ax][k] = q - 1u; local_of[ax][k] = p; k++; }
            if (q < nc[ax]) { cell_of[ax][k] = q; local_of[ax][k] = 0u; k++; }
        } else {
            cell_of[ax][0] = q; local_of[ax][0] = r; k = 1u;
        }
        count[ax] = k;
    }
    var acc = array<real, 3>(0.0, 0.0, 0.0);
    if (prm.first == 0u) {
        for (var i = 0u; i < 3u; i++) { acc[i] = y[3u * a + i]; }
    }
    let ne = prm.ne;
    for (var cz = 0u; cz < count[2]; cz++) {
        for (var cy = 0u; cy < count[1]; cy++) {
            for (var cx = 0u; cx < count[0]; cx++) {
                let ci = cell_of[0][cx];
                let cj = cell_of[1][cy];
                let ck = cell_of[2][cz];
                let cell = ci + prm.ncx * (cj + prm.ncy * ck);
                let l = local_of[0][cx] + np * (local_of[1][cy] + np * local_of[2][cz]);
                let s = slots[cell - prm.cell_base];
                var inside = false;
                var base = 0u;
                if (s == OUTSIDE) {
                    continue;
                } else if (s == INSIDE) {
                    if (prm.first == 0u) { continue; }
                    inside = true;
                } else {
                    if (s < prm.own_lo || s >= prm.own_hi) { continue; }
                    base = (s - prm.own_lo) * ne * ne;
                }
                var m = 0u;
                for (var c = 0u; c < np; c++) {
                    for (var b = 0u; b < np; b++) {
                        for (var aa = 0u; aa < np; aa++) {
                            let nn = (p * ci + aa) + m0 * ((p * cj + b) + m1 * (p * ck + c));
                            let act = node_to_active[nn - prm.lattice_base] - prm.x_base;
                            for (var j = 0u; j < 3u; j++) {
                                let xj = x[3u * act + j];
                                let col = base + 3u * l * ne + 3u * m + j;
                                if (inside) {
                                    acc[0] += k_inside[col] * xj;
                                    acc[1] += k_inside[col + ne] * xj;
                                    acc[2] += k_inside[col + 2u * ne] * xj;
                                } else {
                                    acc[0] += k_own[col] * xj;
                                    acc[1] += k_own[col + ne] * xj;
                                    acc[2] += k_own[col + 2u * ne] * xj;
                                }
                            }
                            m++;
                        }
                    }
                }
            }
        }
    }
    for (var i = 0u; i < 3u; i++) { y[3u * a + i] = acc[i]; }
}
