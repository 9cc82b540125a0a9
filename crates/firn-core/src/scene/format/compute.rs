//! Reads the `[compute]` table: which backend (CPU or GPU) computes the scene.

use serde::Deserialize;

use crate::scene::compute::{Backend, ComputeSettings};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCompute {
    backend: Option<Backend>,
}

/// The `[compute]` table with its default (`backend = "auto"`).
pub(super) fn resolve_compute(raw: Option<RawCompute>) -> ComputeSettings {
    ComputeSettings {
        backend: raw.and_then(|raw| raw.backend).unwrap_or_default(),
    }
}
