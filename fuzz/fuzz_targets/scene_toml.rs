//! Scene files: any text is either a scene or a located error, never a
//! panic, a hang or a run-away allocation.
#![no_main]

use firn_core::Scene;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = Scene::from_toml_str(text, "fuzz.toml");
    }
});
