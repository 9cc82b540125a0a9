use std::path::{Path, PathBuf};

use firn_mesh::{MeshError, TriangleMesh, load_mesh};
use glam::Vec3;

use crate::common::{CUBE_QUADS, fan};

/// A unit cube as six quads (fan-triangulated by every writer below).
const CORNERS: [[f32; 3]; 8] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
    [1.0, 1.0, 1.0],
];
fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// OBJ with vt/vn corners, relative indices for two faces, comments.
fn obj() -> String {
    let mut text = String::from("# cube\no cube\nvt 0 0\nvn 0 0 1\n");
    for [x, y, z] in CORNERS {
        text += &format!("v {x} {y} {z}\n");
    }
    for (f, quad) in CUBE_QUADS.iter().enumerate() {
        let corners: Vec<String> = match f {
            0 => quad.iter().map(|&i| format!("{}/1/1", i + 1)).collect(),
            1 => quad.iter().map(|&i| format!("{}//1", i + 1)).collect(),
            2 | 3 => quad.iter().map(|&i| format!("{}", i as i64 - 8)).collect(),
            _ => quad.iter().map(|&i| format!("{}/1", i + 1)).collect(),
        };
        text += &format!("f {}\ns off\n", corners.join(" "));
    }
    text
}

fn ascii_stl() -> String {
    let mut text = String::from("solid cube\n");
    for triangle in CUBE_QUADS.into_iter().flat_map(fan) {
        text += "  facet normal 0 0 0\n    outer loop\n";
        for i in triangle {
            let [x, y, z] = CORNERS[i];
            text += &format!("      vertex {x:e} {y:e} {z:e}\n");
        }
        text += "    endloop\n  endfacet\n";
    }
    text + "endsolid cube\n"
}

fn binary_stl() -> Vec<u8> {
    let mut bytes = b"solid binary, despite the name".to_vec();
    bytes.resize(80, 0);
    bytes.extend(12u32.to_le_bytes());
    for triangle in CUBE_QUADS.into_iter().flat_map(fan) {
        bytes.extend([0u8; 12]);
        for i in triangle {
            CORNERS[i]
                .iter()
                .for_each(|c| bytes.extend(c.to_le_bytes()));
        }
        bytes.extend([0u8; 2]);
    }
    bytes
}

const PLY_HEADER: &str = "element vertex 8\nproperty float x\nproperty float y\nproperty double z\n\
    property uchar red\nproperty list uchar float extra\nelement edge 1\nproperty int a\nproperty int b\n\
    element face 6\nproperty int flags\nproperty list uchar int vertex_indices\nend_header\n";

fn ascii_ply() -> String {
    let mut text = format!("ply\nformat ascii 1.0\ncomment cube\n{PLY_HEADER}");
    for [x, y, z] in CORNERS {
        text += &format!("{x} {y} {z} 200 2 0.5 0.25\n");
    }
    text += "0 1\n";
    for quad in CUBE_QUADS {
        text += &format!("7 4 {} {} {} {}\n", quad[0], quad[1], quad[2], quad[3]);
    }
    text
}

fn binary_ply(big_endian: bool) -> Vec<u8> {
    let format = if big_endian {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    };
    let mut bytes = format!("ply\nformat {format} 1.0\n{PLY_HEADER}").into_bytes();
    let mut push = |value: Vec<u8>| {
        if big_endian {
            bytes.extend(value.into_iter().rev());
        } else {
            bytes.extend(value);
        }
    };
    for [x, y, z] in CORNERS {
        push(x.to_le_bytes().to_vec());
        push(y.to_le_bytes().to_vec());
        push(f64::from(z).to_le_bytes().to_vec());
        push(vec![200]);
        push(vec![1]);
        push(0.5f32.to_le_bytes().to_vec());
    }
    push(1i32.to_le_bytes().to_vec());
    push(2i32.to_le_bytes().to_vec());
    for quad in CUBE_QUADS {
        push(7i32.to_le_bytes().to_vec());
        push(vec![4]);
        for i in quad {
            push((i as i32).to_le_bytes().to_vec());
        }
    }
    bytes
}

/// Triangles as corner positions, each rotated to start at its smallest
/// corner, sorted: equal for equal meshes whatever the vertex order.
fn canonical(mesh: &TriangleMesh) -> Vec<[[u32; 3]; 3]> {
    let mut triangles: Vec<[[u32; 3]; 3]> = mesh
        .triangles
        .iter()
        .map(|t| {
            let mut corners = t.map(|i| mesh.vertices[i as usize].to_array().map(f32::to_bits));
            let first = (0..3).min_by_key(|&k| corners[k]).unwrap();
            corners.rotate_left(first);
            corners
        })
        .collect();
    triangles.sort();
    triangles
}

#[test]
fn every_format_loads_the_same_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let reference = load_mesh(&write(dir.path(), "cube.obj", obj())).unwrap();
    assert_eq!(reference.mesh.vertices.len(), 8);
    assert_eq!(reference.mesh.triangles.len(), 12);
    assert!(
        reference.diagnostics.warnings().is_empty(),
        "{:?}",
        reference.diagnostics
    );
    assert!((reference.mesh.signed_volume() - 1.0).abs() < 1e-12);
    let others = [
        write(dir.path(), "ascii.stl", ascii_stl()),
        write(dir.path(), "binary.STL", binary_stl()),
        write(dir.path(), "ascii.ply", ascii_ply()),
        write(dir.path(), "little.ply", binary_ply(false)),
        write(dir.path(), "big.Ply", binary_ply(true)),
        write(dir.path(), "upper.OBJ", obj()),
    ];
    for path in others {
        let loaded = load_mesh(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            canonical(&loaded.mesh),
            canonical(&reference.mesh),
            "{}",
            path.display()
        );
        assert_eq!(loaded.mesh.vertices.len(), 8, "{}", path.display());
        assert_eq!(
            loaded.diagnostics,
            reference.diagnostics,
            "{}",
            path.display()
        );
    }
}

/// Loads `bytes` as `name` and returns the error.
fn error(name: &str, bytes: impl AsRef<[u8]>) -> MeshError {
    let dir = tempfile::tempdir().unwrap();
    match load_mesh(&write(dir.path(), name, bytes)) {
        Ok(loaded) => panic!("{name} loaded {} triangles", loaded.mesh.triangles.len()),
        Err(e) => e,
    }
}

#[track_caller]
fn expect(e: &MeshError, line: Option<usize>, message: &str, hint: &str) {
    assert_eq!(e.line, line, "{e}");
    assert!(e.message.contains(message), "message of: {e}");
    assert!(e.hint.contains(hint), "hint of: {e}");
}

const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

#[test]
fn malformed_obj_files_say_where_and_what() {
    let e = error("a.obj", format!("{TRIANGLE}f 1 2 9\n"));
    expect(
        &e,
        Some(4),
        "face 1 refers to vertex 9, but the file has 3 vertices",
        "1 to 3",
    );
    let e = error("a.obj", format!("# x\n{TRIANGLE}f 1 2 3\nf -1 -2 -4\n"));
    expect(&e, Some(6), "face 2 refers to vertex -4", "-1 to -3");
    expect(
        &error("a.obj", "v 0 0 0\nv 1 zero 0\n"),
        Some(2),
        "'zero' in vertex 2 is not a number",
        "decimal",
    );
    expect(
        &error("a.obj", "v 0 0\n"),
        Some(1),
        "vertex 1 has 2 coordinates",
        "v x y z",
    );
    expect(
        &error("a.obj", "v 0 0 0\nv nan 0 0\n"),
        Some(2),
        "vertex 2 has a non-finite coordinate",
        "finite",
    );
    expect(
        &error("a.obj", format!("{TRIANGLE}f 0 1 2\n")),
        Some(4),
        "index 0",
        "first vertex",
    );
    expect(
        &error("a.obj", format!("{TRIANGLE}f 1 2\n")),
        Some(4),
        "face 1 has 2 vertices",
        "three",
    );
    expect(
        &error("a.obj", format!("{TRIANGLE}f 1 a/2 3\n")),
        Some(4),
        "'a/2' in face 1",
        "f 1 2 3",
    );
    expect(&error("a.obj", TRIANGLE), None, "no triangles", "faces");
    expect(
        &error("a.obj", "f 1 2 3\n"),
        Some(1),
        "faces but no vertices",
        "vertex positions",
    );
}

#[test]
fn malformed_stl_files_say_where_and_what() {
    let stl = ascii_stl();
    let broken = stl.replacen("vertex 1e0 0e0 0e0", "vertex 1e0 0e0", 1);
    let line = stl
        .lines()
        .position(|l| l.contains("vertex 1e0 0e0 0e0"))
        .unwrap()
        + 1;
    expect(
        &error("a.stl", broken),
        Some(line),
        "has 2 coordinates",
        "vertex x y z",
    );
    let cut: String = stl.lines().take(5).map(|l| format!("{l}\n")).collect();
    expect(
        &error("a.stl", cut),
        Some(5),
        "ends inside the facet that starts on line 2",
        "truncated",
    );
    expect(
        &error("a.stl", stl.replacen("endloop", "endlop", 1)),
        Some(7),
        "unexpected 'endlop'",
        "binary",
    );
    expect(
        &error("a.stl", stl.replacen("0e0", "inf", 1)),
        Some(4),
        "non-finite",
        "finite",
    );
    let mut binary = binary_stl();
    binary[..5].copy_from_slice(b"SOLID");
    binary.truncate(84 + 50 * 11 + 20);
    expect(
        &error("a.stl", binary),
        None,
        "announces 12 triangles (684 bytes), but the file has 654 bytes",
        "truncated",
    );
    expect(&error("a.stl", b"tiny"), None, "too short", "truncated");
    let mut nan = binary_stl();
    nan[84 + 50 + 12..84 + 50 + 16].copy_from_slice(&f32::NAN.to_le_bytes());
    expect(
        &error("a.stl", nan),
        None,
        "triangle 2 (at byte 134) has a non-finite coordinate",
        "finite",
    );
    expect(
        &error("a.stl", "solid empty\nendsolid empty\n"),
        None,
        "no triangles",
        "faces",
    );
}

#[test]
fn malformed_ply_files_say_where_and_what() {
    let ply = ascii_ply();
    let header_lines = ply.lines().position(|l| l == "end_header").unwrap() + 1;
    expect(
        &error("a.ply", ply.replace("property double z", "property real z")),
        Some(7),
        "unknown property type 'real'",
        "uchar",
    );
    expect(
        &error("a.ply", ply.replace("ply\n", "plx\n")),
        Some(1),
        "not a PLY file",
        "PLY",
    );
    let no_end = &ply[..ply.find("end_header").unwrap()];
    expect(
        &error("a.ply", no_end),
        Some(header_lines - 1),
        "no end_header",
        "truncated",
    );
    expect(
        &error("a.ply", ply.replace("ascii", "utf8")),
        Some(2),
        "unknown PLY format 'utf8'",
        "binary_little_endian",
    );
    expect(
        &error("a.ply", ply.replace("property double z\n", "")),
        Some(4),
        "no scalar property 'z'",
        "property float z",
    );
    let bad_value = ply.replacen("0 1 0 200", "0 one 0 200", 1);
    expect(
        &error("a.ply", bad_value),
        Some(header_lines + 3),
        "'one' in vertex 2",
        "damaged",
    );
    let out_of_range = ply.replacen("7 4 0 2 3 1", "7 4 0 2 3 8", 1);
    expect(
        &error("a.ply", out_of_range),
        Some(header_lines + 10),
        "face 0 refers to vertex 8, but the file has 8 vertices",
        "0 to 7",
    );
    let cut: String = ply
        .lines()
        .take(header_lines + 12)
        .map(|l| format!("{l}\n"))
        .collect();
    expect(
        &error("a.ply", cut),
        Some(header_lines + 13),
        "the file ends inside face 3",
        "truncated",
    );
    let mut binary = binary_ply(false);
    binary.truncate(binary.len() - 3);
    expect(
        &error("a.ply", binary),
        None,
        "the file ends inside face 5",
        "truncated",
    );
    let two = ply.replacen("7 4 0 2 3 1", "7 2 0 2", 1);
    expect(
        &error("a.ply", two),
        Some(header_lines + 10),
        "face 0 has 2 vertices",
        "three",
    );
}

#[test]
fn unknown_extensions_and_missing_files_are_explained() {
    let e = error("cube.fbx", obj());
    expect(&e, None, "unknown mesh format '.fbx'", ".obj, .stl or .ply");
    expect(
        &error("cube", obj()),
        None,
        "no extension",
        ".obj, .stl or .ply",
    );
    let e = load_mesh(Path::new("/nonexistent/dir/cube.obj")).unwrap_err();
    expect(&e, None, "cannot read the file", "readable");
    assert!(
        e.to_string()
            .starts_with("/nonexistent/dir/cube.obj: cannot read the file"),
        "{e}"
    );
}

#[test]
fn errors_display_path_line_message_and_fix() {
    let e = error("a.obj", "v 0 0 0\nv 1 x 0\n");
    let text = e.to_string();
    let expected = format!("{}:2: {}\n  fix: {}", e.path.display(), e.message, e.hint);
    assert_eq!(text, expected);
    assert!(e.path.ends_with("a.obj"));
}

#[test]
fn obj_polygons_are_fans_and_extra_values_are_ignored() {
    let dir = tempfile::tempdir().unwrap();
    let text = "v 0 0 0 1\nv 1 0 0 0.5 0.5 0.5\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\nvt 0 0\nl 1 2\nf 1 2 3 4 5\r\n";
    let loaded = load_mesh(&write(dir.path(), "p.obj", text)).unwrap();
    assert_eq!(loaded.mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
    assert_eq!(loaded.mesh.vertices[1], Vec3::X);
}
