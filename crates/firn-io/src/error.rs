//! The single error type shared by every reader and writer in this crate.

use std::io;
use std::path::PathBuf;

use crate::frame::FrameError;

/// Everything that can go wrong while reading or writing firn's files.
///
/// Each variant that concerns a file names it, so a message such as
/// "cannot write /out/frame_0001.ply: Permission denied (os error 13)" can be
/// shown to the user as is.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// Creating, writing, syncing or renaming a file failed.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The file that was being written (the final name, not the temporary one).
        path: PathBuf,
        /// The operating system's reason.
        source: io::Error,
    },

    /// Opening or reading a file failed.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file that was being read.
        path: PathBuf,
        /// The operating system's reason.
        source: io::Error,
    },

    /// An output directory could not be created.
    #[error("cannot create directory {}: {source}", path.display())]
    CreateDir {
        /// The directory that was requested.
        path: PathBuf,
        /// The operating system's reason.
        source: io::Error,
    },

    /// A path meant to be an output directory exists but is something else.
    #[error("{} exists but is not a directory", path.display())]
    NotADirectory {
        /// The offending path.
        path: PathBuf,
    },

    /// An output directory exists but files cannot be created in it.
    #[error("directory {} is not writable: {source}", path.display())]
    NotWritable {
        /// The directory that was probed.
        path: PathBuf,
        /// The operating system's reason.
        source: io::Error,
    },

    /// The frame handed to a writer is inconsistent, so nothing was written.
    #[error("cannot write {}: {problem}", path.display())]
    InvalidFrame {
        /// The file that would have been written.
        path: PathBuf,
        /// What is wrong with the frame.
        #[source]
        problem: FrameError,
    },

    /// A PLY file is malformed or uses features our reader does not handle.
    #[error("{} is not a PLY file firn can read: {reason}", path.display())]
    InvalidPly {
        /// The file that was read.
        path: PathBuf,
        /// What the reader found wrong.
        reason: String,
    },

    /// A `.pvd` collection file is malformed.
    #[error("{} is not a valid PVD collection: {reason}", path.display())]
    InvalidPvd {
        /// The file that was read.
        path: PathBuf,
        /// What the reader found wrong.
        reason: String,
    },

    /// A JSON file (the run manifest) could not be parsed.
    #[error("cannot parse {}: {source}", path.display())]
    Json {
        /// The file that was read.
        path: PathBuf,
        /// The parser's reason, with line and column.
        source: serde_json::Error,
    },

    /// A checkpoint failed one of its integrity checks.
    #[error("checkpoint {} is corrupt: {reason}", path.display())]
    CorruptCheckpoint {
        /// The checkpoint file.
        path: PathBuf,
        /// Which check failed.
        reason: String,
    },

    /// A checkpoint uses a format version this build does not understand.
    #[error(
        "checkpoint {} was written by a newer firn (format version {found}, this build reads up to {supported})",
        path.display()
    )]
    NewerCheckpoint {
        /// The checkpoint file.
        path: PathBuf,
        /// The version stored in the file.
        found: u32,
        /// The newest version this build can read.
        supported: u32,
    },

    /// A checkpoint lacks an array the caller asked for.
    #[error("checkpoint has no array named `{name}`")]
    MissingArray {
        /// The requested array name.
        name: String,
    },

    /// A checkpoint array's byte length does not fit the requested element type.
    #[error(
        "checkpoint array `{name}` holds {bytes} bytes, which is not a whole number of {element_size}-byte elements"
    )]
    ArrayByteLength {
        /// The array name.
        name: String,
        /// The stored byte length.
        bytes: usize,
        /// The size of the requested element type.
        element_size: usize,
    },

    /// A checkpoint array holds a different number of elements than expected.
    #[error("checkpoint array `{name}` holds {found} elements, expected {expected}")]
    ArrayElementCount {
        /// The array name.
        name: String,
        /// The number of elements stored.
        found: usize,
        /// The number of elements the caller required.
        expected: usize,
    },
}
