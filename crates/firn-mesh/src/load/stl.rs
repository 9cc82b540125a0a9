//! STL, ASCII or binary. A file is binary when its size is exactly
//! 84 + 50·n bytes for the n triangles its header announces, even if it
//! starts with "solid" (many exporters write that into binary headers).
//! STL repeats every corner, so identical positions are merged into shared
//! vertices, which makes edges and holes visible to the diagnostics.

use std::collections::HashMap;

use glam::Vec3;

use super::{Faces, ParseError, finite, point};
use crate::TriangleMesh;

const HEADER: usize = 84;
const RECORD: usize = 50;

pub(super) fn parse(bytes: &[u8]) -> Result<TriangleMesh, ParseError> {
    if let Some(count) = binary_triangle_count(bytes) {
        return parse_binary(bytes, count);
    }
    if bytes.trim_ascii_start().starts_with(b"solid") {
        return parse_ascii(&String::from_utf8_lossy(bytes));
    }
    Err(size_mismatch(bytes))
}

/// The triangle count if the size matches the binary layout exactly.
fn binary_triangle_count(bytes: &[u8]) -> Option<usize> {
    let count = u32::from_le_bytes(bytes.get(80..HEADER)?.try_into().ok()?) as usize;
    let expected = (count as u64) * RECORD as u64 + HEADER as u64;
    (expected == bytes.len() as u64).then_some(count)
}

fn size_mismatch(bytes: &[u8]) -> ParseError {
    let message = match bytes.get(80..HEADER) {
        None => format!(
            "the file has {} bytes: too short for a binary STL (84 bytes at least) and it does not start with 'solid' like an ASCII STL",
            bytes.len()
        ),
        Some(count) => {
            let count = u32::from_le_bytes([count[0], count[1], count[2], count[3]]);
            format!(
                "the binary STL header announces {count} triangles ({} bytes), but the file has {} bytes",
                count as u64 * RECORD as u64 + HEADER as u64,
                bytes.len()
            )
        }
    };
    ParseError::new(
        None,
        message,
        "the file is truncated or not an STL file; export it again",
    )
}

fn parse_binary(bytes: &[u8], count: usize) -> Result<TriangleMesh, ParseError> {
    let mut welder = Welder::default();
    let mut faces = Faces::default();
    for (i, record) in bytes[HEADER..].chunks_exact(RECORD).take(count).enumerate() {
        let what = || format!("triangle {} (at byte {})", i + 1, HEADER + i * RECORD);
        let mut corners = [0u32; 3];
        for (corner, chunk) in corners.iter_mut().zip(record[12..48].chunks_exact(12)) {
            let mut xyz = [0.0f32; 3];
            for (value, bytes) in xyz.iter_mut().zip(chunk.chunks_exact(4)) {
                let raw = f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
                *value = finite(raw, None, &what)?;
            }
            *corner = welder.index(Vec3::from_array(xyz));
        }
        faces.add(&corners, faces.next_source(None));
    }
    faces.into_mesh(welder.vertices)
}

fn parse_ascii(text: &str) -> Result<TriangleMesh, ParseError> {
    let mut reader = AsciiReader::default();
    for (number, line) in text.lines().enumerate() {
        reader.read(line, number + 1)?;
    }
    reader.finish()
}

/// The state of the ASCII parser: the mesh so far and the open facet.
#[derive(Default)]
struct AsciiReader {
    welder: Welder,
    faces: Faces,
    facet: Option<Facet>,
    line: usize,
}

/// A facet that started on `line`, with the corners read so far.
struct Facet {
    line: usize,
    corners: Vec<u32>,
}

impl AsciiReader {
    fn read(&mut self, text: &str, line: usize) -> Result<(), ParseError> {
        self.line = line;
        let at = Some(line);
        let mut tokens = text.split_whitespace();
        match (tokens.next(), self.facet.take()) {
            (None | Some("solid" | "outer" | "endloop"), facet) => self.facet = facet,
            (Some("endsolid"), None) => {}
            (Some("facet"), None) => {
                self.facet = Some(Facet {
                    line,
                    corners: Vec::new(),
                })
            }
            (Some("vertex"), Some(mut open)) => {
                let what = || format!("a vertex of facet {}", self.faces.count + 1);
                let corner = point(tokens, at, &what, "vertex x y z")?;
                open.corners.push(self.welder.index(corner));
                self.facet = Some(open);
            }
            (Some("endfacet"), Some(open)) => self.end_facet(open)?,
            (Some(keyword @ ("vertex" | "endfacet")), None) => {
                return Err(ParseError::new(
                    at,
                    format!("'{keyword}' outside a facet"),
                    "start every facet with a `facet normal nx ny nz` line",
                ));
            }
            (Some(keyword @ ("facet" | "endsolid")), Some(open)) => {
                return Err(ParseError::new(
                    at,
                    format!(
                        "'{keyword}' inside the facet that starts on line {}",
                        open.line
                    ),
                    "close every facet with `endloop` and `endfacet` first",
                ));
            }
            (Some(other), _) => return Err(unexpected(other, at)),
        }
        Ok(())
    }

    fn end_facet(&mut self, open: Facet) -> Result<(), ParseError> {
        if open.corners.len() < 3 {
            return Err(ParseError::new(
                Some(self.line),
                format!(
                    "facet {} has {} vertices; it needs three",
                    self.faces.count + 1,
                    open.corners.len()
                ),
                "give every facet an outer loop with three `vertex x y z` lines",
            ));
        }
        self.faces
            .add(&open.corners, self.faces.next_source(Some(open.line)));
        Ok(())
    }

    fn finish(self) -> Result<TriangleMesh, ParseError> {
        if let Some(open) = self.facet {
            return Err(ParseError::new(
                Some(self.line.max(1)),
                format!(
                    "the file ends inside the facet that starts on line {}",
                    open.line
                ),
                "the file is truncated; export it again",
            ));
        }
        self.faces.into_mesh(self.welder.vertices)
    }
}

fn unexpected(token: &str, line: Option<usize>) -> ParseError {
    let shown: String = token.chars().take(40).collect();
    ParseError::new(
        line,
        format!("unexpected '{shown}' in an ASCII STL"),
        "ASCII STL lines start with solid, facet, outer, vertex, endloop, endfacet or endsolid; \
         the file is damaged, or it is a binary STL whose size does not match its triangle count",
    )
}

/// Merges corners with bit-identical positions into shared vertices,
/// numbered in order of first appearance.
#[derive(Default)]
struct Welder {
    indices: HashMap<[u32; 3], u32>,
    vertices: Vec<Vec3>,
}

impl Welder {
    fn index(&mut self, position: Vec3) -> u32 {
        let key = (position + Vec3::ZERO).to_array().map(f32::to_bits);
        *self.indices.entry(key).or_insert_with(|| {
            self.vertices.push(position);
            (self.vertices.len() - 1) as u32
        })
    }
}
