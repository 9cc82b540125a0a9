//! Particle caches (binary PLY): any bytes are either a point cloud whose
//! columns all hold one value per vertex, or an error.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(cloud) = firn_io::parse_ply(data, Path::new("fuzz.ply")) {
        for column in &cloud.columns {
            let values = match &column.values {
                firn_io::PlyValues::Float(values) => values.len(),
                firn_io::PlyValues::UInt(values) => values.len(),
            };
            assert_eq!(values, cloud.vertex_count, "column {}", column.name);
        }
        let _ = cloud.positions();
    }
});
