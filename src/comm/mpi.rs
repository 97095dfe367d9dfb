//! The MPI transport (feature `mpi`), through the `mpi` crate: one process
//! per rank, `MPI_COMM_WORLD`.

use mpi::collective::SystemOperation;
use mpi::datatype::PartitionMut;
use mpi::environment::Universe;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use mpi::Count;

use super::Comm;
use crate::exact::{ExactSum, INTEGERS};

/// `MPI_COMM_WORLD`; MPI is finalised when it is dropped.
pub struct Mpi {
    world: SimpleCommunicator,
    _universe: Universe,
}

/// The environment variables by which the common launchers tell a process
/// that it is one rank of several: Open MPI's `mpirun`, MPICH's and Intel
/// MPI's Hydra (PMI), PMIx launchers (Slurm's `srun --mpi=pmix`, Open MPI
/// 5), MVAPICH.
const LAUNCHER_VARIABLES: [&str; 5] = [
    "OMPI_COMM_WORLD_SIZE",
    "PMI_SIZE",
    "PMI_RANK",
    "PMIX_RANK",
    "MV2_COMM_WORLD_SIZE",
];

/// Whether a launcher started this process, or `CGFEM_MPI=1` asks for MPI
/// under a launcher that sets none of [`LAUNCHER_VARIABLES`]. Without
/// either the run is the one-rank run and MPI is never touched (a singleton
/// `MPI_Init` starts the MPI runtime for nothing).
pub fn launched() -> bool {
    std::env::var_os("CGFEM_MPI").is_some_and(|v| v == "1")
        || LAUNCHER_VARIABLES
            .iter()
            .any(|v| std::env::var_os(v).is_some())
}

impl Mpi {
    /// Initialises MPI when a launcher started this process ([`launched`]);
    /// `None` without one, or when MPI was initialised already.
    pub fn init() -> Option<Mpi> {
        if !launched() {
            return None;
        }
        let universe = mpi::initialize()?;
        Some(Mpi {
            world: universe.world(),
            _universe: universe,
        })
    }
}

impl Comm for Mpi {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    fn size(&self) -> usize {
        self.world.size() as usize
    }

    fn all_gather(&self, values: &[f64]) -> Vec<Vec<f64>> {
        let size = self.size();
        let mut counts = vec![0 as Count; size];
        self.world
            .all_gather_into(&(values.len() as Count), &mut counts[..]);
        let displs: Vec<Count> = counts
            .iter()
            .scan(0, |acc, &c| {
                let start = *acc;
                *acc += c;
                Some(start)
            })
            .collect();
        let total = counts.iter().sum::<Count>() as usize;
        let mut buf = vec![0.0; total];
        {
            let mut partition = PartitionMut::new(&mut buf[..], &counts[..], &displs[..]);
            self.world.all_gather_varcount_into(values, &mut partition);
        }
        (0..size)
            .map(|r| {
                let start = displs[r] as usize;
                buf[start..start + counts[r] as usize].to_vec()
            })
            .collect()
    }

    /// One all-reduce of the sums' integers ([`ExactSum::to_integers`]):
    /// integer addition is exact in any order, so the reduction tree gives
    /// every rank the same total, in `log P` steps of `8 · INTEGERS` bytes
    /// a sum.
    fn sum_exact(&self, sums: &mut [ExactSum]) {
        let mine: Vec<i64> = sums.iter().flat_map(ExactSum::to_integers).collect();
        let mut total = vec![0_i64; mine.len()];
        self.world
            .all_reduce_into(&mine[..], &mut total[..], SystemOperation::sum());
        for (s, ints) in sums.iter_mut().zip(total.chunks_exact(INTEGERS)) {
            *s = ExactSum::from_integers(ints);
        }
    }

    fn exchange(&self, sends: &[(usize, Vec<f64>)], recvs: &[(usize, usize)]) -> Vec<Vec<f64>> {
        let mut out: Vec<Vec<f64>> = recvs.iter().map(|&(_, len)| vec![0.0; len]).collect();
        mpi::request::multiple_scope(sends.len() + recvs.len(), |scope, requests| {
            for (buf, &(r, _)) in out.iter_mut().zip(recvs) {
                let from = self.world.process_at_rank(r as i32);
                requests.add(from.immediate_receive_into(scope, &mut buf[..]));
            }
            for (r, data) in sends {
                let to = self.world.process_at_rank(*r as i32);
                requests.add(to.immediate_send(scope, &data[..]));
            }
            let mut done = Vec::new();
            requests.wait_all(&mut done);
        });
        out
    }
}
