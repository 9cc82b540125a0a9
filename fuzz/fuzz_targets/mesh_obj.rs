//! OBJ meshes: any bytes are either a mesh with its diagnostics or an
//! error naming the line, never a panic.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = firn_mesh::load_mesh_bytes(data, Path::new("fuzz.obj"));
});
