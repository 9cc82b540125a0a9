//! firn-run: firn's app layer, shared by every front door (the `firn`
//! command, the viewer, the Python module, and MPI ranks through
//! firn-mpi, whose rank 0 drives a [`Recording`] with a
//! [`Stepper`](recording::Stepper)): a scene
//! simulated on the CPU or the GPU, snow or flow, turned into frames,
//! checkpoints and a run directory, and a run directory read back.
//!
//! - [`backend`]: where a scene runs ([`Placement`]), chosen from its
//!   `[compute] backend` and the adapters present;
//! - [`budget`]: whether a scene fits this machine, known before anything
//!   is sampled or allocated;
//! - [`simulation`]: [`Solver`], one type for a simulation on any backend
//!   (each an engine behind one trait, `engine/`): step it, read its
//!   particles, change its parameters, take its state, and measure it
//!   ([`SolverOptions`], phase times, memory);
//! - [`checkpoint`]: the snow and flow checkpoint files;
//! - [`caches`]: a frame's PLY, VTK, VDB, mesh and USD caches and the PVD
//!   collection;
//! - [`surface`]: the snow's surface as a closed triangle mesh;
//! - [`run_dir`]: [`RunDirectory`], the layout of a run's folder, written
//!   and read back;
//! - [`recording`]: [`Recording`], a run in progress: its solver, its
//!   manifest and its checkpoints, frame by frame, with an
//!   [`Observer`](recording::Observer) for what the front door shows;
//! - [`pictures`]: a frame's pictures and a run's animations;
//! - [`error`]: what can go wrong, as [`RunError`].

pub mod backend;
pub mod body_meshes;
pub mod budget;
pub mod caches;
pub mod checkpoint;
mod engine;
pub mod error;
pub mod pictures;
pub mod recording;
pub mod run_dir;
pub mod simulation;
pub mod surface;
pub mod usd_stage;
pub mod volumes;

pub use backend::{Chosen, Placement, choose_backend};
pub use budget::Budget;
pub use error::RunError;
pub use recording::Recording;
pub use run_dir::RunDirectory;
pub use simulation::{Solver, SolverOptions};
