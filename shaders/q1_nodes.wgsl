// q1_nodes: y = A x at every active node of a Q1 operator, from the interior
// stencil and the cell products of `q1_cells` (src/fem/fast_apply.rs, the
// CPU's plan, is the same split). Workgroup g (2D: g = wid.x + wid.y stride):
// - g < n_segments: segment g, up to SEG consecutive interior nodes of one
//   run; node t of the segment sums the structurally nonzero stencil terms,
//   unrolled (generated at the marker), reading its 27 neighbours from the
//   segment's 9 neighbour rows (contiguous runs of x, so a warp's reads
//   coalesce and the rows' re-reads by neighbouring segments hit the caches):
//       y[3(start + t) + i] = Σ S[3(27 j + 3 r + shift) + i] x[3(bases[r] + t + shift) + j]
// - else: boundary nodes (g − n_segments) SEG + t, each the sum of its 8
//   cells' triples in z (a missing cell links to a zero triple).
// Each invocation writes only its own node: no atomics.
// The dot variant (`Kernel::Q1NodesDot`, DOT = true) also sums x · y over
// the workgroup's nodes into partials[g] (each thread its node's three
// products, then thread 0 over the threads in order: one barrier), for CG's
// p · Ap (`cg_update` reduces the partials; src/gpu/device_krylov.rs). The
// plain kernel has no barrier (a barrier costs llvmpipe dearly).
// CPU mirror: `cgfem_gpu::gpu::mirror::q1_nodes` (same name, same binding order).
// Written for `real = f64`; the host swaps the alias line to build the f32 twin.
alias real = f64;

// Keep in sync with `Q1Params` in src/gpu/kernels.rs.
struct Q1Params {
    n_segments: u32, n_boundary: u32, n_cut: u32, n_cells: u32,
    stride: u32, pad0: u32, pad1: u32, pad2: u32,
}
// Keep in sync with `SEG`, `SEGMENT_WORDS` in src/gpu/q1_terms.rs.
const SEG: u32 = 64u;
const SEGMENT_WORDS: u32 = 12u;
// The dot variant swaps this line (src/gpu/kernels.rs, `DOT_LINE`).
const DOT: bool = false;

@group(0) @binding(0) var<uniform> prm: Q1Params;
@group(0) @binding(1) var<uniform> stencil: array<vec4<real>, 61>;
@group(0) @binding(2) var<storage, read> segments: array<u32>;
@group(0) @binding(3) var<storage, read> boundary: array<u32>;
@group(0) @binding(4) var<storage, read> links: array<u32>;
@group(0) @binding(5) var<storage, read> z: array<real>;
@group(0) @binding(6) var<storage, read> x: array<real>;
@group(0) @binding(7) var<storage, read_write> y: array<real>;
@group(0) @binding(8) var<storage, read_write> partials: array<real>;

var<workgroup> sh: array<real, 64>;

fn st(k: u32) -> real {
    return stencil[k / 4u][k % 4u];
}

// Both node functions return x · y at their node (0 for no node).
fn interior(g: u32, t: u32) -> real {
    let s = SEGMENT_WORDS * g;
    let start = segments[s];
    let len = segments[s + 1u];
    if (t >= len) { return 0.0; }
    // @bases
    var y0: real = 0.0;
    var y1: real = 0.0;
    var y2: real = 0.0;
    // @stencil
    let a = start + t;
    y[3u * a] = y0;
    y[3u * a + 1u] = y1;
    y[3u * a + 2u] = y2;
    return x[3u * a] * y0 + x[3u * a + 1u] * y1 + x[3u * a + 2u] * y2;
}

fn boundary_node(b: u32) -> real {
    if (b >= prm.n_boundary) { return 0.0; }
    var acc = array<real, 3>(0.0, 0.0, 0.0);
    for (var cc = 0u; cc < 8u; cc++) {
        let o = links[8u * b + cc];
        for (var i = 0u; i < 3u; i++) { acc[i] += z[o + i]; }
    }
    let a = boundary[b];
    var c: real = 0.0;
    for (var i = 0u; i < 3u; i++) {
        y[3u * a + i] = acc[i];
        c += x[3u * a + i] * acc[i];
    }
    return c;
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) t: u32) {
    let g = wid.x + wid.y * prm.stride;
    var c: real = 0.0;
    if (g < prm.n_segments) {
        c = interior(g, t);
    } else {
        c = boundary_node((g - prm.n_segments) * SEG + t);
    }
    if (DOT) {
        sh[t] = c;
        workgroupBarrier();
        let groups = prm.n_segments + (prm.n_boundary + SEG - 1u) / SEG;
        if (t == 0u && g < groups) {
            var s: real = 0.0;
            for (var k = 0u; k < SEG; k++) { s += sh[k]; }
            partials[g] = s;
        }
    }
}
