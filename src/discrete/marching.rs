//! Marching tetrahedra on the Q1 node lattice: the zero set of a level set ψ
//! as a conforming triangle mesh oriented along ∇ψ.
//!
//! Each cell is split into the 6 tetrahedra of the Freudenthal (Kuhn)
//! triangulation, all sharing the cell's main diagonal from local corner
//! `(0,0,0)` to `(1,1,1)`: for each permutation `(p, q, r)` of the axes, the
//! tetrahedron `0, e_p, e_p + e_q, e_p + e_q + e_r`. The triangulation is
//! translation invariant, so neighbouring cells split their common face along
//! the same diagonal and the mesh is conforming. A node is inside when
//! `ψ < 0` (as [`crate::geometry::Geometry::inside`]). A tetrahedron with one or three inside
//! corners gives one triangle, with two a quadrilateral split in two; there is
//! no ambiguous case (unlike marching cubes).
//!
//! The vertex on a tet edge from an inside corner `a` to an outside corner `b`
//! is the root of `t ↦ ψ(a + t (b − a))` on `[0, 1]`, found by the Illinois
//! variant of regula falsi (bracketing, superlinear) to `|ψ| ≤ 1e-15` or a
//! bracket of a few ulps, so vertices lie on ψ = 0 to round-off and stay on
//! their edge. Vertices are shared through their edge's pair of global node
//! ids (a node with `ψ = 0` exactly is its own vertex), which makes the
//! mesh's vertex list free of duplicates and its edges watertight.

use std::collections::HashMap;

use rayon::prelude::*;

use crate::element::ElementOrder;
use crate::grid::Grid;
use crate::spatial::vec3::{dot, lerp, norm, sub, triangle_normal_scaled};

/// The raw zero-set mesh: vertices (with a cell containing each) and
/// triangles (with the cell whose tetrahedron produced them).
pub(crate) struct RawMesh {
    pub vertices: Vec<[f64; 3]>,
    pub vertex_cell: Vec<usize>,
    pub triangles: Vec<([u32; 3], usize)>,
}

/// The Freudenthal tetrahedra as local corner masks (bit `i` = axis `i`, the
/// Q1 local node numbering).
const TETS: [[usize; 4]; 6] = {
    const PERMS: [[usize; 3]; 6] = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut tets = [[0usize; 4]; 6];
    let mut k = 0;
    while k < 6 {
        let p = PERMS[k];
        tets[k] = [0, 1 << p[0], (1 << p[0]) | (1 << p[1]), 7];
        k += 1;
    }
    tets
};

/// Extracts the zero set of the level set `psi` on `grid`.
pub(crate) fn extract(grid: &Grid, psi: &(impl Fn([f64; 3]) -> f64 + Sync)) -> RawMesh {
    let order = ElementOrder::Q1;
    let values: Vec<f64> = (0..grid.num_nodes(order))
        .into_par_iter()
        .map(|n| psi(grid.node_position(order, n)))
        .collect();
    let mut builder = Builder {
        grid,
        psi,
        values: &values,
        edge_vertex: HashMap::new(),
        mesh: RawMesh {
            vertices: Vec::new(),
            vertex_cell: Vec::new(),
            triangles: Vec::new(),
        },
    };
    let mut nodes = [0usize; 8];
    for c in 0..grid.num_cells() {
        grid.cell_nodes(order, c, &mut nodes);
        let inside = nodes.map(|n| values[n] < 0.0);
        if inside.iter().all(|&i| i) || inside.iter().all(|&i| !i) {
            continue;
        }
        for tet in &TETS {
            builder.tetrahedron(c, tet.map(|l| nodes[l]));
        }
    }
    builder.mesh
}

struct Builder<'a, F> {
    grid: &'a Grid,
    psi: &'a F,
    /// ψ at the Q1 nodes.
    values: &'a [f64],
    edge_vertex: HashMap<(usize, usize), u32>,
    mesh: RawMesh,
}

impl<F: Fn([f64; 3]) -> f64> Builder<'_, F> {
    fn position(&self, node: usize) -> [f64; 3] {
        self.grid.node_position(ElementOrder::Q1, node)
    }

    /// The triangles of one tetrahedron (global node ids).
    fn tetrahedron(&mut self, cell: usize, tet: [usize; 4]) {
        let (ins, outs): (Vec<usize>, Vec<usize>) =
            tet.iter().partition(|&&n| self.values[n] < 0.0);
        if ins.is_empty() || outs.is_empty() {
            return;
        }
        // From the inside corners towards the outside ones: the outward side.
        let mean = |ns: &[usize]| {
            let mut m = [0.0; 3];
            for &n in ns {
                let p = self.position(n);
                (0..3).for_each(|i| m[i] += p[i] / ns.len() as f64);
            }
            m
        };
        let outward = sub(mean(&outs), mean(&ins));
        match (ins.len(), outs.len()) {
            (1, 3) => {
                let v = [outs[0], outs[1], outs[2]].map(|o| self.vertex(cell, ins[0], o));
                self.triangle(cell, v, outward);
            }
            (3, 1) => {
                let v = [ins[0], ins[1], ins[2]].map(|i| self.vertex(cell, i, outs[0]));
                self.triangle(cell, v, outward);
            }
            _ => {
                let q = [
                    self.vertex(cell, ins[0], outs[0]),
                    self.vertex(cell, ins[0], outs[1]),
                    self.vertex(cell, ins[1], outs[1]),
                    self.vertex(cell, ins[1], outs[0]),
                ];
                self.triangle(cell, [q[0], q[1], q[2]], outward);
                self.triangle(cell, [q[0], q[2], q[3]], outward);
            }
        }
    }

    /// Adds a triangle oriented along `outward`, unless it is degenerate.
    fn triangle(&mut self, cell: usize, mut v: [u32; 3], outward: [f64; 3]) {
        if v[0] == v[1] || v[1] == v[2] || v[0] == v[2] {
            return;
        }
        let p = v.map(|i| self.mesh.vertices[i as usize]);
        let n = triangle_normal_scaled(&p);
        if norm(n) <= 1e-14 * self.grid.h * self.grid.h {
            return;
        }
        if dot(n, outward) < 0.0 {
            v.swap(1, 2);
        }
        self.mesh.triangles.push((v, cell));
    }

    /// The vertex on the edge from the inside node `a` to the outside node `b`.
    fn vertex(&mut self, cell: usize, a: usize, b: usize) -> u32 {
        let key = if self.values[b] == 0.0 {
            (b, b)
        } else {
            (a.min(b), a.max(b))
        };
        if let Some(&v) = self.edge_vertex.get(&key) {
            return v;
        }
        let x = if self.values[b] == 0.0 {
            self.position(b)
        } else {
            edge_root(
                self.psi,
                self.position(a),
                self.values[a],
                self.position(b),
                self.values[b],
            )
        };
        let id = self.mesh.vertices.len() as u32;
        self.mesh.vertices.push(x);
        self.mesh.vertex_cell.push(cell);
        self.edge_vertex.insert(key, id);
        id
    }
}

/// The root of `ψ` on the segment from `a` (`ψ(a) = fa < 0`) to `b`
/// (`ψ(b) = fb > 0`): Illinois regula falsi on the segment parameter.
fn edge_root(
    psi: &impl Fn([f64; 3]) -> f64,
    a: [f64; 3],
    fa: f64,
    b: [f64; 3],
    fb: f64,
) -> [f64; 3] {
    let (mut t0, mut f0, mut t1, mut f1) = (0.0f64, fa, 1.0f64, fb);
    let mut best = if -fa < fb { (0.0, -fa) } else { (1.0, fb) };
    let mut last_side = 0i8;
    for _ in 0..200 {
        let mut t = (t0 * f1 - t1 * f0) / (f1 - f0);
        if !(t > t0 && t < t1) {
            t = 0.5 * (t0 + t1);
        }
        let f = psi(lerp(a, b, t));
        if f.abs() < best.1 {
            best = (t, f.abs());
        }
        if f.abs() <= 1e-15 {
            break;
        }
        if f < 0.0 {
            t0 = t;
            f0 = f;
            if last_side == -1 {
                f1 *= 0.5;
            }
            last_side = -1;
        } else {
            t1 = t;
            f1 = f;
            if last_side == 1 {
                f0 *= 0.5;
            }
            last_side = 1;
        }
        if t1 - t0 <= 4.0 * f64::EPSILON {
            break;
        }
    }
    lerp(a, b, best.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn freudenthal_tets_fill_the_cube() {
        // Six tets of volume 1/6 each, all distinct.
        let corner = |m: usize| [0, 1, 2].map(|i| (m >> i & 1) as f64);
        let mut total = 0.0;
        for t in &TETS {
            let p = t.map(corner);
            let e = [sub(p[1], p[0]), sub(p[2], p[0]), sub(p[3], p[0])];
            let vol = dot(e[0], crate::spatial::vec3::cross(e[1], e[2])).abs() / 6.0;
            assert!((vol - 1.0 / 6.0).abs() < 1e-15);
            total += vol;
        }
        assert!((total - 1.0).abs() < 1e-14);
    }

    #[test]
    fn edge_root_lands_on_the_sphere() {
        let g = crate::geometry::Geometry::sphere([0.0; 3], 1.0).unwrap();
        let a = [0.1, 0.2, 0.3];
        let b = [1.4, 0.9, -0.2];
        let x = edge_root(&|x| g.phi(x), a, g.phi(a), b, g.phi(b));
        assert!(g.phi(x).abs() < 1e-15, "{}", g.phi(x));
        assert!((norm(x) - 1.0).abs() < 1e-14);
    }
}
