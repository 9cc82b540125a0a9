//! Crash-safe file writes and output-directory checks.
//!
//! A simulation can be killed at any moment (Ctrl-C, out of memory, a full
//! disk). Writing through a temporary file that is renamed over the target
//! only once it is complete and synced means readers see either the previous
//! version of a file or the new one, never a torn mix.

use std::ffi::OsString;
use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Size of the write buffer between the caller's writes and the file.
pub const WRITE_BUFFER_BYTES: usize = 1 << 20;

/// Distinguishes temporary files of concurrent writes within one process.
static TEMP_FILE_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `path` atomically: `write` fills a temporary file in the same
/// directory, which is flushed, synced and then renamed over `path`.
///
/// On any failure, including an error returned by `write`, the temporary
/// file is removed and an existing `path` is left untouched.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), crate::IoError> {
    let write_error = |source| crate::IoError::Write {
        path: path.to_path_buf(),
        source,
    };
    let temp_path = temporary_path_for(path).map_err(write_error)?;
    let outcome = write_and_sync(&temp_path, write).and_then(|()| fs::rename(&temp_path, path));
    if let Err(source) = outcome {
        // The write already failed; a leftover temporary file is the lesser problem.
        let _ = fs::remove_file(&temp_path);
        return Err(write_error(source));
    }
    Ok(())
}

/// Creates `dir` (and missing parents) and proves that files can be created in
/// it, so a run fails at startup rather than after hours of simulation.
pub fn ensure_writable_dir(dir: &Path) -> Result<(), crate::IoError> {
    if dir.exists() && !dir.is_dir() {
        return Err(crate::IoError::NotADirectory {
            path: dir.to_path_buf(),
        });
    }
    fs::create_dir_all(dir).map_err(|source| crate::IoError::CreateDir {
        path: dir.to_path_buf(),
        source,
    })?;
    probe_writable(dir).map_err(|source| crate::IoError::NotWritable {
        path: dir.to_path_buf(),
        source,
    })
}

/// Picks the hidden temporary sibling `.{file_name}.tmp-{pid}-{n}` of `path`.
fn temporary_path_for(path: &Path) -> io::Result<PathBuf> {
    let file_name = path.file_name().ok_or_else(|| {
        io::Error::new(io::ErrorKind::InvalidInput, "the path does not name a file")
    })?;
    let mut temp_name = OsString::from(".");
    temp_name.push(file_name);
    temp_name.push(format!(
        ".tmp-{}-{}",
        std::process::id(),
        TEMP_FILE_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    Ok(path.with_file_name(temp_name))
}

/// Creates `temp_path`, lets `write` fill it through a buffer, and syncs it to disk.
fn write_and_sync(
    temp_path: &Path,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> io::Result<()> {
    let mut buffered = BufWriter::with_capacity(WRITE_BUFFER_BYTES, File::create(temp_path)?);
    write(&mut buffered)?;
    let file = buffered
        .into_inner()
        .map_err(io::IntoInnerError::into_error)?;
    file.sync_all()
}

/// Creates and removes a probe file in `dir`.
fn probe_writable(dir: &Path) -> io::Result<()> {
    let probe = temporary_path_for(&dir.join("firn-write-probe"))?;
    File::create(&probe)?;
    fs::remove_file(&probe)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn directory_entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn writes_the_content_and_leaves_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.txt");
        write_atomically(&target, |out| out.write_all(b"hello")).unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"hello");
        assert_eq!(directory_entries(dir.path()), ["out.txt"]);
    }

    #[test]
    fn replaces_an_existing_file() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.txt");
        fs::write(&target, b"old").unwrap();
        write_atomically(&target, |out| out.write_all(b"new")).unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"new");
    }

    #[test]
    fn a_failing_writer_leaves_the_target_untouched_and_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.txt");
        fs::write(&target, b"previous frame").unwrap();
        let result = write_atomically(&target, |out| {
            out.write_all(&vec![b'x'; 3 * WRITE_BUFFER_BYTES])?;
            Err(io::Error::other("disk on fire"))
        });
        let message = result.unwrap_err().to_string();
        assert!(message.contains("cannot write"), "{message}");
        assert!(message.contains("out.txt"), "{message}");
        assert!(message.contains("disk on fire"), "{message}");
        assert_eq!(fs::read(&target).unwrap(), b"previous frame");
        assert_eq!(directory_entries(dir.path()), ["out.txt"]);
    }

    #[test]
    fn a_missing_directory_is_reported_with_the_target_path() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("missing").join("out.txt");
        let message = write_atomically(&target, |out| out.write_all(b"x"))
            .unwrap_err()
            .to_string();
        assert!(message.contains(&target.display().to_string()), "{message}");
    }

    #[test]
    fn ensure_writable_dir_creates_nested_directories() {
        let dir = tempfile::tempdir().unwrap();
        let nested = dir.path().join("a").join("b");
        ensure_writable_dir(&nested).unwrap();
        assert!(nested.is_dir());
        assert!(directory_entries(&nested).is_empty());
    }

    #[test]
    fn ensure_writable_dir_rejects_a_path_under_a_regular_file() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("plain.txt");
        fs::write(&file, b"").unwrap();
        let wanted = file.join("frames");
        let error = ensure_writable_dir(&wanted).unwrap_err();
        assert!(
            matches!(error, crate::IoError::CreateDir { .. }),
            "{error:?}"
        );
        let message = error.to_string();
        assert!(
            message.starts_with(&format!("cannot create directory {}: ", wanted.display())),
            "{message}"
        );
    }

    #[test]
    fn ensure_writable_dir_rejects_a_regular_file() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("plain.txt");
        fs::write(&file, b"").unwrap();
        let message = ensure_writable_dir(&file).unwrap_err().to_string();
        assert_eq!(
            message,
            format!("{} exists but is not a directory", file.display())
        );
    }
}
