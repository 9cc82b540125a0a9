//! Mesh file loaders: OBJ, STL (ASCII and binary) and PLY (ASCII and
//! binary), hand-written so that every problem is reported with its line,
//! what is wrong and how to fix it, and so no input can make them panic.

mod obj;
mod ply;
mod stl;

use std::path::Path;

use glam::Vec3;

use crate::{MeshDiagnostics, MeshError, TriangleMesh};

/// A loaded mesh with what is wrong with it, so callers can print
/// [`MeshDiagnostics::warnings`] next to the scene that uses it.
#[derive(Clone, Debug)]
pub struct LoadedMesh {
    /// The triangles, polygons fan-triangulated.
    pub mesh: TriangleMesh,
    /// Its holes, non-manifold edges, degenerate triangles, flipped faces
    /// and parts.
    pub diagnostics: MeshDiagnostics,
}

/// Loads a `.obj`, `.stl` or `.ply` file (the extension in any case picks
/// the format) and diagnoses it. Errors name the file, the line for text
/// formats, the problem and a fix; no input makes it panic.
pub fn load_mesh(path: &Path) -> Result<LoadedMesh, MeshError> {
    let fail = |e: ParseError| located(path, e);
    Format::of(path).map_err(fail)?;
    let bytes = read_bounded(path).map_err(fail)?;
    load_mesh_bytes(&bytes, path)
}

/// Parses and diagnoses the bytes of a mesh file named `path` (its
/// extension picks the format; it is named in errors), as [`load_mesh`]
/// does once it has read them.
pub fn load_mesh_bytes(bytes: &[u8], path: &Path) -> Result<LoadedMesh, MeshError> {
    let fail = |e: ParseError| located(path, e);
    let format = Format::of(path).map_err(fail)?;
    let mesh = parse(bytes, format).map_err(fail)?;
    let diagnostics = MeshDiagnostics::of(&mesh);
    Ok(LoadedMesh { mesh, diagnostics })
}

/// Largest mesh file firn reads (1 GiB): some 20 million triangles of
/// binary STL. The file is read no further, so a device or a pipe that
/// never ends cannot hold a scene check up.
pub const MAX_MESH_FILE_BYTES: u64 = 1 << 30;

/// The whole file, unless it passes [`MAX_MESH_FILE_BYTES`].
fn read_bounded(path: &Path) -> Result<Vec<u8>, ParseError> {
    use std::io::Read;
    let cannot_read = |e: std::io::Error| {
        ParseError::new(
            None,
            format!("cannot read the file: {e}"),
            "check that the path is right and the file is readable",
        )
    };
    let file = std::fs::File::open(path).map_err(cannot_read)?;
    let mut bytes = Vec::new();
    file.take(MAX_MESH_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(cannot_read)?;
    if bytes.len() as u64 > MAX_MESH_FILE_BYTES {
        return Err(ParseError::new(
            None,
            format!(
                "the file is larger than {MAX_MESH_FILE_BYTES} bytes (1 GiB), the most firn reads"
            ),
            "decimate the mesh (e.g. MeshLab's quadric edge collapse or Blender's Decimate \
             modifier); snow needs no more detail than a grid cell",
        ));
    }
    Ok(bytes)
}

/// A parse error with the file attached.
fn located(path: &Path, error: ParseError) -> MeshError {
    MeshError {
        path: path.to_path_buf(),
        line: error.line,
        message: error.message,
        hint: error.hint,
    }
}

/// The supported file formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Obj,
    Stl,
    Ply,
}

impl Format {
    fn of(path: &Path) -> Result<Format, ParseError> {
        let extension = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match extension.as_deref() {
            Some("obj") => Ok(Format::Obj),
            Some("stl") => Ok(Format::Stl),
            Some("ply") => Ok(Format::Ply),
            other => Err(ParseError::new(
                None,
                match other {
                    Some(e) => format!("unknown mesh format '.{e}'"),
                    None => "the file name has no extension, so its mesh format is unknown".into(),
                },
                "use a .obj, .stl or .ply file (convert others, e.g. with MeshLab or Blender)",
            )),
        }
    }
}

fn parse(bytes: &[u8], format: Format) -> Result<TriangleMesh, ParseError> {
    match format {
        Format::Obj => obj::parse(&String::from_utf8_lossy(bytes)),
        Format::Stl => stl::parse(bytes),
        Format::Ply => ply::parse(bytes),
    }
}

/// A problem found while parsing, before the path is attached.
#[derive(Debug)]
struct ParseError {
    line: Option<usize>,
    message: String,
    hint: String,
}

impl ParseError {
    fn new(line: Option<usize>, message: impl Into<String>, hint: impl Into<String>) -> Self {
        ParseError {
            line,
            message: message.into(),
            hint: hint.into(),
        }
    }
}

/// Where a face came from: its number as the format counts faces (from 1
/// in OBJ and STL, from 0 in PLY) and its line in a text file.
#[derive(Clone, Copy, Debug)]
struct FaceSource {
    face: usize,
    line: Option<usize>,
}

/// Triangles as a parser collects them, each with its source so that an
/// index out of range can be reported once all vertices are known.
#[derive(Default)]
struct Faces {
    count: usize,
    triangles: Vec<[u32; 3]>,
    sources: Vec<FaceSource>,
}

impl Faces {
    /// The source of the next face, numbered from 1.
    fn next_source(&self, line: Option<usize>) -> FaceSource {
        FaceSource {
            face: self.count + 1,
            line,
        }
    }

    /// Adds a polygon of at least three vertices, fan-triangulated.
    fn add(&mut self, polygon: &[u32], source: FaceSource) {
        self.count += 1;
        for pair in polygon[1..].windows(2) {
            self.triangles.push([polygon[0], pair[0], pair[1]]);
            self.sources.push(source);
        }
    }

    /// Checks every index against the `n` vertices. `first_index` is the
    /// index the format gives the first vertex (1 for OBJ), `hint` says
    /// which indices are valid given the vertex count.
    fn check_indices(
        &self,
        n: usize,
        first_index: usize,
        hint: impl Fn(usize) -> String,
    ) -> Result<(), ParseError> {
        let bad = self
            .triangles
            .iter()
            .zip(&self.sources)
            .find_map(|(t, source)| t.iter().find(|&&i| i as usize >= n).map(|&i| (i, source)));
        let Some((index, source)) = bad else {
            return Ok(());
        };
        if n == 0 {
            return Err(ParseError::new(
                source.line,
                "the file has faces but no vertices",
                "export the mesh with its vertex positions",
            ));
        }
        Err(ParseError::new(
            source.line,
            format!(
                "face {} refers to vertex {}, but the file has {n} vertices",
                source.face,
                index as usize + first_index
            ),
            hint(n),
        ))
    }

    /// The mesh, unless it has no triangles at all.
    fn into_mesh(self, vertices: Vec<Vec3>) -> Result<TriangleMesh, ParseError> {
        if self.triangles.is_empty() {
            return Err(ParseError::new(
                None,
                "the file contains no triangles",
                "export the mesh with its faces, not only its points or lines",
            ));
        }
        Ok(TriangleMesh {
            vertices,
            triangles: self.triangles,
        })
    }
}

/// The first three tokens as a point, as in `v x y z` (the `syntax` the
/// hint shows); `what` names the vertex and is only called for messages.
fn point<'a>(
    mut tokens: impl Iterator<Item = &'a str>,
    line: Option<usize>,
    what: &dyn Fn() -> String,
    syntax: &str,
) -> Result<Vec3, ParseError> {
    let mut xyz = [0.0; 3];
    for (i, value) in xyz.iter_mut().enumerate() {
        let token = tokens.next().ok_or_else(|| {
            ParseError::new(
                line,
                format!("{} has {i} coordinates; it needs three", what()),
                format!("write vertices as `{syntax}`"),
            )
        })?;
        *value = coordinate(token, line, what)?;
    }
    Ok(Vec3::from_array(xyz))
}

/// Parses a coordinate, which must be a finite number; `what` names the
/// vertex for messages and is only called when something is wrong.
fn coordinate(
    token: &str,
    line: Option<usize>,
    what: &dyn Fn() -> String,
) -> Result<f32, ParseError> {
    let value: f32 = token.parse().map_err(|_| {
        ParseError::new(
            line,
            format!("'{token}' in {} is not a number", what()),
            "write coordinates as decimal numbers such as 0.25 or -1.5e-3",
        )
    })?;
    finite(value, line, what)
}

/// Checks that a coordinate is finite.
fn finite(value: f32, line: Option<usize>, what: &dyn Fn() -> String) -> Result<f32, ParseError> {
    if value.is_finite() {
        return Ok(value);
    }
    Err(ParseError::new(
        line,
        format!("{} has a non-finite coordinate ({value})", what()),
        "replace NaN and infinite coordinates with finite numbers (re-export the mesh)",
    ))
}

#[cfg(test)]
mod tests;
