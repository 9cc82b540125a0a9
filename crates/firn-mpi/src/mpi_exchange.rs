//! [`Exchange`] over MPI (rsmpi): the particles between neighbours by
//! `MPI_Isend` and a probed `MPI_Recv` to and from each neighbour only,
//! other particle messages by `MPI_Alltoallv` (their counts by
//! `MPI_Alltoall`), gathers on rank 0 by a probed `MPI_Recv` from each rank
//! in turn (straight into the buffer handed back); the reductions by `MPI_Allreduce`, the renumbering's
//! offsets by `MPI_Exscan`, rank 0's commands and a failing rank's message
//! by `MPI_Bcast`: a substep without far migrants costs each rank messages
//! to its neighbours and O(log ranks) rounds of reductions.

use std::rc::Rc;

use mpi::Count;
use mpi::collective::SystemOperation;
use mpi::datatype::{Partition, PartitionMut};
use mpi::topology::SimpleCommunicator;
use mpi::traits::{Communicator, CommunicatorCollectives, Destination, Root, Source};

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

    /// This rank's place among the ranks on its node (shared memory,
    /// `MPI_Comm_split_type`), by rank. Every rank must call it.
    pub fn local_rank(&self) -> usize {
        self.world.split_shared(self.world.rank()).rank() as usize
    }

    /// Stops every rank of the run with exit code `code` (`MPI_Abort`),
    /// for a rank that cannot go on while the others wait on it.
    pub fn abort(&self, code: i32) -> ! {
        self.world.abort(code)
    }
}

/// The tag of the messages between neighbours ([`Exchange::exchange_with`]).
const NEIGHBOUR_TAG: mpi::Tag = 7;

/// The tag of the messages to rank 0 in [`Exchange::gather`]; everything
/// else goes by collectives.
const GATHER_TAG: mpi::Tag = 8;

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

    fn gather(&self, words: &[u32]) -> Option<Vec<Vec<u32>>> {
        let root = self.world.process_at_rank(0);
        if self.rank() != 0 {
            root.send_with_tag(words, GATHER_TAG);
            return None;
        }
        let mut parts = vec![words.to_vec()];
        for rank in 1..self.size() {
            let (words, _) = self
                .world
                .process_at_rank(rank as mpi::Rank)
                .receive_vec_with_tag::<u32>(GATHER_TAG);
            parts.push(words);
        }
        Some(parts)
    }

    fn exchange_with(&self, outgoing: Vec<Vec<u32>>, partners: &[usize]) -> Vec<Vec<u32>> {
        let mut incoming = vec![Vec::new(); self.size()];
        mpi::request::scope(|scope| {
            let sends: Vec<_> = partners
                .iter()
                .map(|&rank| {
                    self.world
                        .process_at_rank(rank as mpi::Rank)
                        .immediate_send_with_tag(scope, &outgoing[rank][..], NEIGHBOUR_TAG)
                })
                .collect();
            for &rank in partners {
                let (words, _) = self
                    .world
                    .process_at_rank(rank as mpi::Rank)
                    .receive_vec_with_tag::<u32>(NEIGHBOUR_TAG);
                incoming[rank] = words;
            }
            for send in sends {
                send.wait();
            }
        });
        incoming
    }

    fn broadcast_from(&self, root: usize, words: Vec<u32>) -> Vec<u32> {
        let process = self.world.process_at_rank(root as mpi::Rank);
        let mut length = words.len() as u64;
        process.broadcast_into(&mut length);
        let mut words = if self.rank() == root {
            words
        } else {
            vec![0; length as usize]
        };
        process.broadcast_into(&mut words[..]);
        words
    }

    fn barrier(&self) {
        self.world.barrier();
    }

    fn max_f32(&self, values: &[f32]) -> Vec<f32> {
        let mut result = vec![0.0; values.len()];
        self.world
            .all_reduce_into(values, &mut result[..], SystemOperation::max());
        result
    }

    fn sum_u64(&self, counts: &[u64]) -> Vec<u64> {
        let mut result = vec![0; counts.len()];
        self.world
            .all_reduce_into(counts, &mut result[..], SystemOperation::sum());
        result
    }

    fn min_u64(&self, values: &[u64]) -> Vec<u64> {
        let mut result = vec![0; values.len()];
        self.world
            .all_reduce_into(values, &mut result[..], SystemOperation::min());
        result
    }

    fn max_u64(&self, values: &[u64]) -> Vec<u64> {
        let mut result = vec![0; values.len()];
        self.world
            .all_reduce_into(values, &mut result[..], SystemOperation::max());
        result
    }

    fn exclusive_sum_u64(&self, value: u64) -> u64 {
        let mut below = 0u64;
        self.world
            .exclusive_scan_into(&value, &mut below, SystemOperation::sum());
        // MPI leaves rank 0's result undefined.
        if self.rank() == 0 { 0 } else { below }
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
