//! firn-mesh: triangle meshes as snow bodies and colliders.
//!
//! - [`load_mesh`] reads OBJ, STL and PLY files with line-accurate errors
//!   ([`MeshError`]) and reports holes, non-manifold edges, degenerate
//!   triangles, flipped faces and parts ([`MeshDiagnostics`]);
//! - [`WindingNumber`] decides inside/outside by the generalized winding
//!   number (Jacobson et al. 2013), fast through the tree approximation of
//!   Barill et al. 2018 ("Fast winding numbers"), and robust to the holes of
//!   scanned meshes: it is what fills a mesh with particles;
//! - [`SignedDistanceField`] samples exact distances signed by the winding
//!   number on a grid, for mesh colliders.
//!
//! ```no_run
//! use firn_mesh::{MeshTransform, WindingNumber, load_mesh};
//! use glam::Vec3;
//!
//! let loaded = load_mesh("assets/meshes/bunny.obj".as_ref())?;
//! for warning in loaded.diagnostics.warnings() {
//!     eprintln!("warning: {warning}");
//! }
//! let transform = MeshTransform { scale: Vec3::splat(2.0), ..MeshTransform::IDENTITY };
//! let mesh = loaded.mesh.transformed(&transform);
//! let inside = WindingNumber::new(&mesh);
//! println!("{}", inside.contains(mesh.bounds().0.lerp(mesh.bounds().1, 0.5)));
//! # Ok::<(), firn_mesh::MeshError>(())
//! ```

mod bvh;
mod diagnostics;
mod error;
mod geometry;
mod load;
mod mesh;
mod narrow_band;
mod sdf;
mod winding;

pub use diagnostics::MeshDiagnostics;
pub use error::MeshError;
pub use load::{LoadedMesh, MAX_MESH_FILE_BYTES, load_mesh, load_mesh_bytes};
pub use mesh::{MeshTransform, TriangleMesh};
pub use narrow_band::{
    BRICK_SIDE, BandFootprint, INSIDE_BRICK, NarrowBandField, OUTSIDE_BRICK, SAMPLES_PER_BRICK,
    SurfaceSample,
};
pub use sdf::SignedDistanceField;
pub use winding::WindingNumber;
