//! firn-core: everything the solvers share and nothing that simulates.
//!
//! - [`scene`]: the scene model (domain, time, materials, bodies, colliders,
//!   output), the TOML scene format with located error messages, and body
//!   sampling into particles.
//! - [`math`]: the robust 3x3 SVD and polar decomposition, and the B-spline
//!   interpolation kernels of the Material Point Method.

pub mod math;
pub mod scene;

pub use scene::{Material, Scene, SceneError};
