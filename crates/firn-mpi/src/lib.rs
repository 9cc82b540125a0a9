//! firn-mpi: a snow simulation or a curl-noise flow split between
//! processes (MPI ranks), giving the same bits as one process for any rank
//! count.
//!
//! The grid's blocks are cut into slabs of whole block columns along x
//! ([`slabs`]); each rank owns the particles of its slab and steps them
//! with a [`firn_mpm::Simulation`] ([`rank`]), which holds no state of the
//! split: the rank keeps its particles' keys beside it. Particles carry
//! their place in the one-process array, so every block sums its
//! particles in the one-process order; in the scatter each rank sends its
//! neighbours the sums of its blocks next to theirs
//! ([`firn_mpm::block_sums`]), so every node sums the one process's blocks
//! in the one process's order (docs/architecture.md, "MPI"). A flow, whose
//! particles never read each other, splits by particles instead: every
//! rank steps its part of a copy of the whole flow ([`rank_flow`]).
//!
//! The ranks talk through [`exchange::Exchange`]: particles and block sums
//! by an all-to-all of word buffers, and reductions, a scan and broadcasts.
//! [`exchange::ThreadRanks`] runs ranks as threads of one process (the
//! tests); with the `mpi` feature, `MpiExchange` runs them on MPI
//! (`mpirun -np N firn run SCENE`). [`driver`] plugs the ranks into
//! [`firn_run::Recording`]: in a snow run every rank writes its own VTK
//! pieces and checkpoint pieces, rank 0 the caches of the whole run; in a
//! flow run rank 0 writes everything, as one process would; the others
//! follow rank 0's commands.

pub mod driver;
pub mod exchange;
#[cfg(feature = "mpi")]
pub mod mpi_exchange;
pub mod packing;
mod part;
pub mod rank;
pub mod rank_flow;
pub mod slabs;

pub use driver::{Command, RootStepper, follow};
pub use exchange::{Exchange, ThreadRanks};
pub use rank::{Phase, RankSnow, RankTraffic};
pub use rank_flow::RankFlow;
pub use slabs::Slabs;
