//! VTK XML PolyData (`.vtp`) particle caches and the `.pvd` collection that
//! gives ParaView its time slider.
//!
//! Each particle is a point plus a vertex cell, so ParaView renders the cloud
//! without a Glyph filter. Arrays are stored inline as `format="binary"`: the
//! base64 encoding of a `UInt64` byte count followed by the raw little-endian
//! data, as the VTK XML format specifies for `header_type="UInt64"`.

use std::fs;
use std::io::{self, Write};
use std::path::Path;

use base64::engine::general_purpose::STANDARD;
use base64::write::EncoderWriter;
use glam::Vec3;

use crate::IoError;
use crate::atomic::write_atomically;
use crate::frame::{AttributeValues, FrameData, Values};
use crate::xml;

/// Cell indices generated per buffer when streaming the vertex cells.
const INDEX_CHUNK: usize = 64 * 1024;

/// Writes `frame` as a VTK XML PolyData file, atomically.
///
/// Points are `Float32` triples; every attribute becomes a `PointData` array
/// named after it (`Float32` scalars, 3-component `Float32` vectors, `UInt32`
/// integers); the frame time is stored as the `TimeValue` field ParaView reads.
pub fn write_vtp(path: &Path, frame: &FrameData) -> Result<(), IoError> {
    frame.validate().map_err(|problem| IoError::InvalidFrame {
        path: path.to_path_buf(),
        problem,
    })?;
    write_atomically(path, |out| write_polydata(out, frame))
}

/// One `DataSet` of a `.pvd` collection: a time and the file holding it.
#[derive(Debug, Clone, PartialEq)]
pub struct PvdEntry {
    /// Simulation time in seconds.
    pub time: f64,
    /// Which piece of the frame the file holds (0 for a frame in one file;
    /// a run split between MPI ranks writes one piece per rank).
    pub part: u32,
    /// Path of the frame's file, relative to the `.pvd` file.
    pub file: String,
}

/// The `.pvd` time series of a run, rewritten whole after every frame so that
/// ParaView can follow a run in progress.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PvdCollection {
    entries: Vec<PvdEntry>,
}

impl PvdCollection {
    /// An empty collection.
    pub fn new() -> Self {
        Self::default()
    }

    /// The entries in time order.
    pub fn entries(&self) -> &[PvdEntry] {
        &self.entries
    }

    /// Records `file` at `time`, replacing an earlier entry for the same file
    /// and keeping the entries in time order.
    pub fn push(&mut self, time: f64, file: impl Into<String>) {
        self.push_part(time, 0, file);
    }

    /// Records `file` as piece `part` of the frame at `time`, replacing an
    /// earlier entry for the same file and keeping the entries in time
    /// order (the pieces of a frame in the order pushed).
    pub fn push_part(&mut self, time: f64, part: u32, file: impl Into<String>) {
        let file = file.into();
        self.entries.retain(|entry| entry.file != file);
        let position = self
            .entries
            .partition_point(|entry| entry.time.total_cmp(&time).is_le());
        self.entries.insert(position, PvdEntry { time, part, file });
    }

    /// Drops entries later than `time`, e.g. frames a resumed run will redo.
    pub fn remove_after(&mut self, time: f64) {
        self.entries.retain(|entry| entry.time <= time);
    }

    /// Writes the collection to `path`, atomically.
    pub fn write(&self, path: &Path) -> Result<(), IoError> {
        write_atomically(path, |out| out.write_all(self.to_xml().as_bytes()))
    }

    /// Loads the entries of an existing `.pvd` file, e.g. when resuming a run.
    pub fn read(path: &Path) -> Result<Self, IoError> {
        let text = fs::read_to_string(path).map_err(|source| IoError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_xml(&text).map_err(|reason| IoError::InvalidPvd {
            path: path.to_path_buf(),
            reason,
        })
    }

    fn to_xml(&self) -> String {
        let mut lines = vec![
            r#"<?xml version="1.0"?>"#.to_string(),
            r#"<VTKFile type="Collection" version="1.0" byte_order="LittleEndian">"#.to_string(),
            "  <Collection>".to_string(),
        ];
        lines.extend(self.entries.iter().map(|entry| {
            format!(
                r#"    <DataSet timestep="{}" group="" part="{}" file="{}"/>"#,
                entry.time,
                entry.part,
                xml::escape(&entry.file)
            )
        }));
        lines.push("  </Collection>".to_string());
        lines.push("</VTKFile>\n".to_string());
        lines.join("\n")
    }

    fn from_xml(text: &str) -> Result<Self, String> {
        let root = xml::elements_named(text, "VTKFile")?;
        if root.first().and_then(|file| file.attribute("type")) != Some("Collection") {
            return Err("the root is not a VTKFile of type Collection".into());
        }
        let body = xml::elements_named(text, "Collection")?
            .first()
            .map(|collection| collection.text)
            .ok_or("the file has no Collection element")?;
        let mut collection = Self::new();
        for data_set in xml::elements_named(body, "DataSet")? {
            let entry = parse_entry(&data_set)?;
            collection.push_part(entry.time, entry.part, entry.file);
        }
        Ok(collection)
    }
}

fn parse_entry(data_set: &xml::Element) -> Result<PvdEntry, String> {
    let required = |name| {
        data_set
            .attribute(name)
            .ok_or_else(|| format!("a DataSet has no `{name}` attribute"))
    };
    let timestep = required("timestep")?;
    let time = timestep
        .parse()
        .map_err(|_| format!("invalid timestep `{timestep}`"))?;
    let part = match data_set.attribute("part") {
        None => 0,
        Some(part) => part.parse().map_err(|_| format!("invalid part `{part}`"))?,
    };
    Ok(PvdEntry {
        time,
        part,
        file: required("file")?.to_string(),
    })
}

/// The bytes an inline binary array holds.
enum Payload<'a> {
    /// Raw little-endian values.
    Bytes(&'a [u8]),
    /// An attribute's floats, stored or computed while writing.
    Floats(Values<'a, f32>),
    /// An attribute's vectors, stored or computed while writing.
    Vectors(Values<'a, Vec3>),
    /// An attribute's unsigned integers, stored or computed while writing.
    Words(Values<'a, u32>),
    /// `len` consecutive `Int64` values starting at `first`, generated while writing.
    Int64Run { first: i64, len: usize },
}

impl Payload<'_> {
    fn byte_len(&self) -> usize {
        match self {
            Self::Bytes(bytes) => bytes.len(),
            Self::Floats(values) => values.len() * size_of::<f32>(),
            Self::Vectors(values) => values.len() * size_of::<Vec3>(),
            Self::Words(values) => values.len() * size_of::<u32>(),
            Self::Int64Run { len, .. } => len * size_of::<i64>(),
        }
    }

    fn write_to(&self, out: &mut dyn Write) -> io::Result<()> {
        match self {
            Self::Bytes(bytes) => out.write_all(bytes),
            Self::Floats(values) => write_values(out, values),
            Self::Vectors(values) => write_values(out, values),
            Self::Words(values) => write_values(out, values),
            Self::Int64Run { first, len } => write_int64_run(out, *first, *len),
        }
    }
}

/// Streams `values` as raw little-endian bytes, a chunk at a time.
fn write_values<T: bytemuck::Pod>(out: &mut dyn Write, values: &Values<T>) -> io::Result<()> {
    values.try_for_each_chunk(|chunk| out.write_all(bytemuck::cast_slice(chunk)))
}

/// An inline `DataArray` element.
struct DataArray<'a> {
    vtk_type: &'static str,
    name: &'a str,
    components: usize,
    tuples: usize,
    payload: Payload<'a>,
}

impl DataArray<'_> {
    fn write_to(&self, out: &mut dyn Write, indent: &str) -> io::Result<()> {
        write!(
            out,
            r#"{indent}<DataArray type="{}" Name="{}" NumberOfComponents="{}" NumberOfTuples="{}" format="binary">"#,
            self.vtk_type,
            xml::escape(self.name),
            self.components,
            self.tuples
        )?;
        write_base64_block(out, &self.payload)?;
        writeln!(out, "</DataArray>")
    }
}

fn write_polydata(out: &mut dyn Write, frame: &FrameData) -> io::Result<()> {
    let count = frame.particle_count();
    writeln!(out, r#"<?xml version="1.0"?>"#)?;
    writeln!(
        out,
        r#"<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">"#
    )?;
    writeln!(out, "  <PolyData>")?;
    write_time_field(out, frame.time)?;
    writeln!(
        out,
        r#"    <Piece NumberOfPoints="{count}" NumberOfVerts="{count}" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="0">"#
    )?;
    write_point_data(out, frame)?;
    write_points(out, frame)?;
    write_vertex_cells(out, count)?;
    writeln!(out, "    </Piece>")?;
    writeln!(out, "  </PolyData>")?;
    writeln!(out, "</VTKFile>")
}

fn write_time_field(out: &mut dyn Write, time: f64) -> io::Result<()> {
    writeln!(out, "    <FieldData>")?;
    let time_bytes = time.to_le_bytes();
    DataArray {
        vtk_type: "Float64",
        name: "TimeValue",
        components: 1,
        tuples: 1,
        payload: Payload::Bytes(&time_bytes),
    }
    .write_to(out, "      ")?;
    writeln!(out, "    </FieldData>")
}

fn write_point_data(out: &mut dyn Write, frame: &FrameData) -> io::Result<()> {
    writeln!(out, "      <PointData>")?;
    for attribute in &frame.attributes {
        let (vtk_type, components, payload) = match attribute.values {
            AttributeValues::Scalar(values) => ("Float32", 1, Payload::Floats(values)),
            AttributeValues::Vector(values) => ("Float32", 3, Payload::Vectors(values)),
            AttributeValues::Integer(values) => ("UInt32", 1, Payload::Words(values)),
        };
        DataArray {
            vtk_type,
            name: &attribute.name,
            components,
            tuples: frame.particle_count(),
            payload,
        }
        .write_to(out, "        ")?;
    }
    writeln!(out, "      </PointData>")
}

fn write_points(out: &mut dyn Write, frame: &FrameData) -> io::Result<()> {
    writeln!(out, "      <Points>")?;
    DataArray {
        vtk_type: "Float32",
        name: "Points",
        components: 3,
        tuples: frame.particle_count(),
        payload: Payload::Bytes(bytemuck::cast_slice(frame.positions)),
    }
    .write_to(out, "        ")?;
    writeln!(out, "      </Points>")
}

/// One vertex cell per point: connectivity `0..n`, offsets `1..=n`.
fn write_vertex_cells(out: &mut dyn Write, count: usize) -> io::Result<()> {
    writeln!(out, "      <Verts>")?;
    for (name, first) in [("connectivity", 0), ("offsets", 1)] {
        DataArray {
            vtk_type: "Int64",
            name,
            components: 1,
            tuples: count,
            payload: Payload::Int64Run { first, len: count },
        }
        .write_to(out, "        ")?;
    }
    writeln!(out, "      </Verts>")
}

/// Writes `base64([u64 byte count][payload])` as one continuous block.
fn write_base64_block(out: &mut dyn Write, payload: &Payload) -> io::Result<()> {
    let mut encoder = EncoderWriter::new(out, &STANDARD);
    encoder.write_all(&(payload.byte_len() as u64).to_le_bytes())?;
    payload.write_to(&mut encoder)?;
    encoder.finish()?;
    Ok(())
}

/// Streams `len` consecutive `Int64` values in chunks instead of materialising them.
fn write_int64_run(out: &mut dyn Write, first: i64, len: usize) -> io::Result<()> {
    let mut values = (first..).take(len);
    let mut chunk: Vec<i64> = Vec::with_capacity(len.min(INDEX_CHUNK));
    loop {
        chunk.clear();
        chunk.extend(values.by_ref().take(INDEX_CHUNK));
        if chunk.is_empty() {
            return Ok(());
        }
        out.write_all(bytemuck::cast_slice(&chunk))?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Attribute;
    use base64::Engine;

    /// Decodes an inline binary block into its header count and data bytes.
    fn decode_block(text: &str) -> (u64, Vec<u8>) {
        let bytes = STANDARD.decode(text.trim()).unwrap();
        let (header, data) = bytes.split_at(8);
        (
            u64::from_le_bytes(header.try_into().unwrap()),
            data.to_vec(),
        )
    }

    fn data_array<'t>(document: &'t str, name: &str) -> xml::Element<'t> {
        xml::elements_named(document, "DataArray")
            .unwrap()
            .into_iter()
            .find(|array| array.attribute("Name") == Some(name))
            .unwrap_or_else(|| panic!("no DataArray named {name}"))
    }

    fn write_sample(path: &Path, positions: &[Vec3], velocity: &[Vec3], jp: &[f32], id: &[u32]) {
        let frame = FrameData::new(4, 0.16, positions)
            .with_attribute(Attribute::vector("velocity", velocity))
            .with_attribute(Attribute::scalar("jp", jp))
            .with_attribute(Attribute::integer("id", id));
        write_vtp(path, &frame).unwrap();
    }

    #[test]
    fn the_polydata_file_describes_points_cells_and_attributes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frame.vtp");
        let count = INDEX_CHUNK + 5;
        let positions: Vec<Vec3> = (0..count).map(|i| Vec3::splat(i as f32)).collect();
        let velocity: Vec<Vec3> = (0..count)
            .map(|i| Vec3::new(0.0, -(i as f32), 1.0))
            .collect();
        let jp: Vec<f32> = (0..count).map(|i| 1.0 + i as f32 * 1e-3).collect();
        let id: Vec<u32> = (0..count as u32).collect();
        write_sample(&path, &positions, &velocity, &jp, &id);
        let document = fs::read_to_string(&path).unwrap();

        assert!(document.contains(
            r#"<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">"#
        ));
        let piece = &xml::elements_named(&document, "Piece").unwrap()[0];
        assert_eq!(
            piece.attribute("NumberOfPoints"),
            Some(count.to_string().as_str())
        );
        assert_eq!(
            piece.attribute("NumberOfVerts"),
            Some(count.to_string().as_str())
        );
        let names: Vec<String> = xml::elements_named(&document, "DataArray")
            .unwrap()
            .iter()
            .map(|array| array.attribute("Name").unwrap().to_string())
            .collect();
        assert_eq!(
            names,
            [
                "TimeValue",
                "velocity",
                "jp",
                "id",
                "Points",
                "connectivity",
                "offsets"
            ]
        );

        let velocity_array = data_array(&document, "velocity");
        assert_eq!(velocity_array.attribute("type"), Some("Float32"));
        assert_eq!(velocity_array.attribute("NumberOfComponents"), Some("3"));
        let (byte_count, data) = decode_block(velocity_array.text);
        assert_eq!(byte_count, (count * 12) as u64);
        assert_eq!(data.len(), count * 12);
        let second_y = f32::from_le_bytes(data[16..20].try_into().unwrap());
        assert_eq!(second_y, -1.0);

        let (_, id_data) = decode_block(data_array(&document, "id").text);
        let decoded_ids: Vec<u32> = id_data
            .chunks_exact(4)
            .map(|word| u32::from_le_bytes(word.try_into().unwrap()))
            .collect();
        assert_eq!(decoded_ids, id);

        let (offsets_bytes, offsets) = decode_block(data_array(&document, "offsets").text);
        assert_eq!(offsets_bytes, (count * 8) as u64);
        let first_offsets: [i64; 3] = bytemuck::pod_read_unaligned(&offsets[..24]);
        assert_eq!(first_offsets, [1, 2, 3]);
        let last_offset: i64 = bytemuck::pod_read_unaligned(&offsets[offsets.len() - 8..]);
        assert_eq!(last_offset, count as i64);

        let (_, time) = decode_block(data_array(&document, "TimeValue").text);
        assert_eq!(f64::from_le_bytes(time.try_into().unwrap()), 0.16);
    }

    #[test]
    fn an_empty_frame_has_empty_arrays() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.vtp");
        write_sample(&path, &[], &[], &[], &[]);
        let document = fs::read_to_string(&path).unwrap();

        let piece = &xml::elements_named(&document, "Piece").unwrap()[0];
        assert_eq!(piece.attribute("NumberOfPoints"), Some("0"));
        let (byte_count, data) = decode_block(data_array(&document, "Points").text);
        assert_eq!((byte_count, data.len()), (0, 0));
    }

    #[test]
    fn a_mismatched_attribute_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frame.vtp");
        let positions = [Vec3::ZERO];
        let frame =
            FrameData::new(0, 0.0, &positions).with_attribute(Attribute::integer("id", &[]));
        assert!(matches!(
            write_vtp(&path, &frame),
            Err(IoError::InvalidFrame { .. })
        ));
        assert!(!path.exists());
    }

    #[test]
    fn the_collection_lists_entries_in_time_order() {
        let mut collection = PvdCollection::new();
        collection.push(0.2, "frames/frame_0002.vtp");
        collection.push(0.0, "frames/frame_0000.vtp");
        collection.push(0.1, "frames/frame_0001.vtp");
        let xml_text = collection.to_xml();

        let data_sets = xml::elements_named(&xml_text, "DataSet").unwrap();
        let listed: Vec<(&str, &str)> = data_sets
            .iter()
            .map(|set| {
                (
                    set.attribute("timestep").unwrap(),
                    set.attribute("file").unwrap(),
                )
            })
            .collect();
        assert_eq!(
            listed,
            [
                ("0", "frames/frame_0000.vtp"),
                ("0.1", "frames/frame_0001.vtp"),
                ("0.2", "frames/frame_0002.vtp"),
            ]
        );
    }

    #[test]
    fn the_collection_round_trips_through_its_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.pvd");
        let mut collection = PvdCollection::new();
        collection.push(0.04, "frame_0001.vtp");
        collection.push(0.08, "odd & \"quoted\".vtp");
        collection.push_part(0.08, 1, "frame_0002_rank_0001.vtp");
        collection.write(&path).unwrap();
        let text = fs::read_to_string(&path).unwrap();
        assert!(
            text.contains(r#"part="1" file="frame_0002_rank_0001.vtp""#),
            "{text}"
        );

        assert_eq!(PvdCollection::read(&path).unwrap(), collection);
    }

    #[test]
    fn pushing_a_file_again_replaces_it_and_remove_after_trims_the_tail() {
        let mut collection = PvdCollection::new();
        for frame in 0..4 {
            collection.push(frame as f64, format!("frame_{frame}.vtp"));
        }
        collection.push(1.5, "frame_1.vtp");
        collection.remove_after(2.0);
        let files: Vec<&str> = collection
            .entries()
            .iter()
            .map(|entry| entry.file.as_str())
            .collect();
        assert_eq!(files, ["frame_0.vtp", "frame_1.vtp", "frame_2.vtp"]);
    }

    #[test]
    fn reading_a_non_collection_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.pvd");
        fs::write(&path, r#"<VTKFile type="PolyData"></VTKFile>"#).unwrap();
        let message = PvdCollection::read(&path).unwrap_err().to_string();
        assert!(message.contains("not a valid PVD collection"), "{message}");
    }
}
