//! [`Exchange`] over MPI (rsmpi): the counts by `MPI_Alltoall`, the words
//! by `MPI_Alltoallv`.

use std::rc::Rc;

use mpi::Count;
use mpi::datatype::{Partition, PartitionMut};
use mpi::topology::SimpleCommunicator;
use mpi::traits::{Communicator, CommunicatorCollectives};

use crate::exchange::Exchange;

/// The ranks of an MPI communicator (`MPI_COMM_WORLD` for a run); clones
/// share it.
#[derive(Clone)]
pub struct MpiExchange {
    world: Rc<SimpleCommunicator>,
}

impl MpiExchange {
    /// The ranks of `world`.
    pub fn new(world: SimpleCommunicator) -> MpiExchange {
        MpiExchange {
            world: Rc::new(world),
        }
    }

    /// Stops every rank of the run with exit code `code` (`MPI_Abort`),
    /// for a rank that cannot go on while the others wait on it.
    pub fn abort(&self, code: i32) -> ! {
        self.world.abort(code)
    }
}

/// Offsets of consecutive blocks of `counts` words.
fn displacements(counts: &[Count]) -> Vec<Count> {
    counts
        .iter()
        .scan(0, |next, &count| {
            let start = *next;
            *next += count;
            Some(start)
        })
        .collect()
}

impl Exchange for MpiExchange {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    fn size(&self) -> usize {
        self.world.size() as usize
    }

    fn exchange(&self, outgoing: Vec<Vec<u32>>) -> Vec<Vec<u32>> {
        let size = self.size();
        assert_eq!(outgoing.len(), size, "one buffer per rank");
        let send_counts: Vec<Count> = outgoing
            .iter()
            .map(|buffer| Count::try_from(buffer.len()).expect("an MPI message over 2^31 words"))
            .collect();
        let mut receive_counts = vec![0 as Count; size];
        self.world
            .all_to_all_into(&send_counts[..], &mut receive_counts[..]);
        let send_displs = displacements(&send_counts);
        let receive_displs = displacements(&receive_counts);
        let send: Vec<u32> = outgoing.concat();
        let total: usize = receive_counts.iter().map(|&c| c as usize).sum();
        let mut receive = vec![0u32; total];
        {
            let sent = Partition::new(&send[..], &send_counts[..], &send_displs[..]);
            let mut received =
                PartitionMut::new(&mut receive[..], &receive_counts[..], &receive_displs[..]);
            self.world.all_to_all_varcount_into(&sent, &mut received);
        }
        receive_displs
            .iter()
            .zip(&receive_counts)
            .map(|(&start, &count)| receive[start as usize..(start + count) as usize].to_vec())
            .collect()
    }
}

/// Variables that MPI launchers set in the processes they start: Open MPI's
/// mpirun, MPICH's Hydra and PMIx-based launchers (srun, prterun).
const LAUNCHER_VARIABLES: [&str; 3] = ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"];

/// MPI for the length of a run: finalized when dropped.
pub struct MpiRun {
    universe: mpi::environment::Universe,
}

impl MpiRun {
    /// Starts MPI if an MPI launcher started this process; `None` for a
    /// process started otherwise (it runs alone, without MPI).
    pub fn launched() -> Option<MpiRun> {
        let by_launcher = LAUNCHER_VARIABLES
            .iter()
            .any(|name| std::env::var_os(name).is_some());
        if !by_launcher {
            return None;
        }
        mpi::initialize().map(|universe| MpiRun { universe })
    }

    /// All ranks of the run.
    pub fn exchange(&self) -> MpiExchange {
        MpiExchange::new(self.universe.world())
    }
}
