//! The one error type of the loaders.

use std::path::PathBuf;

/// Why a mesh file could not be loaded: where (file and, for text, line),
/// what is wrong and how to fix it. Displays as
/// `"{path}:{line}: {message}\n  fix: {hint}"`, without `:{line}` when the
/// problem has no line (binary data, unreadable file).
#[derive(thiserror::Error, Debug)]
#[error("{}{}: {message}\n  fix: {hint}", .path.display(), line_suffix(.line))]
pub struct MeshError {
    /// The file that failed to load.
    pub path: PathBuf,
    /// The 1-based line of the problem in a text file, if there is one.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
    /// How to fix it.
    pub hint: String,
}

fn line_suffix(line: &Option<usize>) -> String {
    line.map(|l| format!(":{l}")).unwrap_or_default()
}
