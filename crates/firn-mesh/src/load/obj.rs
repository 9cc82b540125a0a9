//! Wavefront OBJ: `v x y z` and `f` with `v`, `v/vt`, `v//vn` or
//! `v/vt/vn` corners, 1-based or negative (relative) indices; polygons are
//! fan-triangulated and every other statement is ignored.

use glam::Vec3;

use super::{Faces, ParseError, point};
use crate::TriangleMesh;

pub(super) fn parse(text: &str) -> Result<TriangleMesh, ParseError> {
    let mut vertices: Vec<Vec3> = Vec::new();
    let mut faces = Faces::default();
    let mut polygon = Vec::new();
    for (number, line) in text.lines().enumerate() {
        let at = Some(number + 1);
        let statement = line.split('#').next().unwrap_or_default();
        let mut tokens = statement.split_whitespace();
        match tokens.next() {
            Some("v") => {
                let what = || format!("vertex {}", vertices.len() + 1);
                vertices.push(point(tokens, at, &what, "v x y z")?);
            }
            Some("f") => {
                let source = faces.next_source(at);
                polygon.clear();
                for corner in tokens {
                    polygon.push(corner_index(corner, vertices.len(), source.face, at)?);
                }
                check_polygon(&polygon, source.face, at)?;
                faces.add(&polygon, source);
            }
            _ => {}
        }
    }
    faces.check_indices(vertices.len(), 1, range_hint)?;
    faces.into_mesh(vertices)
}

fn range_hint(n: usize) -> String {
    format!(
        "OBJ vertex indices run from 1 to {n}, or from -1 to -{n} counting back from the face; \
         fix or remove the face"
    )
}

fn check_polygon(polygon: &[u32], face: usize, line: Option<usize>) -> Result<(), ParseError> {
    if polygon.len() >= 3 {
        return Ok(());
    }
    Err(ParseError::new(
        line,
        format!(
            "face {face} has {} vertices; a face needs at least three",
            polygon.len()
        ),
        "give the face three or more vertex indices, or remove it (lines belong in `l` statements)",
    ))
}

/// The 0-based vertex index of a face corner (`v`, `v/vt`, `v//vn` or
/// `v/vt/vn`), with negative indices counted back from the `defined`
/// vertices read so far. Indices beyond those are checked at the end.
fn corner_index(
    corner: &str,
    defined: usize,
    face: usize,
    line: Option<usize>,
) -> Result<u32, ParseError> {
    let text = corner.split('/').next().unwrap_or_default();
    let index: i64 = text.parse().map_err(|_| {
        ParseError::new(
            line,
            format!("'{corner}' in face {face} is not a vertex index"),
            "write face corners as v, v/vt, v//vn or v/vt/vn with whole numbers, e.g. `f 1 2 3`",
        )
    })?;
    let resolved = match index {
        0 => {
            return Err(ParseError::new(
                line,
                format!("face {face} uses vertex index 0, but OBJ indices start at 1"),
                "add 1 to every vertex index of the face (the first vertex is 1)",
            ));
        }
        i if i < 0 => defined as i64 + i,
        i => i - 1,
    };
    u32::try_from(resolved).map_err(|_| {
        ParseError::new(
            line,
            format!(
                "face {face} refers to vertex {index}, but only {defined} vertices come before it"
            ),
            range_hint(defined),
        )
    })
}
