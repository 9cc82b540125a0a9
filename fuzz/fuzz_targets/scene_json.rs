//! Scenes as JSON (a run's manifest holds one): read back as `firn render`
//! and the viewer do, then held to the scene format's rules.
#![no_main]

use firn_core::Scene;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(mut scene) = serde_json::from_slice::<Scene>(data)
        && scene.load_meshes().is_ok()
    {
        let _ = scene.validate();
    }
});
