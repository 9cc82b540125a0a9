//! Binary checkpoints from which a run can resume.
//!
//! A checkpoint is JSON metadata plus named raw arrays, so the solver decides
//! what state to save without this crate knowing its types. The layout, all
//! integers little-endian:
//!
//! ```text
//! b"FIRNCKPT"  u32 format version
//! u64 metadata length, metadata (JSON)
//! u32 array count, then per array: u32 name length, name (UTF-8), u64 byte length, bytes
//! u32 CRC-32 of everything above
//! ```
//!
//! The reader refuses, naming the file and the check that failed, a file
//! without the magic bytes, a version it does not read (0, or newer than
//! this build's), a truncated file and one whose checksum does not match
//! (a flipped bit); whether the state itself is one a run can reach is the
//! solver's to check (`firn_run::checkpoint::read`).

use std::fs;
use std::io::{self, Write};
use std::path::Path;

use bytemuck::Pod;

use crate::IoError;
use crate::atomic::write_atomically;

/// Identifies a firn checkpoint.
const MAGIC: &[u8; 8] = b"FIRNCKPT";

/// The layout version this build writes and the newest it reads.
const FORMAT_VERSION: u32 = 1;

/// Bytes of magic and version that start every checkpoint.
const PREAMBLE_BYTES: usize = MAGIC.len() + size_of::<u32>();

/// Bytes of the trailing checksum.
const CHECKSUM_BYTES: usize = size_of::<u32>();

/// Solver state saved for resuming: metadata plus named raw arrays.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Checkpoint {
    /// Free-form metadata (frame index, time, scene hash, ...).
    pub meta: serde_json::Value,
    /// Named arrays of raw little-endian bytes, in the order they were pushed.
    pub arrays: Vec<(String, Vec<u8>)>,
}

impl Checkpoint {
    /// An empty checkpoint with the given metadata.
    pub fn new(meta: serde_json::Value) -> Self {
        Self {
            meta,
            arrays: Vec::new(),
        }
    }

    /// Stores `values` under `name` as raw bytes, replacing an earlier array
    /// of the same name.
    pub fn push_array<T: Pod>(&mut self, name: impl Into<String>, values: &[T]) {
        let name = name.into();
        self.arrays.retain(|(existing, _)| *existing != name);
        self.arrays
            .push((name, bytemuck::cast_slice(values).to_vec()));
    }

    /// The raw bytes of array `name`.
    pub fn array_bytes(&self, name: &str) -> Result<&[u8], IoError> {
        self.arrays
            .iter()
            .find(|(existing, _)| existing == name)
            .map(|(_, bytes)| bytes.as_slice())
            .ok_or_else(|| IoError::MissingArray { name: name.into() })
    }

    /// Array `name` decoded as elements of `T`, bit for bit.
    pub fn array<T: Pod>(&self, name: &str) -> Result<Vec<T>, IoError> {
        let bytes = self.array_bytes(name)?;
        let element_size = size_of::<T>();
        if element_size == 0 || bytes.len() % element_size != 0 {
            return Err(IoError::ArrayByteLength {
                name: name.into(),
                bytes: bytes.len(),
                element_size,
            });
        }
        let mut values = vec![T::zeroed(); bytes.len() / element_size];
        bytemuck::cast_slice_mut::<T, u8>(&mut values).copy_from_slice(bytes);
        Ok(values)
    }

    /// Like [`Checkpoint::array`], but also requires exactly `len` elements.
    pub fn array_of_len<T: Pod>(&self, name: &str, len: usize) -> Result<Vec<T>, IoError> {
        let values = self.array(name)?;
        if values.len() != len {
            return Err(IoError::ArrayElementCount {
                name: name.into(),
                found: values.len(),
                expected: len,
            });
        }
        Ok(values)
    }

    /// Writes the checkpoint to `path`, atomically.
    pub fn write(&self, path: &Path) -> Result<(), IoError> {
        let arrays = self
            .arrays
            .iter()
            .map(|(name, bytes)| (name.as_str(), bytes.as_slice()));
        write_checkpoint(path, &self.meta, arrays)
    }

    /// Reads a checkpoint, verifying its magic bytes, format version and checksum.
    pub fn read(path: &Path) -> Result<Self, IoError> {
        let bytes = fs::read(path).map_err(|source| IoError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Checkpoint::from_bytes(&bytes, path)
    }

    /// Decodes the bytes of a checkpoint read from `path` (named in
    /// errors), with the checks of [`Checkpoint::read`].
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, IoError> {
        parse_checkpoint(bytes).map_err(|problem| problem.into_error(path))
    }
}

/// A checkpoint to write whose arrays stay where they are (the solver's):
/// [`CheckpointView::write`] streams them into the file, so writing one
/// costs no copy of the state. The file is the one a [`Checkpoint`] with
/// the same metadata and arrays writes, byte for byte.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CheckpointView<'a> {
    /// Free-form metadata (frame index, time, scene hash, ...).
    pub meta: serde_json::Value,
    /// Named arrays as raw bytes, borrowed, in the order they were pushed.
    pub arrays: Vec<(String, &'a [u8])>,
}

impl<'a> CheckpointView<'a> {
    /// An empty checkpoint with the given metadata.
    pub fn new(meta: serde_json::Value) -> Self {
        Self {
            meta,
            arrays: Vec::new(),
        }
    }

    /// Lends `values` under `name` as raw bytes, replacing an earlier array
    /// of the same name.
    pub fn push_array<T: Pod>(&mut self, name: impl Into<String>, values: &'a [T]) {
        let name = name.into();
        self.arrays.retain(|(existing, _)| *existing != name);
        self.arrays.push((name, bytemuck::cast_slice(values)));
    }

    /// Writes the checkpoint to `path`, atomically.
    pub fn write(&self, path: &Path) -> Result<(), IoError> {
        let arrays = self
            .arrays
            .iter()
            .map(|(name, bytes)| (name.as_str(), *bytes));
        write_checkpoint(path, &self.meta, arrays)
    }
}

/// Writes a checkpoint of `meta` and `arrays` (name, bytes) to `path`,
/// atomically, the checksum computed as the bytes pass.
fn write_checkpoint<'b>(
    path: &Path,
    meta: &serde_json::Value,
    arrays: impl ExactSizeIterator<Item = (&'b str, &'b [u8])>,
) -> Result<(), IoError> {
    write_atomically(path, |out| {
        let mut checksummed = ChecksummedWriter::new(out);
        write_contents(&mut checksummed, meta, arrays)?;
        let checksum = checksummed.hasher.finalize();
        checksummed.inner.write_all(&checksum.to_le_bytes())
    })
}

/// Everything but the checksum.
fn write_contents<'b>(
    out: &mut dyn Write,
    meta: &serde_json::Value,
    arrays: impl ExactSizeIterator<Item = (&'b str, &'b [u8])>,
) -> io::Result<()> {
    out.write_all(MAGIC)?;
    out.write_all(&FORMAT_VERSION.to_le_bytes())?;
    write_u64_prefixed(out, &serde_json::to_vec(meta)?)?;
    out.write_all(&length_as_u32(arrays.len())?.to_le_bytes())?;
    for (name, bytes) in arrays {
        out.write_all(&length_as_u32(name.len())?.to_le_bytes())?;
        out.write_all(name.as_bytes())?;
        write_u64_prefixed(out, bytes)?;
    }
    Ok(())
}

/// Passes writes through while computing their CRC-32.
struct ChecksummedWriter<'w> {
    inner: &'w mut dyn Write,
    hasher: crc32fast::Hasher,
}

impl<'w> ChecksummedWriter<'w> {
    fn new(inner: &'w mut dyn Write) -> Self {
        Self {
            inner,
            hasher: crc32fast::Hasher::new(),
        }
    }
}

impl Write for ChecksummedWriter<'_> {
    fn write(&mut self, buffer: &[u8]) -> io::Result<usize> {
        let written = self.inner.write(buffer)?;
        self.hasher.update(&buffer[..written]);
        Ok(written)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

fn write_u64_prefixed(out: &mut dyn Write, bytes: &[u8]) -> io::Result<()> {
    out.write_all(&(bytes.len() as u64).to_le_bytes())?;
    out.write_all(bytes)
}

fn length_as_u32(length: usize) -> io::Result<u32> {
    u32::try_from(length)
        .map_err(|_| io::Error::other(format!("{length} does not fit a u32 field")))
}

/// Why a checkpoint's bytes were rejected, before the path is attached.
enum ReadProblem {
    Corrupt(String),
    Newer(u32),
}

impl ReadProblem {
    fn into_error(self, path: &Path) -> IoError {
        let path = path.to_path_buf();
        match self {
            Self::Corrupt(reason) => IoError::CorruptCheckpoint { path, reason },
            Self::Newer(found) => IoError::NewerCheckpoint {
                path,
                found,
                supported: FORMAT_VERSION,
            },
        }
    }
}

impl From<String> for ReadProblem {
    fn from(reason: String) -> Self {
        Self::Corrupt(reason)
    }
}

fn parse_checkpoint(bytes: &[u8]) -> Result<Checkpoint, ReadProblem> {
    check_magic(bytes)?;
    if bytes.len() < PREAMBLE_BYTES + CHECKSUM_BYTES {
        return Err(format!("truncated to {} bytes", bytes.len()).into());
    }
    check_version(bytes)?;
    let contents = verified_contents(bytes)?;
    Ok(parse_contents(&contents[PREAMBLE_BYTES..])?)
}

fn check_magic(bytes: &[u8]) -> Result<(), ReadProblem> {
    if bytes.starts_with(MAGIC) {
        Ok(())
    } else if MAGIC.starts_with(bytes) {
        Err(format!("truncated to {} bytes", bytes.len()).into())
    } else {
        Err("bad magic bytes (not a firn checkpoint)".to_string().into())
    }
}

fn check_version(bytes: &[u8]) -> Result<(), ReadProblem> {
    let version = ByteReader::new(&bytes[MAGIC.len()..]).u32()?;
    match version {
        0 => Err("unknown format version 0".to_string().into()),
        FORMAT_VERSION => Ok(()),
        newer => Err(ReadProblem::Newer(newer)),
    }
}

/// The bytes covered by the checksum, once the checksum matches.
fn verified_contents(bytes: &[u8]) -> Result<&[u8], ReadProblem> {
    let (contents, stored) = bytes.split_at(bytes.len() - CHECKSUM_BYTES);
    let stored = ByteReader::new(stored).u32()?;
    if crc32fast::hash(contents) == stored {
        Ok(contents)
    } else {
        Err("checksum mismatch (the file is damaged or truncated)"
            .to_string()
            .into())
    }
}

/// Parses metadata and arrays, which follow the magic and version.
fn parse_contents(bytes: &[u8]) -> Result<Checkpoint, String> {
    let mut reader = ByteReader::new(bytes);
    let meta_length = reader.length_u64()?;
    let meta = serde_json::from_slice(reader.take(meta_length)?)
        .map_err(|error| format!("invalid metadata: {error}"))?;
    let array_count = reader.u32()?;
    let arrays = (0..array_count)
        .map(|_| read_array(&mut reader))
        .collect::<Result<_, _>>()?;
    if !reader.remaining.is_empty() {
        return Err(format!(
            "{} unexpected bytes after the last array",
            reader.remaining.len()
        ));
    }
    Ok(Checkpoint { meta, arrays })
}

fn read_array(reader: &mut ByteReader) -> Result<(String, Vec<u8>), String> {
    let name_length = reader.u32()? as usize;
    let name = std::str::from_utf8(reader.take(name_length)?)
        .map_err(|_| "an array name is not valid UTF-8".to_string())?
        .to_string();
    let byte_length = reader.length_u64()?;
    let bytes = reader.take(byte_length)?.to_vec();
    Ok((name, bytes))
}

/// Reads little-endian fields from a byte slice, failing instead of panicking
/// when a field runs past the end.
struct ByteReader<'b> {
    remaining: &'b [u8],
}

impl<'b> ByteReader<'b> {
    fn new(bytes: &'b [u8]) -> Self {
        Self { remaining: bytes }
    }

    fn take(&mut self, count: usize) -> Result<&'b [u8], String> {
        if count > self.remaining.len() {
            return Err(format!(
                "a field of {count} bytes runs past the end ({} bytes left)",
                self.remaining.len()
            ));
        }
        let (taken, rest) = self.remaining.split_at(count);
        self.remaining = rest;
        Ok(taken)
    }

    fn u32(&mut self) -> Result<u32, String> {
        let bytes = self.take(size_of::<u32>())?;
        Ok(u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]))
    }

    fn length_u64(&mut self) -> Result<usize, String> {
        const WORD_BYTES: usize = size_of::<u64>();
        let mut word = [0; WORD_BYTES];
        word.copy_from_slice(self.take(WORD_BYTES)?);
        let length = u64::from_le_bytes(word);
        usize::try_from(length).map_err(|_| format!("length {length} is too large"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    const NAN_WITH_PAYLOAD: u32 = 0x7fa0_0001;

    fn sample() -> Checkpoint {
        let mut checkpoint = Checkpoint::new(serde_json::json!({ "frame": 12, "time": 0.5 }));
        let jp = [1.0, f32::from_bits(NAN_WITH_PAYLOAD), -0.0, f32::INFINITY];
        checkpoint.push_array("jp", &jp);
        checkpoint.push_array("velocity", &[Vec3::new(1.0, 2.0, 3.0), Vec3::NEG_Y]);
        checkpoint.push_array("flags", &[1u8, 2, 3]);
        checkpoint.push_array("empty", &[] as &[u64]);
        checkpoint
    }

    fn written_sample(dir: &Path) -> std::path::PathBuf {
        let path = dir.join("state.ckpt");
        sample().write(&path).unwrap();
        path
    }

    fn corrupt_reason(path: &Path) -> String {
        match Checkpoint::read(path) {
            Err(IoError::CorruptCheckpoint { reason, .. }) => reason,
            other => panic!("expected a corrupt checkpoint, got {other:?}"),
        }
    }

    #[test]
    fn arrays_round_trip_bit_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let restored = Checkpoint::read(&written_sample(dir.path())).unwrap();

        assert_eq!(restored.meta, sample().meta);
        assert_eq!(restored.arrays, sample().arrays);
        let jp: Vec<u32> = restored
            .array::<f32>("jp")
            .unwrap()
            .iter()
            .map(|v| v.to_bits())
            .collect();
        assert_eq!(
            jp,
            [
                1.0f32.to_bits(),
                NAN_WITH_PAYLOAD,
                0x8000_0000,
                f32::INFINITY.to_bits()
            ]
        );
        assert_eq!(
            restored.array_of_len::<Vec3>("velocity", 2).unwrap(),
            [Vec3::new(1.0, 2.0, 3.0), Vec3::NEG_Y]
        );
        assert_eq!(restored.array::<u8>("flags").unwrap(), [1, 2, 3]);
        assert!(restored.array::<u64>("empty").unwrap().is_empty());
    }

    #[test]
    fn the_file_starts_with_magic_and_version() {
        let dir = tempfile::tempdir().unwrap();
        let bytes = fs::read(written_sample(dir.path())).unwrap();
        assert_eq!(&bytes[..8], b"FIRNCKPT");
        assert_eq!(bytes[8..12], 1u32.to_le_bytes());
    }

    #[test]
    fn a_flipped_byte_fails_the_checksum() {
        let dir = tempfile::tempdir().unwrap();
        let path = written_sample(dir.path());
        let mut bytes = fs::read(&path).unwrap();
        let middle = bytes.len() / 2;
        bytes[middle] ^= 0x10;
        fs::write(&path, &bytes).unwrap();

        let message = Checkpoint::read(&path).unwrap_err().to_string();

        assert_eq!(
            message,
            format!(
                "checkpoint {} is corrupt: checksum mismatch (the file is damaged or truncated)",
                path.display()
            )
        );
    }

    #[test]
    fn a_truncated_file_is_corrupt() {
        let dir = tempfile::tempdir().unwrap();
        let path = written_sample(dir.path());
        let bytes = fs::read(&path).unwrap();
        for length in [bytes.len() - 1, bytes.len() / 2, 10, 5, 0] {
            fs::write(&path, &bytes[..length]).unwrap();
            let reason = corrupt_reason(&path);
            assert!(
                reason.contains("checksum mismatch") || reason.contains("truncated"),
                "{length}: {reason}"
            );
        }
    }

    #[test]
    fn a_newer_format_version_is_reported_as_such() {
        let dir = tempfile::tempdir().unwrap();
        let path = written_sample(dir.path());
        let mut bytes = fs::read(&path).unwrap();
        bytes[8..12].copy_from_slice(&7u32.to_le_bytes());
        fs::write(&path, &bytes).unwrap();

        let message = Checkpoint::read(&path).unwrap_err().to_string();

        assert!(
            message.contains("was written by a newer firn (format version 7"),
            "{message}"
        );
    }

    #[test]
    fn a_foreign_file_has_bad_magic() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("state.ckpt");
        fs::write(&path, b"PK\x03\x04 definitely a zip file").unwrap();
        assert!(corrupt_reason(&path).contains("bad magic"));
    }

    #[test]
    fn missing_and_misshapen_arrays_name_the_array() {
        let checkpoint = sample();
        assert_eq!(
            checkpoint
                .array::<f32>("positions")
                .unwrap_err()
                .to_string(),
            "checkpoint has no array named `positions`"
        );
        assert_eq!(
            checkpoint.array::<u32>("flags").unwrap_err().to_string(),
            "checkpoint array `flags` holds 3 bytes, which is not a whole number of 4-byte elements"
        );
        assert_eq!(
            checkpoint
                .array_of_len::<f32>("jp", 5)
                .unwrap_err()
                .to_string(),
            "checkpoint array `jp` holds 4 elements, expected 5"
        );
    }

    #[test]
    fn a_view_writes_the_bytes_of_the_owned_checkpoint() {
        let dir = tempfile::tempdir().unwrap();
        let owned = sample();
        let mut view = CheckpointView::new(owned.meta.clone());
        view.push_array("jp", &[0.0f32]);
        for (name, bytes) in &owned.arrays {
            view.push_array(name.as_str(), bytes.as_slice());
        }
        let path = dir.path().join("view.ckpt");
        view.write(&path).unwrap();
        assert_eq!(
            fs::read(&path).unwrap(),
            fs::read(written_sample(dir.path())).unwrap()
        );
    }

    #[test]
    fn pushing_a_name_again_replaces_the_array() {
        let mut checkpoint = sample();
        checkpoint.push_array("jp", &[2.0f32]);
        assert_eq!(checkpoint.array::<f32>("jp").unwrap(), [2.0]);
        assert_eq!(checkpoint.arrays.len(), 4);
    }
}
