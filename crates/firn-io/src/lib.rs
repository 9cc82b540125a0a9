//! Output side of the firn snow simulator.
//!
//! Everything a run leaves on disk goes through this crate: per-frame particle
//! caches (binary PLY for Blender/Houdini, VTK PolyData plus a `.pvd` time
//! series for ParaView), per-frame OpenVDB volumes (Blender, Houdini), the snow's surface as
//! PLY and OBJ meshes, a USD stage of the
//! whole run (Houdini, Omniverse, Blender), the
//! run manifest that records what was produced, and binary checkpoints for
//! resuming. Every file is written atomically, so a
//! crash or a full disk never leaves a half-written file under its final name.
//!
//! Writers borrow particle data through [`FrameData`] instead of copying it out
//! of the solver, and stream it into the file a chunk at a time; a checkpoint
//! is written from borrowed arrays through [`CheckpointView`].

// The writers hand raw slices of `f32`/`u32`/`u64` to formats that are
// little-endian by definition; refusing big-endian targets keeps that sound.
#[cfg(not(target_endian = "little"))]
compile_error!("firn-io writes raw little-endian data and supports little-endian targets only");

pub mod atomic;
pub mod checkpoint;
pub mod error;
pub mod frame;
pub mod manifest;
pub mod mesh;
pub mod ply;
pub mod usd;
pub mod vdb;
pub mod vtk;
mod xml;

pub use atomic::{ensure_writable_dir, write_atomically};
pub use checkpoint::{Checkpoint, CheckpointView};
pub use error::IoError;
pub use frame::{Attribute, AttributeValues, CHUNK_VALUES, FrameData, FrameError, Values};
pub use manifest::{
    BodyPose, ColliderPose, FrameRecord, MANIFEST_FILE, Manifest, MassBalance, RunStatus,
    SolverFrameStats,
};
pub use mesh::{MeshData, write_mesh_obj, write_mesh_ply};
pub use ply::{PlyCloud, PlyColumn, PlyValues, parse_ply, read_ply, write_ply};
pub use usd::{
    UsdCollider, UsdColliderSample, UsdPoints, UsdShape, UsdSolids, UsdStage, write_usd_frame,
};
pub use vdb::{FloatGrid, GridClass, Leaf, write_vdb};
pub use vtk::{PvdCollection, PvdEntry, write_vtp};
