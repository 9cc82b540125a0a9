//! Run manifests: any bytes are either a manifest or a JSON error.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = firn_io::Manifest::from_bytes(data, Path::new("manifest.json"));
});
