//! Triangle meshes (the snow's reconstructed surface) as binary
//! little-endian PLY and as Wavefront OBJ.
//!
//! Both files hold the same shared vertices and triangles, in the same order,
//! triangles counter-clockwise seen from outside. PLY stores the positions as
//! `float` and each face as a `uchar` count (3) and three `int` indices; OBJ
//! writes each coordinate as the shortest decimal that reads back as the same
//! `f32`, so both files carry the same numbers and the same bytes for the
//! same mesh.

use std::io::{self, Write};
use std::path::Path;

use glam::Vec3;

use crate::IoError;
use crate::atomic::write_atomically;

/// A triangle mesh borrowed for writing.
#[derive(Clone, Copy, Debug)]
pub struct MeshData<'a> {
    /// Vertex positions.
    pub vertices: &'a [Vec3],
    /// Triangles as three indices into `vertices`.
    pub triangles: &'a [[u32; 3]],
}

/// Writes `mesh` to `path` as binary little-endian PLY, atomically.
pub fn write_mesh_ply(path: &Path, mesh: MeshData<'_>) -> Result<(), IoError> {
    write_atomically(path, |out| out.write_all(&encode_mesh_ply(mesh)))
}

/// Writes `mesh` to `path` as Wavefront OBJ, atomically.
pub fn write_mesh_obj(path: &Path, mesh: MeshData<'_>) -> Result<(), IoError> {
    write_atomically(path, |out| write_obj(out, mesh))
}

/// The bytes of `mesh` as binary little-endian PLY.
pub fn encode_mesh_ply(mesh: MeshData<'_>) -> Vec<u8> {
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment firn snow surface\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.vertices.len(),
        mesh.triangles.len()
    );
    let mut bytes =
        Vec::with_capacity(header.len() + 12 * mesh.vertices.len() + 13 * mesh.triangles.len());
    bytes.extend_from_slice(header.as_bytes());
    for vertex in mesh.vertices {
        for coordinate in vertex.to_array() {
            bytes.extend_from_slice(&coordinate.to_le_bytes());
        }
    }
    for triangle in mesh.triangles {
        bytes.push(3);
        for &index in triangle {
            bytes.extend_from_slice(&index.to_le_bytes());
        }
    }
    bytes
}

/// The bytes of `mesh` as Wavefront OBJ.
pub fn encode_mesh_obj(mesh: MeshData<'_>) -> Vec<u8> {
    let mut bytes = Vec::new();
    write_obj(&mut bytes, mesh).expect("writing to memory cannot fail");
    bytes
}

/// Writes the OBJ text of `mesh`: a `v` line per vertex, then an `f` line
/// per triangle with 1-based indices.
fn write_obj(out: &mut dyn Write, mesh: MeshData<'_>) -> io::Result<()> {
    let mut text = String::from("# firn snow surface\n");
    for vertex in mesh.vertices {
        text.push_str(&format!("v {} {} {}\n", vertex.x, vertex.y, vertex.z));
        flush_when_long(out, &mut text)?;
    }
    for [a, b, c] in mesh.triangles {
        text.push_str(&format!("f {} {} {}\n", a + 1, b + 1, c + 1));
        flush_when_long(out, &mut text)?;
    }
    out.write_all(text.as_bytes())
}

/// Hands `text` to `out` once it holds a megabyte.
fn flush_when_long(out: &mut dyn Write, text: &mut String) -> io::Result<()> {
    if text.len() >= 1 << 20 {
        out.write_all(text.as_bytes())?;
        text.clear();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let vertices = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.0, 0.0, 0.1)];
        let triangles = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        (vertices, triangles)
    }

    #[test]
    fn ply_holds_the_header_and_the_records() {
        let (vertices, triangles) = tetrahedron();
        let bytes = encode_mesh_ply(MeshData {
            vertices: &vertices,
            triangles: &triangles,
        });
        let text = String::from_utf8_lossy(&bytes);
        let body = text.find("end_header\n").expect("header") + "end_header\n".len();
        assert!(text.contains("element vertex 4\n") && text.contains("element face 4\n"));
        assert_eq!(bytes.len() - body, 4 * 12 + 4 * 13);
        let last_face = &bytes[bytes.len() - 13..];
        assert_eq!(last_face[0], 3);
        assert_eq!(&last_face[1..5], &1i32.to_le_bytes());
    }

    #[test]
    fn obj_counts_from_one_and_keeps_the_shortest_decimals() {
        let (vertices, triangles) = tetrahedron();
        let text = String::from_utf8(encode_mesh_obj(MeshData {
            vertices: &vertices,
            triangles: &triangles,
        }))
        .expect("utf-8");
        assert!(text.contains("v 0 0 0.1\n"), "{text}");
        assert!(text.ends_with("f 2 3 4\n"), "{text}");
    }
}
