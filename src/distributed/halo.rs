//! Which of a rank's unknowns it owns, and the exchange that brings the
//! others (its ghosts) from their owners. A node belongs to the brick that
//! holds its cell: the cell whose lowest corner it is, or the last cell
//! along an axis for the nodes on the grid's upper faces. A rank holds the
//! nodes of its window (its brick grown by ghost layers); the ones it does
//! not own are ghosts, and each is asked once, at set-up, of its owner.

use super::partition::owner;
use crate::comm::Comm;
use crate::discrete::dofs::DofMap;
use crate::element::ElementOrder;
use crate::grid::{CellBox, Grid};

/// A rank's owned and ghost nodes, and what it sends and receives to bring
/// its ghosts up to date.
#[derive(Clone, Debug)]
pub struct Halo {
    /// Whether each local active node is owned here.
    owned: Vec<bool>,
    /// The ghosts, ascending.
    ghosts: Vec<u32>,
    /// Per neighbour: its rank and the owned nodes it asked for, in its order.
    sends: Vec<(usize, Vec<u32>)>,
    /// Per neighbour: its rank and the ghosts it owns, in the order asked.
    recvs: Vec<(usize, Vec<u32>)>,
}

/// The cell (index) that decides the owner of lattice node `node` of
/// elements of `order`: the cell whose lowest corner it is, or the last
/// along an axis.
pub fn owner_cell(grid: &Grid, order: ElementOrder, node: usize) -> usize {
    let p = order.degree();
    let per_axis = grid.nodes_per_axis(order);
    let l = [
        node % per_axis[0],
        (node / per_axis[0]) % per_axis[1],
        node / (per_axis[0] * per_axis[1]),
    ];
    grid.cell_index([0, 1, 2].map(|a| (l[a] / p).min(grid.n[a] - 1)))
}

impl Halo {
    /// The halo of this rank's `dofs` (over its window of `grid`) among
    /// `bricks`, windows grown by `ghost` layers. Collective.
    ///
    /// # Panics
    /// When a neighbour asks for a node this rank does not hold or own (the
    /// windows are too narrow for the set-up's couplings).
    pub fn new(
        comm: &dyn Comm,
        grid: &Grid,
        dofs: &DofMap,
        bricks: &[CellBox],
        ghost: usize,
    ) -> Halo {
        let me = comm.rank();
        let nodes = dofs.num_active();
        let mut owned = vec![false; nodes];
        let mut asks: Vec<Vec<u32>> = vec![Vec::new(); comm.size()];
        let mut ghosts = Vec::new();
        for (a, &node) in dofs.active_to_node.iter().enumerate() {
            let cell = owner_cell(grid, dofs.order, node as usize);
            let r = owner(bricks, grid.cell_ijk(cell));
            if r == me {
                owned[a] = true;
            } else {
                asks[r].push(a as u32);
                ghosts.push(a as u32);
            }
        }
        // The cells owning the nodes of a window lie in it grown by one.
        let reach = |r: usize| bricks[r].grown(ghost + 1, grid.n);
        let neighbours: Vec<usize> = (0..comm.size())
            .filter(|&q| q != me && (reach(me).meets(&bricks[q]) || reach(q).meets(&bricks[me])))
            .collect();
        // How many each neighbour asks, then what.
        let counts: Vec<(usize, Vec<f64>)> = neighbours
            .iter()
            .map(|&q| (q, vec![asks[q].len() as f64]))
            .collect();
        let ones: Vec<(usize, usize)> = neighbours.iter().map(|&q| (q, 1)).collect();
        let wanted = comm.exchange(&counts, &ones);
        let lists: Vec<(usize, Vec<f64>)> = neighbours
            .iter()
            .filter(|&&q| !asks[q].is_empty())
            .map(|&q| {
                let ids = asks[q]
                    .iter()
                    .map(|&a| dofs.active_to_node[a as usize] as f64);
                (q, ids.collect())
            })
            .collect();
        let incoming: Vec<(usize, usize)> = neighbours
            .iter()
            .zip(&wanted)
            .filter(|(_, w)| w[0] > 0.0)
            .map(|(&q, w)| (q, w[0] as usize))
            .collect();
        let asked = comm.exchange(&lists, &incoming);
        let sends = incoming
            .iter()
            .zip(asked)
            .map(|(&(q, _), ids)| {
                let local = ids.iter().map(|&id| {
                    let a = dofs.node_to_active[id as usize];
                    assert!(
                        a != u32::MAX && owned[a as usize],
                        "rank {q} asks rank {me} for node {id}, which it does not own"
                    );
                    a
                });
                (q, local.collect())
            })
            .collect();
        let recvs = neighbours
            .iter()
            .map(|&q| (q, std::mem::take(&mut asks[q])))
            .filter(|(_, nodes)| !nodes.is_empty())
            .collect();
        Halo {
            owned,
            ghosts,
            sends,
            recvs,
        }
    }

    /// Whether local active node `a` is owned here.
    pub fn owns(&self, a: usize) -> bool {
        self.owned[a]
    }

    /// Number of owned nodes.
    pub fn num_owned(&self) -> usize {
        self.owned.iter().filter(|&&o| o).count()
    }

    /// Brings the ghost entries of `x` (three per node) from their owners.
    /// Collective.
    pub fn fill_ghosts(&self, comm: &dyn Comm, x: &mut [f64]) {
        let sends: Vec<(usize, Vec<f64>)> = self
            .sends
            .iter()
            .map(|(q, nodes)| {
                let values = nodes.iter().flat_map(|&a| {
                    let d = 3 * a as usize;
                    [x[d], x[d + 1], x[d + 2]]
                });
                (*q, values.collect())
            })
            .collect();
        let recvs: Vec<(usize, usize)> =
            self.recvs.iter().map(|(q, n)| (*q, 3 * n.len())).collect();
        let got = comm.exchange(&sends, &recvs);
        for ((_, nodes), values) in self.recvs.iter().zip(got) {
            for (&a, v) in nodes.iter().zip(values.chunks_exact(3)) {
                let d = 3 * a as usize;
                x[d..d + 3].copy_from_slice(v);
            }
        }
    }

    /// Sets the ghost entries of `x` (three per node) to zero.
    pub fn zero_ghosts(&self, x: &mut [f64]) {
        for &a in &self.ghosts {
            let d = 3 * a as usize;
            x[d..d + 3].fill(0.0);
        }
    }

    /// Bytes received by one [`Halo::fill_ghosts`] (f64 values).
    pub fn bytes_per_fill(&self) -> usize {
        self.recvs.iter().map(|(_, n)| 24 * n.len()).sum()
    }
}
