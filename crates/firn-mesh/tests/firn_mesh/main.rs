//! firn-mesh integration tests, one binary: winding numbers, signed
//! distance fields, loaders, diagnostics and the Stanford bunny.

mod bunny;
mod common;
mod diagnostics;
mod loaders;
mod mesh;
mod narrow_band;
mod sdf;
mod winding;
