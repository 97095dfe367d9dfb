//! Which of a rank's unknowns it owns, and the exchange that brings the
//! others (its ghosts) from their owners. A node belongs to the brick that
//! holds its cell: the cell whose lowest corner it is, or the last cell
//! along an axis for the nodes on the grid's upper faces. A rank holds the
//! nodes of its window (its brick grown by ghost layers); the ones it does
//! not own are ghosts, and each is asked once, at set-up, of its owner.

use super::partition::owner;
use crate::backend::Backend;
use crate::comm::Comm;
use crate::discrete::dofs::DofMap;
use crate::element::ElementOrder;
use crate::grid::{CellBox, Grid};

/// A rank's owned and ghost nodes, and what it sends and receives to bring
/// its ghosts up to date: all of them (before a recovery), or only the
/// *near* ones, the nodes of the cells around its owned nodes (before an
/// apply, whose owned rows need no other).
#[derive(Clone, Debug)]
pub struct Halo {
    /// Whether each local active node is owned here.
    owned: Vec<bool>,
    /// The ghosts, ascending.
    ghosts: Vec<u32>,
    /// Per neighbour: its rank and the owned nodes it asked for, in its
    /// order (its near ghosts first), and how many of them are near.
    sends: Vec<Exchange>,
    /// Per neighbour: its rank and the ghosts it owns, in the order asked
    /// (near first), and how many are near.
    recvs: Vec<Exchange>,
    /// The entries (three per node) of `sends` and `recvs`, neighbour after
    /// neighbour, for each reach ([`Reach::Near`], [`Reach::Window`]).
    sent: [Vec<usize>; 2],
    received: [Vec<usize>; 2],
    /// The entries of the ghosts.
    ghost_entries: Vec<usize>,
}

/// One neighbour's share of a ghost exchange.
#[derive(Clone, Debug)]
struct Exchange {
    rank: usize,
    nodes: Vec<u32>,
    near: usize,
}

/// Which ghosts an exchange brings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reach {
    /// The nodes of the cells around the owned nodes (an apply's).
    Near,
    /// Every ghost of the window (a recovery's).
    Window,
}

/// The cell (index) that decides the owner of lattice node `node` of
/// elements of `order`: the cell whose lowest corner it is, or the last
/// along an axis.
pub fn owner_cell(grid: &Grid, order: ElementOrder, node: usize) -> usize {
    let (p, l) = (order.degree(), lattice_ijk(grid, order, node));
    grid.cell_index([0, 1, 2].map(|a| (l[a] / p).min(grid.n[a] - 1)))
}

/// The lattice coordinates of node `node` of elements of `order`.
fn lattice_ijk(grid: &Grid, order: ElementOrder, node: usize) -> [usize; 3] {
    let per_axis = grid.nodes_per_axis(order);
    [
        node % per_axis[0],
        (node / per_axis[0]) % per_axis[1],
        node / (per_axis[0] * per_axis[1]),
    ]
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
        // Per owner: (far, local node), near ones first once sorted.
        let mut asks: Vec<Vec<(bool, u32)>> = vec![Vec::new(); comm.size()];
        let mut ghosts = Vec::new();
        // The cells around the owned nodes: one more layer below the brick
        // (the nodes on its upper faces belong to the next brick up).
        let brick = bricks[me];
        let near_box = CellBox {
            lo: brick.lo.map(|v| v.saturating_sub(1)),
            hi: brick.hi,
        };
        for (a, &node) in dofs.active_to_node.iter().enumerate() {
            let cell = owner_cell(grid, dofs.order, node as usize);
            let r = owner(bricks, grid.cell_ijk(cell));
            if r == me {
                owned[a] = true;
            } else {
                let far = !near_node(grid, dofs.order, node as usize, &near_box);
                asks[r].push((far, a as u32));
                ghosts.push(a as u32);
            }
        }
        for list in &mut asks {
            list.sort_unstable();
        }
        // The cells owning the nodes of a window lie in it grown by one.
        let reach = |r: usize| bricks[r].grown(ghost + 1, grid.n);
        let neighbours: Vec<usize> = (0..comm.size())
            .filter(|&q| q != me && (reach(me).meets(&bricks[q]) || reach(q).meets(&bricks[me])))
            .collect();
        // How many each neighbour asks, then what: the near count, then the
        // lattice nodes.
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
                let near = asks[q].iter().filter(|(far, _)| !far).count() as f64;
                let ids = asks[q]
                    .iter()
                    .map(|&(_, a)| dofs.active_to_node[a as usize] as f64);
                (q, std::iter::once(near).chain(ids).collect())
            })
            .collect();
        let incoming: Vec<(usize, usize)> = neighbours
            .iter()
            .zip(&wanted)
            .filter(|(_, w)| w[0] > 0.0)
            .map(|(&q, w)| (q, 1 + w[0] as usize))
            .collect();
        let asked = comm.exchange(&lists, &incoming);
        let sends: Vec<Exchange> = incoming
            .iter()
            .zip(asked)
            .map(|(&(q, _), list)| {
                let local = list[1..].iter().map(|&id| {
                    let a = dofs.node_to_active[id as usize];
                    assert!(
                        a != u32::MAX && owned[a as usize],
                        "rank {q} asks rank {me} for node {id}, which it does not own"
                    );
                    a
                });
                Exchange {
                    rank: q,
                    nodes: local.collect(),
                    near: list[0] as usize,
                }
            })
            .collect();
        let recvs: Vec<Exchange> = neighbours
            .iter()
            .filter(|&&q| !asks[q].is_empty())
            .map(|&q| Exchange {
                rank: q,
                near: asks[q].iter().filter(|(far, _)| !far).count(),
                nodes: asks[q].iter().map(|&(_, a)| a).collect(),
            })
            .collect();
        let reaches = [Reach::Near, Reach::Window];
        Halo {
            sent: reaches.map(|r| entries_of(&sends, r)),
            received: reaches.map(|r| entries_of(&recvs, r)),
            ghost_entries: entries(&ghosts),
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

    /// The ghost values that `reach` takes, from their owners, with the
    /// local entries they go to; `read` gives this rank's entries at the
    /// indices it is asked for. Collective.
    fn exchange(
        &self,
        comm: &dyn Comm,
        reach: Reach,
        read: impl FnOnce(&[usize]) -> Vec<f64>,
    ) -> (&[usize], Vec<f64>) {
        let values = read(&self.sent[reach as usize]);
        let mut at = 0;
        let sends: Vec<(usize, Vec<f64>)> = self
            .sends
            .iter()
            .map(|e| {
                let n = 3 * e.take(reach);
                at += n;
                (e.rank, values[at - n..at].to_vec())
            })
            .collect();
        let recvs: Vec<(usize, usize)> = self
            .recvs
            .iter()
            .map(|e| (e.rank, 3 * e.take(reach)))
            .collect();
        let got = comm.exchange(&sends, &recvs);
        (&self.received[reach as usize], got.concat())
    }

    /// Brings the ghost entries of `x` (three per node) that `reach` takes
    /// from their owners. Collective.
    pub fn fill_ghosts(&self, comm: &dyn Comm, x: &mut [f64], reach: Reach) {
        let (ghosts, values) = self.exchange(comm, reach, |i| i.iter().map(|&k| x[k]).collect());
        for (&k, v) in ghosts.iter().zip(values) {
            x[k] = v;
        }
    }

    /// [`Halo::fill_ghosts`] on a vector of `be`. Collective.
    pub fn fill_ghosts_on<B: Backend>(
        &self,
        comm: &dyn Comm,
        be: &B,
        x: &mut B::Vector,
        reach: Reach,
    ) {
        let (ghosts, values) = self.exchange(comm, reach, |i| be.read_entries(x, i));
        be.write_entries(&values, ghosts, x);
    }

    /// Sets the ghost entries of `x` (three per node) to zero.
    pub fn zero_ghosts(&self, x: &mut [f64]) {
        for &a in &self.ghosts {
            let d = 3 * a as usize;
            x[d..d + 3].fill(0.0);
        }
    }

    /// [`Halo::zero_ghosts`] on a vector of `be`.
    pub fn zero_ghosts_on<B: Backend>(&self, be: &B, x: &mut B::Vector) {
        let zeros = vec![0.0; self.ghost_entries.len()];
        be.write_entries(&zeros, &self.ghost_entries, x);
    }

    /// Bytes one [`Halo::fill_ghosts`] of `reach` receives (f64 values).
    pub fn bytes_per_fill(&self, reach: Reach) -> usize {
        8 * self.received[reach as usize].len()
    }
}

/// Whether lattice node `node` is a node of one of the cells of `b`
/// (closed: on its faces too).
fn near_node(grid: &Grid, order: ElementOrder, node: usize, b: &CellBox) -> bool {
    let (p, l) = (order.degree(), lattice_ijk(grid, order, node));
    (0..3).all(|a| p * b.lo[a] <= l[a] && l[a] <= p * b.hi[a])
}

impl Exchange {
    /// How many of its nodes `reach` takes.
    fn take(&self, reach: Reach) -> usize {
        match reach {
            Reach::Near => self.near,
            Reach::Window => self.nodes.len(),
        }
    }
}

/// The entries (three per node) of `nodes`.
fn entries(nodes: &[u32]) -> Vec<usize> {
    nodes
        .iter()
        .flat_map(|&a| (0..3).map(move |c| 3 * a as usize + c))
        .collect()
}

/// The entries of the nodes `reach` takes of every exchange of `list`, one
/// after the other.
fn entries_of(list: &[Exchange], reach: Reach) -> Vec<usize> {
    list.iter()
        .flat_map(|e| entries(&e.nodes[..e.take(reach)]))
        .collect()
}
