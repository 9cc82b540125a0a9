//! Binary PLY point clouds: the particle cache format Blender and Houdini import.
//!
//! Files are `binary_little_endian 1.0` with a single `vertex` element whose
//! properties are the position (`x y z`) followed by every attribute of the
//! frame. The reader understands exactly what the writer produces (and other
//! files restricted to `float`/`uint` vertex properties), which is enough to
//! re-render a cache or to check it in tests.
//!
//! firn's caches carry one more header comment, `firn cache 1 crc32 XXXXXXXX`:
//! the cache layout's version and the CRC-32 of the vertex data. The reader
//! refuses a cache of a newer version and one whose data does not match its
//! checksum (a flipped bit, a torn copy); other tools ignore the comment.
//! Files without it (from other tools) are read unchecked.

use std::fs;
use std::io;
use std::path::Path;

use glam::Vec3;

use crate::IoError;
use crate::atomic::write_atomically;
use crate::frame::{AttributeValues, FrameData, FrameError};

/// Vertices encoded per buffer handed to the writer.
const CHUNK_VERTICES: usize = crate::frame::CHUNK_VALUES;

/// Every supported property type is four bytes wide.
const PROPERTY_BYTES: usize = 4;

/// The line that closes a PLY header.
const END_HEADER: &[u8] = b"end_header\n";

/// The first words of the comment that carries the cache version and checksum.
const CACHE_COMMENT: &str = "firn cache";

/// The cache layout this build writes and the newest it reads.
const CACHE_VERSION: u32 = 1;

/// Writes `frame` as a binary little-endian PLY point cloud, atomically.
///
/// Scalars become `float <name>`, integers `uint <name>`, and vectors three
/// float properties: `vx vy vz` for "velocity", `nx ny nz` for "normal"
/// (the names DCC tools recognise) and `<name>_x <name>_y <name>_z` otherwise.
pub fn write_ply(path: &Path, frame: &FrameData) -> Result<(), IoError> {
    let invalid = |problem| IoError::InvalidFrame {
        path: path.to_path_buf(),
        problem,
    };
    frame.validate().map_err(invalid)?;
    let properties = vertex_properties(frame);
    ensure_unique_property_names(&properties).map_err(invalid)?;
    let record_bytes = properties.len() * PROPERTY_BYTES;
    let mut hasher = crc32fast::Hasher::new();
    for_each_chunk(frame, record_bytes, |chunk| {
        hasher.update(chunk);
        Ok(())
    })
    .map_err(|source| IoError::Write {
        path: path.to_path_buf(),
        source,
    })?;
    let header = header_text(frame, &properties, hasher.finalize());
    write_atomically(path, |out| {
        out.write_all(header.as_bytes())?;
        for_each_chunk(frame, record_bytes, |chunk| out.write_all(chunk))
    })
}

/// Reads a binary little-endian PLY point cloud with `float`/`uint` vertex properties.
pub fn read_ply(path: &Path) -> Result<PlyCloud, IoError> {
    let bytes = fs::read(path).map_err(|source| IoError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    parse_ply(&bytes, path)
}

/// Decodes the bytes of a PLY point cloud read from `path` (named in
/// errors), with the checks of [`read_ply`].
pub fn parse_ply(bytes: &[u8], path: &Path) -> Result<PlyCloud, IoError> {
    decode_ply(bytes).map_err(|reason| IoError::InvalidPly {
        path: path.to_path_buf(),
        reason,
    })
}

/// The vertices of a PLY file, stored column by column.
#[derive(Debug, Clone, PartialEq)]
pub struct PlyCloud {
    /// The header's `comment` lines, without the keyword.
    pub comments: Vec<String>,
    /// Number of vertices (particles).
    pub vertex_count: usize,
    /// One column per vertex property, in file order.
    pub columns: Vec<PlyColumn>,
}

/// One vertex property and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct PlyColumn {
    /// The property name as written in the header.
    pub name: String,
    /// One value per vertex.
    pub values: PlyValues,
}

/// The values of a column, by PLY type.
#[derive(Debug, Clone, PartialEq)]
pub enum PlyValues {
    /// A `float` property.
    Float(Vec<f32>),
    /// A `uint` property.
    UInt(Vec<u32>),
}

impl PlyCloud {
    /// The column called `name`, if present.
    pub fn column(&self, name: &str) -> Option<&PlyValues> {
        self.columns
            .iter()
            .find(|column| column.name == name)
            .map(|column| &column.values)
    }

    /// The `float` column called `name`, if present.
    pub fn floats(&self, name: &str) -> Option<&[f32]> {
        match self.column(name)? {
            PlyValues::Float(values) => Some(values),
            PlyValues::UInt(_) => None,
        }
    }

    /// The `uint` column called `name`, if present.
    pub fn uints(&self, name: &str) -> Option<&[u32]> {
        match self.column(name)? {
            PlyValues::UInt(values) => Some(values),
            PlyValues::Float(_) => None,
        }
    }

    /// Particle positions assembled from the `x`, `y` and `z` columns.
    pub fn positions(&self) -> Option<Vec<Vec3>> {
        self.vec3_from(["x", "y", "z"])
    }

    /// A vector attribute reassembled from its component columns, using the
    /// same naming as [`write_ply`] (so `vector("velocity")` reads `vx vy vz`).
    pub fn vector(&self, attribute: &str) -> Option<Vec<Vec3>> {
        let [x, y, z] = vector_component_names(attribute);
        self.vec3_from([&x, &y, &z])
    }

    fn vec3_from(&self, [x, y, z]: [&str; 3]) -> Option<Vec<Vec3>> {
        let (xs, ys, zs) = (self.floats(x)?, self.floats(y)?, self.floats(z)?);
        Some(
            xs.iter()
                .zip(ys)
                .zip(zs)
                .map(|((&x, &y), &z)| Vec3::new(x, y, z))
                .collect(),
        )
    }
}

/// The PLY property types firn uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PropertyType {
    Float,
    UInt,
}

impl PropertyType {
    fn keyword(self) -> &'static str {
        match self {
            Self::Float => "float",
            Self::UInt => "uint",
        }
    }

    fn from_keyword(keyword: &str) -> Option<Self> {
        match keyword {
            "float" | "float32" => Some(Self::Float),
            "uint" | "uint32" => Some(Self::UInt),
            _ => None,
        }
    }
}

/// One `property` line of the vertex element.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Property {
    name: String,
    kind: PropertyType,
}

impl Property {
    fn float(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            kind: PropertyType::Float,
        }
    }
}

/// The property names of a vector attribute's three components.
fn vector_component_names(attribute: &str) -> [String; 3] {
    match attribute {
        "velocity" => ["vx", "vy", "vz"].map(String::from),
        "normal" => ["nx", "ny", "nz"].map(String::from),
        _ => ["x", "y", "z"].map(|axis| format!("{attribute}_{axis}")),
    }
}

/// The vertex properties of `frame`, in the order they are stored per vertex.
fn vertex_properties(frame: &FrameData) -> Vec<Property> {
    let mut properties: Vec<Property> = ["x", "y", "z"].map(Property::float).into();
    for attribute in &frame.attributes {
        match attribute.values {
            AttributeValues::Scalar(_) => properties.push(Property::float(&attribute.name)),
            AttributeValues::Vector(_) => {
                properties.extend(vector_component_names(&attribute.name).map(Property::float))
            }
            AttributeValues::Integer(_) => properties.push(Property {
                name: attribute.name.clone(),
                kind: PropertyType::UInt,
            }),
        }
    }
    properties
}

/// Rejects frames whose attributes map onto clashing properties (e.g. a scalar named "x").
fn ensure_unique_property_names(properties: &[Property]) -> Result<(), FrameError> {
    for (position, property) in properties.iter().enumerate() {
        if properties[..position]
            .iter()
            .any(|earlier| earlier.name == property.name)
        {
            return Err(FrameError::DuplicateName {
                name: property.name.clone(),
            });
        }
    }
    Ok(())
}

/// The complete ASCII header, `end_header` line included; `checksum` is
/// the CRC-32 of the vertex data.
fn header_text(frame: &FrameData, properties: &[Property], checksum: u32) -> String {
    let mut lines = vec![
        "ply".to_string(),
        "format binary_little_endian 1.0".to_string(),
        format!("comment firn frame {} time {}", frame.index, frame.time),
        format!("comment {CACHE_COMMENT} {CACHE_VERSION} crc32 {checksum:08x}"),
        format!("element vertex {}", frame.particle_count()),
    ];
    lines.extend(
        properties
            .iter()
            .map(|property| format!("property {} {}", property.kind.keyword(), property.name)),
    );
    lines.push("end_header\n".to_string());
    lines.join("\n")
}

/// Encodes the interleaved vertex records a chunk of vertices at a time and
/// hands each chunk to `take` (to hash it, then to write it).
fn for_each_chunk(
    frame: &FrameData,
    record_bytes: usize,
    mut take: impl FnMut(&[u8]) -> io::Result<()>,
) -> io::Result<()> {
    let mut chunk = Vec::with_capacity(CHUNK_VERTICES.min(frame.particle_count()) * record_bytes);
    for start in (0..frame.particle_count()).step_by(CHUNK_VERTICES) {
        let end = (start + CHUNK_VERTICES).min(frame.particle_count());
        chunk.clear();
        for vertex in start..end {
            append_vertex(&mut chunk, frame, vertex);
        }
        take(&chunk)?;
    }
    Ok(())
}

/// Appends one vertex record: position, then each attribute's value.
fn append_vertex(buffer: &mut Vec<u8>, frame: &FrameData, vertex: usize) {
    append_vec3(buffer, frame.positions[vertex]);
    for attribute in &frame.attributes {
        match attribute.values {
            AttributeValues::Scalar(values) => {
                buffer.extend_from_slice(&values.get(vertex).to_le_bytes())
            }
            AttributeValues::Vector(values) => append_vec3(buffer, values.get(vertex)),
            AttributeValues::Integer(values) => {
                buffer.extend_from_slice(&values.get(vertex).to_le_bytes())
            }
        }
    }
}

fn append_vec3(buffer: &mut Vec<u8>, value: Vec3) {
    for component in value.to_array() {
        buffer.extend_from_slice(&component.to_le_bytes());
    }
}

/// The parsed header: what the reader needs to decode the body.
struct Header {
    comments: Vec<String>,
    vertex_count: usize,
    properties: Vec<Property>,
}

fn decode_ply(bytes: &[u8]) -> Result<PlyCloud, String> {
    let (header_text, body) = split_header(bytes)?;
    let header = parse_header(header_text)?;
    check_cache_comment(&header.comments, body)?;
    let columns = decode_columns(&header, body)?;
    Ok(PlyCloud {
        comments: header.comments,
        vertex_count: header.vertex_count,
        columns,
    })
}

/// Splits the file into the header text (without `end_header`) and the body.
fn split_header(bytes: &[u8]) -> Result<(&str, &[u8]), String> {
    let header_end = bytes
        .windows(END_HEADER.len() + 1)
        .position(|window| window[0] == b'\n' && &window[1..] == END_HEADER)
        .ok_or("the header has no `end_header` line")?
        + 1;
    let header = std::str::from_utf8(&bytes[..header_end])
        .map_err(|_| "the header is not valid text".to_string())?;
    Ok((header, &bytes[header_end + END_HEADER.len()..]))
}

fn parse_header(text: &str) -> Result<Header, String> {
    let mut lines = text.lines();
    if lines.next() != Some("ply") {
        return Err("the file does not start with `ply`".into());
    }
    let mut header = Header {
        comments: Vec::new(),
        vertex_count: 0,
        properties: Vec::new(),
    };
    let mut format_seen = false;
    let mut vertex_element_seen = false;
    for line in lines {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            [] | ["obj_info", ..] => {}
            ["comment", ..] => header.comments.push(comment_text(line)),
            ["format", rest @ ..] => {
                check_format(rest)?;
                format_seen = true;
            }
            ["element", rest @ ..] if !vertex_element_seen => {
                header.vertex_count = parse_vertex_element(rest)?;
                vertex_element_seen = true;
            }
            ["element", ..] => return Err(format!("unsupported extra element: `{line}`")),
            ["property", rest @ ..] if vertex_element_seen => {
                header.properties.push(parse_property(rest)?);
            }
            ["property", ..] => return Err("a property precedes the vertex element".into()),
            _ => return Err(format!("unexpected header line `{line}`")),
        }
    }
    if !format_seen {
        return Err("the header has no `format` line".into());
    }
    Ok(header)
}

/// Checks firn's cache comment, if the file has one: a version this build
/// reads and the checksum of `body`.
fn check_cache_comment(comments: &[String], body: &[u8]) -> Result<(), String> {
    let Some(comment) = comments
        .iter()
        .find(|comment| comment.starts_with(CACHE_COMMENT))
    else {
        return Ok(());
    };
    let words: Vec<&str> = comment.split_whitespace().collect();
    let (version, stored) = match words.as_slice() {
        ["firn", "cache", version, "crc32", checksum] => (
            version.parse::<u32>().ok(),
            u32::from_str_radix(checksum, 16)
                .ok()
                .filter(|_| checksum.len() == 8),
        ),
        _ => (None, None),
    };
    let damaged = || format!("its header comment `{comment}` is damaged");
    match version {
        Some(CACHE_VERSION) => {}
        Some(newer) if newer > CACHE_VERSION => {
            return Err(format!(
                "it was written by a newer firn (cache version {newer}; this build reads \
                 {CACHE_VERSION})"
            ));
        }
        _ => return Err(damaged()),
    }
    let stored = stored.ok_or_else(damaged)?;
    let actual = crc32fast::hash(body);
    if actual == stored {
        Ok(())
    } else {
        Err(format!(
            "checksum mismatch: the vertex data has CRC-32 {actual:08x} but the header says \
             {stored:08x}, so the file is damaged or truncated"
        ))
    }
}

fn comment_text(line: &str) -> String {
    line.trim_start()
        .trim_start_matches("comment")
        .trim()
        .to_string()
}

fn check_format(words: &[&str]) -> Result<(), String> {
    match words {
        ["binary_little_endian", "1.0"] => Ok(()),
        _ => Err(format!(
            "only `binary_little_endian 1.0` is supported, found `{}`",
            words.join(" ")
        )),
    }
}

fn parse_vertex_element(words: &[&str]) -> Result<usize, String> {
    match words {
        ["vertex", count] => count
            .parse()
            .map_err(|_| format!("invalid vertex count `{count}`")),
        _ => Err(format!(
            "expected `element vertex <count>`, found `element {}`",
            words.join(" ")
        )),
    }
}

fn parse_property(words: &[&str]) -> Result<Property, String> {
    match words {
        [kind, name] => PropertyType::from_keyword(kind)
            .map(|kind| Property {
                name: name.to_string(),
                kind,
            })
            .ok_or_else(|| format!("unsupported property type `{kind}` for `{name}`")),
        _ => Err(format!(
            "unsupported property `property {}`",
            words.join(" ")
        )),
    }
}

/// Decodes the interleaved body into one column per property.
fn decode_columns(header: &Header, body: &[u8]) -> Result<Vec<PlyColumn>, String> {
    let record_bytes = header.properties.len() * PROPERTY_BYTES;
    let expected_bytes = header
        .vertex_count
        .checked_mul(record_bytes)
        .ok_or("the vertex count is implausibly large")?;
    if body.len() != expected_bytes {
        return Err(format!(
            "expected {expected_bytes} bytes of vertex data, found {}",
            body.len()
        ));
    }
    if record_bytes == 0 {
        return Ok(Vec::new());
    }
    let columns = header
        .properties
        .iter()
        .enumerate()
        .map(|(index, property)| PlyColumn {
            name: property.name.clone(),
            values: decode_column(body, record_bytes, index * PROPERTY_BYTES, property.kind),
        })
        .collect();
    Ok(columns)
}

fn decode_column(body: &[u8], record_bytes: usize, offset: usize, kind: PropertyType) -> PlyValues {
    let words = body.chunks_exact(record_bytes).map(|record| {
        u32::from_le_bytes([
            record[offset],
            record[offset + 1],
            record[offset + 2],
            record[offset + 3],
        ])
    });
    match kind {
        PropertyType::Float => PlyValues::Float(words.map(f32::from_bits).collect()),
        PropertyType::UInt => PlyValues::UInt(words.collect()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Attribute;

    fn header_lines(path: &Path) -> Vec<String> {
        let bytes = fs::read(path).unwrap();
        let (header, _) = split_header(&bytes).unwrap();
        header.lines().map(String::from).collect()
    }

    fn bits(values: &[f32]) -> Vec<u32> {
        values.iter().map(|value| value.to_bits()).collect()
    }

    fn vec3_bits(values: &[Vec3]) -> Vec<u32> {
        values
            .iter()
            .flat_map(|value| value.to_array())
            .map(f32::to_bits)
            .collect()
    }

    #[test]
    fn written_frames_read_back_bit_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frame.ply");
        let count = CHUNK_VERTICES + 7;
        let positions: Vec<Vec3> = (0..count)
            .map(|i| Vec3::new(i as f32, -(i as f32) * 0.5, 1.0 / (i as f32 + 1.0)))
            .collect();
        let velocity: Vec<Vec3> = positions.iter().map(|p| *p * 3.0).collect();
        let mut jp: Vec<f32> = (0..count).map(|i| 1.0 - i as f32 * 1e-6).collect();
        jp[3] = f32::from_bits(0x7fc0_1234);
        let phase: Vec<u32> = (0..count as u32).map(|i| i % 3).collect();
        let frame = FrameData::new(12, 0.5, &positions)
            .with_attribute(Attribute::vector("velocity", &velocity))
            .with_attribute(Attribute::scalar("jp", &jp))
            .with_attribute(Attribute::integer("phase", &phase));

        write_ply(&path, &frame).unwrap();
        let cloud = read_ply(&path).unwrap();

        assert_eq!(cloud.vertex_count, count);
        assert_eq!(
            vec3_bits(&cloud.positions().unwrap()),
            vec3_bits(&positions)
        );
        assert_eq!(
            vec3_bits(&cloud.vector("velocity").unwrap()),
            vec3_bits(&velocity)
        );
        assert_eq!(bits(cloud.floats("jp").unwrap()), bits(&jp));
        assert_eq!(cloud.uints("phase").unwrap(), phase.as_slice());
        assert_eq!(cloud.comments[0], "firn frame 12 time 0.5");
        assert!(cloud.comments[1].starts_with("firn cache 1 crc32 "));
    }

    #[test]
    fn the_header_lists_the_expected_properties() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frame.ply");
        let positions = [Vec3::ONE];
        let velocity = [Vec3::X];
        let stress = [Vec3::Y];
        let density = [400.0];
        let id = [7];
        let frame = FrameData::new(3, 0.125, &positions)
            .with_attribute(Attribute::vector("velocity", &velocity))
            .with_attribute(Attribute::vector("stress", &stress))
            .with_attribute(Attribute::scalar("density", &density))
            .with_attribute(Attribute::integer("id", &id));

        write_ply(&path, &frame).unwrap();

        let bytes = fs::read(&path).unwrap();
        let body = &bytes[bytes.len() - 11 * PROPERTY_BYTES..];
        let checksum = format!("comment firn cache 1 crc32 {:08x}", crc32fast::hash(body));
        assert_eq!(
            header_lines(&path),
            [
                "ply",
                "format binary_little_endian 1.0",
                "comment firn frame 3 time 0.125",
                checksum.as_str(),
                "element vertex 1",
                "property float x",
                "property float y",
                "property float z",
                "property float vx",
                "property float vy",
                "property float vz",
                "property float stress_x",
                "property float stress_y",
                "property float stress_z",
                "property float density",
                "property uint id",
            ]
        );
        let file_length = fs::metadata(&path).unwrap().len() as usize;
        let header_length: usize = header_lines(&path).iter().map(|line| line.len() + 1).sum();
        assert_eq!(
            file_length,
            header_length + END_HEADER.len() + 11 * PROPERTY_BYTES
        );
    }

    #[test]
    fn an_empty_frame_is_a_valid_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.ply");
        let frame = FrameData::new(0, 0.0, &[]).with_attribute(Attribute::scalar("jp", &[]));

        write_ply(&path, &frame).unwrap();

        assert!(fs::read(&path).unwrap().ends_with(b"\nend_header\n"));
        assert!(header_lines(&path).contains(&"element vertex 0".to_string()));
        let cloud = read_ply(&path).unwrap();
        assert_eq!(cloud.vertex_count, 0);
        assert_eq!(cloud.positions().unwrap(), Vec::<Vec3>::new());
        assert_eq!(cloud.floats("jp").unwrap(), &[] as &[f32]);
    }

    #[test]
    fn a_mismatched_attribute_is_an_error_and_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frame.ply");
        let positions = [Vec3::ZERO, Vec3::ONE];
        let frame =
            FrameData::new(0, 0.0, &positions).with_attribute(Attribute::scalar("jp", &[1.0]));

        let error = write_ply(&path, &frame).unwrap_err();

        assert_eq!(
            error.to_string(),
            format!(
                "cannot write {}: attribute `jp` has 1 values but the frame has 2 particles",
                path.display()
            )
        );
        assert!(!path.exists());
    }

    #[test]
    fn an_attribute_clashing_with_a_position_column_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let positions = [Vec3::ZERO];
        let frame =
            FrameData::new(0, 0.0, &positions).with_attribute(Attribute::scalar("y", &[1.0]));
        let error = write_ply(&dir.path().join("frame.ply"), &frame).unwrap_err();
        assert!(matches!(
            error,
            IoError::InvalidFrame {
                problem: FrameError::DuplicateName { .. },
                ..
            }
        ));
    }

    #[test]
    fn a_truncated_file_is_rejected() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frame.ply");
        let positions = [Vec3::ZERO, Vec3::ONE];
        write_ply(&path, &FrameData::new(0, 0.0, &positions)).unwrap();
        let bytes = fs::read(&path).unwrap();
        fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();

        let message = read_ply(&path).unwrap_err().to_string();

        assert!(message.contains("checksum mismatch"), "{message}");
    }

    #[test]
    fn a_flipped_bit_in_the_vertex_data_fails_the_checksum() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frame.ply");
        let positions = [Vec3::ZERO, Vec3::ONE];
        write_ply(&path, &FrameData::new(0, 0.0, &positions)).unwrap();
        let mut bytes = fs::read(&path).unwrap();
        let last = bytes.len() - 1;
        bytes[last] ^= 0x01;
        fs::write(&path, &bytes).unwrap();

        let message = read_ply(&path).unwrap_err().to_string();

        assert!(
            message.starts_with(&path.display().to_string()),
            "{message}"
        );
        assert!(
            message.contains("checksum mismatch: the vertex data has CRC-32"),
            "{message}"
        );
    }

    #[test]
    fn a_cache_of_a_newer_layout_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frame.ply");
        write_ply(&path, &FrameData::new(0, 0.0, &[Vec3::ONE])).unwrap();
        let mut bytes = fs::read(&path).unwrap();
        let tag = b"firn cache 1 ";
        let at = bytes
            .windows(tag.len())
            .position(|window| window == tag)
            .expect("the cache comment is in the header");
        bytes[at + tag.len() - 2] = b'2';
        fs::write(&path, &bytes).unwrap();

        let message = read_ply(&path).unwrap_err().to_string();

        assert!(
            message.contains("written by a newer firn (cache version 2; this build reads 1)"),
            "{message}"
        );
    }

    #[test]
    fn a_file_without_the_cache_comment_is_read_unchecked() {
        let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 1\n\
                          property float x\nend_header\n"
            .to_vec();
        bytes.extend_from_slice(&2.5f32.to_le_bytes());
        let cloud = parse_ply(&bytes, Path::new("other.ply")).unwrap();
        assert_eq!(cloud.floats("x").unwrap(), [2.5]);
    }

    #[test]
    fn ascii_files_are_rejected_with_the_reason() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ascii.ply");
        fs::write(
            &path,
            "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n",
        )
        .unwrap();
        let message = read_ply(&path).unwrap_err().to_string();
        assert!(message.contains("found `ascii 1.0`"), "{message}");
    }
}
