//! The scene: what is simulated, for how long, and where results go.
//!
//! [`model`] holds the plain data types a program can build in code, with the
//! defaults of the scene format; [`builder`] builds them from those defaults
//! ([`Scene::builder`]); [`mod@format`] reads them from TOML scene files (`format = 1`) and reports bad
//! input with file, line, column and a fix; [`sampling`] turns bodies of snow
//! into particles; [`render`] holds the camera and the picture settings;
//! [`flow`] holds the settings of curl-noise particle flows (`kind = "flow"`);
//! [`mesh`] places triangle meshes as bodies and colliders; [`compute`] says
//! which backend (CPU or GPU) computes the scene; [`estimate`] says what it
//! will cost before anything runs; [`wind`] blows a curl-noise field over
//! the snow (`[wind]`); [`rigid_body`] describes the solids the snow pushes
//! and that push it (`[[rigid_bodies]]`).

pub mod builder;
pub mod clumps;
pub mod compute;
pub mod estimate;
pub mod flow;
pub mod format;
pub mod material;
pub mod mesh;
pub mod mesh_sequence;
pub mod model;
pub mod motion;
pub mod render;
pub mod rigid_body;
pub mod sampling;
pub mod wind;

pub use builder::SceneBuilder;
pub use clumps::Clumps;
pub use compute::*;
pub use estimate::{BodyEstimate, Bytes, CPU_BYTES_PER_PARTICLE, FirstStep, WorkEstimate};
pub use flow::*;
pub use format::SceneError;
pub use material::Material;
pub use mesh::{MeshBody, MeshCollider, MeshPlacement};
pub use mesh_sequence::{MeshFrames, MeshSequenceCollider, SequenceInterval};
pub use model::*;
pub use motion::{Keyframe, Motion, PathShape, Pose};
pub use render::*;
pub use rigid_body::{BodyMass, MeshSolid, RigidBody};
pub use wind::{Spindrift, Wind};
