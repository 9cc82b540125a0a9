//! Byte-level robustness: truncated, corrupted and random inputs must give
//! errors, never panics.

use super::{Format, parse};

const OBJ: &str =
    "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\nf -5/1 -4//2 -1/3/3\n";
const STL: &str = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
const PLY: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";

fn binary_stl() -> Vec<u8> {
    let mut bytes = b"solid but binary".to_vec();
    bytes.resize(80, b' ');
    bytes.extend(1u32.to_le_bytes());
    for value in [
        0.0f32, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0,
    ] {
        bytes.extend(value.to_le_bytes());
    }
    bytes.extend([0, 0]);
    bytes
}

fn binary_ply(big_endian: bool) -> Vec<u8> {
    let format = if big_endian {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    };
    let mut bytes = format!(
        "ply\nformat {format} 1.0\nelement vertex 3\nproperty double x\nproperty float y\nproperty float z\n\
         property uchar red\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n"
    )
    .into_bytes();
    let order = |b: Vec<u8>| {
        if big_endian {
            b.into_iter().rev().collect()
        } else {
            b
        }
    };
    for [x, y, z] in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        bytes.extend(order(f64::from(x).to_le_bytes().to_vec()));
        bytes.extend(order(y.to_le_bytes().to_vec()));
        bytes.extend(order(z.to_le_bytes().to_vec()));
        bytes.push(255);
    }
    bytes.push(3);
    for i in 0u32..3 {
        bytes.extend(order(i.to_le_bytes().to_vec()));
    }
    bytes
}

fn samples() -> Vec<(Format, Vec<u8>)> {
    vec![
        (Format::Obj, OBJ.as_bytes().to_vec()),
        (Format::Stl, STL.as_bytes().to_vec()),
        (Format::Stl, binary_stl()),
        (Format::Ply, PLY.as_bytes().to_vec()),
        (Format::Ply, binary_ply(false)),
        (Format::Ply, binary_ply(true)),
    ]
}

/// A small deterministic xorshift generator.
struct Random(u64);

impl Random {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

#[test]
fn samples_parse() {
    for (format, bytes) in samples() {
        let mesh = parse(&bytes, format).unwrap_or_else(|e| panic!("{format:?}: {e:?}"));
        assert!(!mesh.triangles.is_empty());
    }
}

#[test]
fn every_truncation_is_an_error_or_a_mesh_never_a_panic() {
    for (format, bytes) in samples() {
        for end in 0..bytes.len() {
            if let Ok(mesh) = parse(&bytes[..end], format) {
                assert!(
                    mesh.triangles
                        .iter()
                        .flatten()
                        .all(|&i| (i as usize) < mesh.vertices.len())
                );
            }
        }
    }
}

#[test]
fn corrupted_and_random_bytes_never_panic() {
    let mut random = Random(0x9e37_79b9_7f4a_7c15);
    for (format, bytes) in samples() {
        for _ in 0..2000 {
            let mut corrupted = bytes.clone();
            for _ in 0..1 + random.next() % 4 {
                let at = random.next() as usize % corrupted.len();
                corrupted[at] = random.next() as u8;
            }
            let _ = parse(&corrupted, format);
        }
    }
    for format in [Format::Obj, Format::Stl, Format::Ply] {
        for length in 0..300 {
            let garbage: Vec<u8> = (0..length).map(|_| random.next() as u8).collect();
            let _ = parse(&garbage, format);
            let mut headed = b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 9\nproperty list int int vertex_indices\nend_header\n".to_vec();
            headed.extend(&garbage);
            assert!(parse(&headed, Format::Ply).is_err());
        }
    }
}
