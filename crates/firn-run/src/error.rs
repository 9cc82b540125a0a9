//! What can go wrong while a scene runs and its files are written: the
//! solvers' own errors, passed through unchanged, and the few this crate
//! adds.

use std::path::PathBuf;

use firn_flow::FlowError;
use firn_gpu::GpuError;
use firn_io::IoError;
use firn_mpm::SimulationError;
use thiserror::Error;

/// Why a simulation could not start, step, change or be written.
///
/// The wrapped errors show as they are, so a message reads the same as the
/// solver's or the writer's own.
#[derive(Debug, Error)]
pub enum RunError {
    /// The CPU snow solver refused the scene or went unstable.
    #[error(transparent)]
    Snow(#[from] SimulationError),
    /// The CPU flow refused the scene or a state.
    #[error(transparent)]
    Flow(#[from] FlowError),
    /// The GPU backend refused the scene, failed or went unstable.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// A cache, manifest or checkpoint could not be written.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A checkpoint could not be read back.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// The scene needs more memory than the machine has.
    #[error(transparent)]
    TooLarge(#[from] crate::budget::TooLarge),
    /// A frame could not be simulated.
    #[error("the simulation stopped in frame {frame}: {source}")]
    Stopped {
        /// The frame being simulated.
        frame: u32,
        /// Why.
        source: Box<RunError>,
    },
    /// The operation does not apply to this kind of simulation or backend.
    #[error("{0}")]
    Unsupported(&'static str),
    /// A picture handed in by the front door could not be made.
    #[error("{0}")]
    Pictures(String),
    /// Another process of a run split between processes (an MPI rank)
    /// failed; its own message says why.
    #[error("rank {rank} of {ranks}: {message}")]
    Rank {
        /// The failing rank.
        rank: usize,
        /// How many ranks the run has.
        ranks: usize,
        /// The failing rank's error message.
        message: String,
    },
}

/// Why a checkpoint file could not be read back.
#[derive(Debug, Error)]
pub enum CheckpointError {
    /// The file is missing, damaged or lacks an array.
    #[error(transparent)]
    File(#[from] IoError),
    /// The checkpoint's checksum holds, but its state is not one a run of
    /// the scene reaches.
    #[error("checkpoint {} holds a state no run of this scene reaches: {reason}", path.display())]
    Implausible {
        /// The checkpoint file.
        path: PathBuf,
        /// What is wrong with the state.
        reason: String,
    },
    /// The header lacks a counter the solver needs.
    #[error("checkpoint {} lacks `{field}`", path.display())]
    MissingField {
        /// The checkpoint file.
        path: PathBuf,
        /// The header field.
        field: &'static str,
    },
}

/// Why a run could not be picked up from its directory.
#[derive(Debug, Error)]
pub enum ResumeError {
    /// The directory holds no checkpoint.
    #[error("no checkpoint at {}", path.display())]
    NoCheckpoint {
        /// Where the checkpoint was looked for.
        path: PathBuf,
    },
    /// The checkpoint could not be read, or the solver refused its state.
    #[error(transparent)]
    Restore(#[from] RunError),
    /// The checkpoint was written for another scene.
    #[error("the scene differs from the one that wrote {}", path.display())]
    SceneDiffers {
        /// The checkpoint file.
        path: PathBuf,
    },
    /// The run's manifest could not be read.
    #[error(transparent)]
    Manifest(IoError),
}

/// Why a run directory could not be read back.
#[derive(Debug, Error)]
pub enum ReadRunError {
    /// There is no readable manifest.
    #[error(
        "{source}\n  fix: pass the directory of a run made by `firn run` (it holds {})",
        firn_io::MANIFEST_FILE
    )]
    Manifest {
        /// Why the manifest could not be read.
        source: IoError,
    },
    /// The manifest's scene is not one this build reads.
    #[error(
        "{}: the scene in the manifest cannot be read: {source}\n  fix: re-run the scene with this version of firn",
        path.display()
    )]
    Scene {
        /// The manifest.
        path: PathBuf,
        /// Why the scene could not be read.
        source: serde_json::Error,
    },
    /// The manifest's scene breaks a rule of the scene format.
    #[error(
        "{}: the scene in the manifest is not valid: {source}\n  fix: re-run the scene with this version of firn",
        path.display()
    )]
    InvalidScene {
        /// The manifest.
        path: PathBuf,
        /// The broken rule.
        source: Box<firn_core::scene::SceneError>,
    },
    /// A mesh the scene refers to cannot be loaded again.
    #[error("{}: a mesh of the scene cannot be loaded again: {reason}", path.display())]
    Mesh {
        /// The manifest.
        path: PathBuf,
        /// Why the mesh could not be loaded.
        reason: String,
    },
    /// The frame's record names no PLY cache.
    #[error(
        "frame {index} has no PLY cache in {}\n  fix: add \"ply\" to [output] formats and run the scene again",
        directory.display()
    )]
    NoPlyCache {
        /// The frame.
        index: u32,
        /// The run directory.
        directory: PathBuf,
    },
    /// The frame's PLY cache cannot be read.
    #[error(
        "{source}\n  fix: re-run the scene (firn run --resume continues an interrupted run), or remove the damaged frame's record"
    )]
    FrameCache {
        /// Why the cache could not be read.
        source: IoError,
    },
}
