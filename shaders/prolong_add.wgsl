// prolong_add: xf = xf + P xc, trilinear prolongation from the coarse nodal
// lattice (cx, cy, cz nodes per axis) to the nested fine one (fx, fy, fz):
// fine node I reads coarse nodes I/2 (I even: weight 1; odd: I/2 and I/2 + 1
// at 1/2 each, per axis), the inactive ones skipped.
// CPU mirror: `cgfem_gpu::gpu::mirror::prolong_add` (same name, same binding order);
// the host's `crate::multigrid::transfer` in the same order of terms.
// One invocation per fine active node (three components), 2D dispatch:
// a = gid.x + gid.y * stride. A gather: no atomics.
alias real = f64;

// Keep in sync with `GatherParams` in src/gpu/kernels.rs.
struct GatherParams { n: u32, stride: u32, fx: u32, fy: u32, fz: u32, cx: u32, cy: u32, cz: u32 }
@group(0) @binding(0) var<uniform> prm: GatherParams;
@group(0) @binding(1) var<storage, read> xc: array<real>;
@group(0) @binding(2) var<storage, read_write> xf: array<real>;
@group(0) @binding(3) var<storage, read> fine_active_to_node: array<u32>;
@group(0) @binding(4) var<storage, read> coarse_node_to_active: array<u32>;

const INACTIVE: u32 = 0xffffffffu;

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
    let a = g.x + g.y * prm.stride;
    if (a >= prm.n) { return; }
    let node = fine_active_to_node[a];
    let i = node % prm.fx;
    let j = (node / prm.fx) % prm.fy;
    let k = node / (prm.fx * prm.fy);
    let ni = 1u + (i & 1u);
    let nj = 1u + (j & 1u);
    let nk = 1u + (k & 1u);
    var y0 = xf[3u * a];
    var y1 = xf[3u * a + 1u];
    var y2 = xf[3u * a + 2u];
    for (var ck = 0u; ck < nk; ck = ck + 1u) {
        let vk = select(1.0, 0.5, nk == 2u);
        for (var cj = 0u; cj < nj; cj = cj + 1u) {
            let vj = select(1.0, 0.5, nj == 2u);
            for (var ci = 0u; ci < ni; ci = ci + 1u) {
                let vi = select(1.0, 0.5, ni == 2u);
                let c = coarse_node_to_active[(i / 2u + ci)
                    + prm.cx * ((j / 2u + cj) + prm.cy * (k / 2u + ck))];
                if (c == INACTIVE) { continue; }
                let w = real(vi * vj * vk);
                y0 = y0 + w * xc[3u * c];
                y1 = y1 + w * xc[3u * c + 1u];
                y2 = y2 + w * xc[3u * c + 2u];
            }
        }
    }
    xf[3u * a] = y0;
    xf[3u * a + 1u] = y1;
    xf[3u * a + 2u] = y2;
}
