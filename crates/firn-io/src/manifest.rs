//! The run manifest: a JSON record of how a run was configured and which
//! files each frame produced, rewritten atomically after every frame so that
//! tools (and a resumed run) can trust it at any moment.

use std::fs;
use std::path::Path;

use serde::{Deserialize, Deserializer, Serialize};

use crate::IoError;
use crate::atomic::write_atomically;

/// The manifest's file name in a run directory.
pub const MANIFEST_FILE: &str = "manifest.json";

/// Everything worth knowing about a run and its outputs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Version of firn that produced the run.
    pub firn_version: String,
    /// The scene file the run was started from, if any.
    pub scene_file: Option<String>,
    /// The fully resolved scene, defaults included, so the run can be reproduced.
    pub scene: serde_json::Value,
    /// Compute backend name: "cpu" or "gpu".
    pub backend: String,
    /// The GPU adapter the run computed on (absent on the CPU, and in
    /// manifests written before GPU runs existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adapter: Option<String>,
    /// Worker threads used.
    pub threads: usize,
    /// Number of simulated particles.
    pub particle_count: usize,
    /// Background grid resolution in cells per axis.
    pub grid_cells: [u32; 3],
    /// Completed frames in order.
    pub frames: Vec<FrameRecord>,
    /// Whether the run is still going, finished or failed.
    pub status: RunStatus,
    /// Animated previews of the whole run (GIF, MP4), relative to the manifest.
    #[serde(default)]
    pub animations: Vec<String>,
}

/// What one output frame took and produced.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameRecord {
    /// Frame number.
    pub index: u32,
    /// Simulation time at the frame, in seconds.
    #[serde(deserialize_with = "null_as_nan")]
    pub time: f64,
    /// Solver substeps taken since the previous frame.
    pub substeps: u32,
    /// Wall-clock seconds spent on the frame.
    #[serde(deserialize_with = "null_as_nan")]
    pub wall_seconds: f64,
    /// Cost per particle per substep in nanoseconds, the throughput figure.
    #[serde(deserialize_with = "null_as_nan")]
    pub ns_per_particle_substep: f64,
    /// This frame's caches, relative to the manifest.
    pub files: Vec<String>,
    /// This frame's pictures, one per render style, relative to the manifest.
    #[serde(default)]
    pub images: Vec<String>,
    /// The semi-implicit solver's work in this frame (absent for the
    /// explicit integrator).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solver: Option<SolverFrameStats>,
    /// Where the snow's mass is at the frame, with spindrift (absent
    /// without it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass: Option<MassBalance>,
    /// Where each of the scene's colliders is at the frame and how it is
    /// turned, in the scene's order (absent without colliders).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub colliders: Vec<ColliderPose>,
    /// Where each of the scene's rigid bodies is at the frame, how it is
    /// turned and how it moves, in the scene's order (absent without
    /// bodies).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rigid_bodies: Vec<BodyPose>,
}

/// A collider's pose at a frame: a point p of its scene-file geometry is
/// at `position` + `rotation` (p − its reference point at time 0).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ColliderPose {
    /// Where its reference point is (the plane's point, the centre), m.
    pub position: [f32; 3],
    /// Its orientation, a unit quaternion [x, y, z, w].
    pub rotation: [f32; 4],
}

/// A rigid body's pose and motion at a frame: a point p of its scene-file
/// shape (a sphere, box, cylinder or capsule in its own frame) is at
/// `position` + `rotation` (p − its reference point); a mesh body's placed
/// vertices carry its starting rotation already, so they turn by
/// `rotation` times the inverse of that.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BodyPose {
    /// Where its reference point (the centre of its shape) is, m.
    pub position: [f32; 3],
    /// Its orientation, a unit quaternion [x, y, z, w].
    pub rotation: [f32; 4],
    /// Velocity of its centre of mass, m/s.
    pub velocity: [f32; 3],
    /// Angular velocity, rad/s.
    pub angular_velocity: [f32; 3],
}

/// Where a snow scene's mass is, with spindrift: in the snow, in the air
/// (drift) or blown out of the domain. Each sum is in f64 in particle order;
/// `total` is the three added: the scene's mass at every frame, to the
/// rounding of those sums (each particle keeps its mass bit for bit).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MassBalance {
    /// Σ m_p of the snow particles, kg.
    pub snow: f64,
    /// Σ m_p of the drift particles, kg.
    pub drift: f64,
    /// Σ m_p of the drift that left the domain, kg.
    pub escaped: f64,
    /// snow + drift + escaped, kg.
    pub total: f64,
    /// Snow particles.
    pub snow_particles: u64,
    /// Drift particles.
    pub drift_particles: u64,
    /// Drift particles that left the domain.
    pub escaped_particles: u64,
}

/// What the semi-implicit velocity solve did during one frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SolverFrameStats {
    /// Substeps solved.
    pub solves: u64,
    /// Conjugate-residual iterations, summed over the substeps.
    pub iterations: u64,
    /// Mean iterations per solve.
    pub mean_iterations: f64,
    /// Final relative residual of the frame's last solve.
    pub final_residual: f32,
    /// Solves that stopped before reaching the tolerance.
    pub unconverged: u64,
}

/// The state of a run, as recorded in its manifest.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "state", rename_all = "snake_case")]
pub enum RunStatus {
    /// The run is in progress (or was killed without a chance to say so).
    Running,
    /// The run completed all frames.
    Finished,
    /// The run stopped on an error.
    Failed {
        /// The error, as shown to the user.
        message: String,
    },
}

impl Manifest {
    /// Records a finished frame, dropping any records from that frame on,
    /// which a resumed run is redoing.
    pub fn record_frame(&mut self, record: FrameRecord) {
        self.frames.retain(|frame| frame.index < record.index);
        self.frames.push(record);
    }

    /// Writes the manifest as pretty JSON, atomically.
    pub fn write(&self, path: &Path) -> Result<(), IoError> {
        write_atomically(path, |out| {
            serde_json::to_writer_pretty(&mut *out, self)?;
            out.write_all(b"\n")
        })
    }

    /// Reads a manifest written by [`Manifest::write`].
    pub fn read(path: &Path) -> Result<Self, IoError> {
        let bytes = fs::read(path).map_err(|source| IoError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Manifest::from_bytes(&bytes, path)
    }

    /// Decodes the bytes of a manifest read from `path` (named in errors).
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, IoError> {
        serde_json::from_slice(bytes).map_err(|source| IoError::Json {
            path: path.to_path_buf(),
            source,
        })
    }
}

/// JSON has no NaN or infinity; serde_json writes them as `null`, so read
/// `null` back as NaN rather than rejecting the whole manifest.
fn null_as_nan<'de, D: Deserializer<'de>>(deserializer: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(deserializer)?.unwrap_or(f64::NAN))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(index: u32) -> FrameRecord {
        FrameRecord {
            index,
            time: f64::from(index) / 24.0,
            substeps: 40,
            wall_seconds: 1.25,
            ns_per_particle_substep: 85.5,
            files: vec![format!("frames/frame_{index:04}.ply")],
            images: vec![format!("images/points/frame_{index:05}.png")],
            solver: Some(SolverFrameStats {
                solves: 40,
                iterations: 400,
                mean_iterations: 10.0,
                final_residual: 1e-4,
                unconverged: 0,
            }),
            mass: None,
            colliders: vec![ColliderPose {
                position: [0.5, 0.25, 0.5],
                rotation: [0.0, 0.38268343, 0.0, 0.9238795],
            }],
            rigid_bodies: vec![BodyPose {
                position: [0.25, 0.5, 0.75],
                rotation: [0.0, 0.0, 0.38268343, 0.9238795],
                velocity: [0.0, -1.5, 0.25],
                angular_velocity: [0.5, 0.0, -2.0],
            }],
        }
    }

    fn sample() -> Manifest {
        Manifest {
            firn_version: "0.1.0".into(),
            scene_file: Some("scenes/avalanche.toml".into()),
            scene: serde_json::json!({ "gravity": [0.0, -9.81, 0.0], "frames": 48 }),
            backend: "gpu".into(),
            adapter: Some("llvmpipe (LLVM 19.1.7, 256 bits)".into()),
            threads: 16,
            particle_count: 1_000_000,
            grid_cells: [128, 64, 128],
            frames: vec![frame(0), frame(1)],
            status: RunStatus::Failed {
                message: "out of memory".into(),
            },
            animations: vec!["images/points.gif".into()],
        }
    }

    #[test]
    fn the_manifest_round_trips_through_its_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("manifest.json");
        sample().write(&path).unwrap();
        assert_eq!(Manifest::read(&path).unwrap(), sample());
    }

    #[test]
    fn the_status_is_tagged_with_its_state() {
        let json = serde_json::to_value(sample()).unwrap();
        assert_eq!(
            json["status"],
            serde_json::json!({ "state": "failed", "message": "out of memory" })
        );
        let running = serde_json::to_value(RunStatus::Running).unwrap();
        assert_eq!(running, serde_json::json!({ "state": "running" }));
    }

    #[test]
    fn non_finite_timings_survive_as_nan() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("manifest.json");
        let mut manifest = sample();
        manifest.frames[0].ns_per_particle_substep = f64::INFINITY;
        manifest.write(&path).unwrap();
        assert!(
            Manifest::read(&path).unwrap().frames[0]
                .ns_per_particle_substep
                .is_nan()
        );
    }

    #[test]
    fn recording_a_frame_again_drops_the_later_ones() {
        let mut manifest = sample();
        manifest.record_frame(frame(2));
        manifest.record_frame(frame(1));
        let indices: Vec<u32> = manifest.frames.iter().map(|frame| frame.index).collect();
        assert_eq!(indices, [0, 1]);
    }

    #[test]
    fn manifests_without_an_adapter_still_read() {
        let mut json = serde_json::to_value(sample()).unwrap();
        json.as_object_mut().unwrap().remove("adapter");
        let read: Manifest = serde_json::from_value(json).unwrap();
        assert_eq!(read.adapter, None);
        let cpu = Manifest {
            adapter: None,
            ..sample()
        };
        let written = serde_json::to_value(&cpu).unwrap();
        assert!(written.get("adapter").is_none(), "{written}");
    }

    #[test]
    fn frames_without_rigid_bodies_leave_them_out() {
        let mut record = frame(0);
        record.rigid_bodies.clear();
        let written = serde_json::to_value(&record).unwrap();
        assert!(written.get("rigid_bodies").is_none(), "{written}");
        let read: FrameRecord = serde_json::from_value(written).unwrap();
        assert_eq!(read, record);
    }

    #[test]
    fn a_malformed_manifest_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("manifest.json");
        fs::write(&path, "{ not json").unwrap();
        let message = Manifest::read(&path).unwrap_err().to_string();
        assert!(
            message.starts_with(&format!("cannot parse {}", path.display())),
            "{message}"
        );
    }
}
