//! Checkpoint files: a solver's complete state after a frame, with the
//! resolved scene it was simulating, in firn-io's checkpoint format (JSON
//! metadata and named raw arrays). A snow checkpoint holds the particle
//! arrays and the counters as bits, and its spindrift (the drift arrays and
//! the escaped tally; a checkpoint written before spindrift existed has
//! none and reads as no drift), and its rigid bodies' saved world (firn-rigid,
//! base64 in the metadata) where it has any; a flow checkpoint its snapshot's
//! arrays.
//! Either resumes on either backend.

use std::path::{Path, PathBuf};

use base64::Engine;
use base64::engine::general_purpose::STANDARD as BASE64;
use firn_core::Scene;
use firn_core::scene::SceneKind;
use firn_flow::{FlowSnapshot, FlowView};
use firn_io::{Checkpoint, CheckpointView, IoError};
use firn_mpm::{Drift, Escaped, Particles, Snapshot, SnowView};

use crate::error::{CheckpointError, ResumeError, RunError};
use crate::run_dir::RunDirectory;
use crate::simulation::{HostState, SolverState};

/// A checkpoint read back.
pub struct SavedCheckpoint {
    /// The frame the checkpoint was taken after.
    pub frame: u32,
    /// The resolved scene the run was started with, as JSON.
    pub scene_json: serde_json::Value,
    /// The solver's state.
    pub state: SolverState,
}

/// Writes `state`, taken after frame `frame` of the scene `scene_json`, to
/// `path` (atomically). The arrays stream into the file from where they
/// are (a solver's own, or a snapshot's: [`SolverState::view`]), so writing
/// costs no copy of them.
pub fn write(
    state: HostState<'_>,
    frame: u32,
    scene_json: &serde_json::Value,
    path: &Path,
) -> Result<(), IoError> {
    let checkpoint = match state {
        HostState::Snow(snow) => snow_checkpoint(snow, frame, scene_json),
        HostState::Flow(flow) => flow_checkpoint(flow, frame, scene_json),
    };
    checkpoint.write(path)
}

/// Reads the checkpoint at `path` of a simulation of `scene`, and refuses
/// one whose state no run of the scene reaches (a particle that is not
/// finite or far outside the domain, a time that is not the frame's), even
/// when its checksum holds: it is never resumed into.
pub fn read(path: &Path, scene: &Scene) -> Result<SavedCheckpoint, CheckpointError> {
    let checkpoint = Checkpoint::read(path)?;
    let saved = match scene.kind {
        SceneKind::Snow => read_snow(&checkpoint, path),
        SceneKind::Flow(_) => read_flow(&checkpoint, path),
    }?;
    check_plausible(&saved, scene).map_err(|reason| CheckpointError::Implausible {
        path: path.to_path_buf(),
        reason,
    })?;
    Ok(saved)
}

/// How far (in cells) a saved particle may lie outside the domain: the
/// solver stops a run whose snow strays one cell out.
const OUTSIDE_TOLERANCE_CELLS: f32 = 1.0;

/// Why `saved` cannot be a state of `scene` after its frame, if it cannot.
fn check_plausible(saved: &SavedCheckpoint, scene: &Scene) -> Result<(), String> {
    let time = &scene.time;
    let frames = time.frame_count();
    if saved.frame > frames {
        return Err(format!(
            "it was taken after frame {}, but the scene has {frames} frames",
            saved.frame
        ));
    }
    let (state_time, positions) = match &saved.state {
        SolverState::Snow(snapshot) => {
            check_snow_particles(snapshot)?;
            (snapshot.time, &snapshot.particles.position)
        }
        SolverState::Flow(snapshot) => {
            let frame_steps = u64::from(scene.kind.flow().map_or(1, |flow| flow.substeps));
            let time_of_steps = snapshot.substeps as f64 / (time.fps * frame_steps as f64);
            (time_of_steps, &snapshot.positions)
        }
    };
    let frame_time = f64::from(saved.frame) / time.fps;
    if !state_time.is_finite() || (state_time - frame_time).abs() > 1e-6 * frame_time.max(1.0) {
        return Err(format!(
            "its state is at t = {state_time} s, but frame {} ends at t = {frame_time} s",
            saved.frame
        ));
    }
    let domain = &scene.domain;
    let margin = glam::Vec3::splat(OUTSIDE_TOLERANCE_CELLS * domain.cell_size);
    let (low, high) = (domain.min - margin, domain.max + margin);
    if let Some((index, position)) = positions
        .iter()
        .enumerate()
        .find(|(_, p)| !(p.is_finite() && p.cmpge(low).all() && p.cmple(high).all()))
    {
        return Err(format!(
            "particle {index} is at {position}, outside the domain {} .. {}",
            domain.min, domain.max
        ));
    }
    Ok(())
}

/// Every snow particle's attributes are finite, and its mass, volume and
/// plastic volume change positive.
fn check_snow_particles(snapshot: &Snapshot) -> Result<(), String> {
    let p = &snapshot.particles;
    let finite_vectors = |v: &[glam::Vec3]| v.iter().position(|v| !v.is_finite());
    let finite_matrices = |m: &[glam::Mat3]| m.iter().position(|m| !m.is_finite());
    let positive = |s: &[f32]| s.iter().position(|s| !(s.is_finite() && *s > 0.0));
    let problems = [
        ("velocity is not finite", finite_vectors(&p.velocity)),
        ("mass is not a positive number", positive(&p.mass)),
        (
            "initial volume is not a positive number",
            positive(&p.volume0),
        ),
        ("plastic J is not a positive number", positive(&p.plastic_j)),
        (
            "elastic deformation is not finite",
            finite_matrices(&p.elastic),
        ),
        ("stress is not finite", finite_matrices(&p.stress)),
        (
            "velocity gradient is not finite",
            finite_matrices(&p.velocity_gradient),
        ),
    ];
    if let Some((what, Some(index))) = problems.iter().find(|(_, index)| index.is_some()) {
        return Err(format!("particle {index}'s {what}"));
    }
    let maxima = [snapshot.max_speed_squared, snapshot.max_wave_speed_squared];
    if maxima.iter().any(|m| !(m.is_finite() && *m >= 0.0)) {
        return Err(format!(
            "its speed maxima ({}, {}) are not finite",
            maxima[0], maxima[1]
        ));
    }
    Ok(())
}

/// The resolved scene as JSON, for manifests and checkpoints.
pub fn scene_json(scene: &Scene) -> serde_json::Value {
    serde_json::to_value(scene).unwrap_or_default()
}

/// Whether two resolved scenes (as JSON) simulate the same thing: equal but
/// for `compute`, which says only where, and which checkpoints written
/// before it existed lack.
pub fn same_physics(a: &serde_json::Value, b: &serde_json::Value) -> bool {
    without_compute(a) == without_compute(b)
}

/// `scene` without its `compute` table.
fn without_compute(scene: &serde_json::Value) -> serde_json::Value {
    let mut scene = scene.clone();
    if let Some(table) = scene.as_object_mut() {
        table.remove("compute");
    }
    scene
}

/// A snow checkpoint: the counters (floats as their bits) and the particles.
fn snow_checkpoint<'a>(
    snow: SnowView<'a>,
    frame: u32,
    scene_json: &serde_json::Value,
) -> CheckpointView<'a> {
    let (max_speed_squared, max_wave_speed_squared) = snow.motion_bounds();
    let escaped = snow.escaped();
    let mut checkpoint = CheckpointView::new(serde_json::json!({
        "frame": frame,
        "time_bits": snow.time().to_bits(),
        "steps": snow.steps(),
        "max_speed_squared_bits": max_speed_squared.to_bits(),
        "max_wave_speed_squared_bits": max_wave_speed_squared.to_bits(),
        "escaped_count": escaped.count,
        "escaped_mass_bits": escaped.mass.to_bits(),
        "scene": scene_json,
    }));
    let p = snow.particles();
    checkpoint.push_array("position", &p.position);
    checkpoint.push_array("velocity", &p.velocity);
    checkpoint.push_array("mass", &p.mass);
    checkpoint.push_array("volume0", &p.volume0);
    checkpoint.push_array("elastic", &p.elastic);
    checkpoint.push_array("plastic_j", &p.plastic_j);
    checkpoint.push_array("stress", &p.stress);
    checkpoint.push_array("velocity_gradient", &p.velocity_gradient);
    checkpoint.push_array("material", &p.material);
    let drift = snow.drift();
    checkpoint.push_array("drift_position", &drift.position);
    checkpoint.push_array("drift_velocity", &drift.velocity);
    checkpoint.push_array("drift_mass", &drift.mass);
    checkpoint.push_array("drift_volume", &drift.volume);
    checkpoint.push_array("drift_material", &drift.material);
    if let Some(bytes) = snow.rigid_bytes() {
        checkpoint.meta["rigid_bodies"] = BASE64.encode(bytes).into();
    }
    checkpoint
}

/// A flow checkpoint: the snapshot's arrays and its counters.
fn flow_checkpoint<'a>(
    flow: FlowView<'a>,
    frame: u32,
    scene_json: &serde_json::Value,
) -> CheckpointView<'a> {
    let (trail_capacity, trail_head, trail_points, trail_lengths, trail_generations) =
        match flow.trails() {
            Some(trails) => trails.raw(),
            None => (0, 0, &[][..], &[][..], &[][..]),
        };
    let mut checkpoint = CheckpointView::new(serde_json::json!({
        "kind": "flow",
        "frame": frame,
        "substeps": flow.substeps(),
        "trail_capacity": trail_capacity,
        "trail_head": trail_head,
        "scene": scene_json,
    }));
    checkpoint.push_array("births", flow.births());
    checkpoint.push_array("positions", flow.positions());
    checkpoint.push_array("velocities", flow.velocities());
    checkpoint.push_array("ages", flow.ages());
    checkpoint.push_array("lifetimes", flow.lifetimes());
    checkpoint.push_array("generations", flow.generations());
    checkpoint.push_array("emitters", flow.emitters());
    checkpoint.push_array("trail_points", trail_points);
    checkpoint.push_array("trail_lengths", trail_lengths);
    checkpoint.push_array("trail_generations", trail_generations);
    checkpoint
}

/// The unsigned counter `name` of a checkpoint's metadata.
fn counter(
    checkpoint: &Checkpoint,
    path: &Path,
    name: &'static str,
) -> Result<u64, CheckpointError> {
    checkpoint
        .meta
        .get(name)
        .and_then(serde_json::Value::as_u64)
        .ok_or_else(|| CheckpointError::MissingField {
            path: path.to_path_buf(),
            field: name,
        })
}

/// The frame a checkpoint was taken after, which must fit a `u32`.
fn frame(checkpoint: &Checkpoint, path: &Path) -> Result<u32, CheckpointError> {
    let frame = counter(checkpoint, path, "frame")?;
    u32::try_from(frame).map_err(|_| CheckpointError::Implausible {
        path: path.to_path_buf(),
        reason: format!("its frame {frame} is past any scene's last"),
    })
}

/// The scene a checkpoint was written for.
fn saved_scene(checkpoint: &Checkpoint) -> serde_json::Value {
    checkpoint.meta.get("scene").cloned().unwrap_or_default()
}

/// The rigid bodies' saved world of a snow checkpoint, if it has one.
fn read_rigid_bodies(
    checkpoint: &Checkpoint,
    path: &Path,
) -> Result<Option<Vec<u8>>, CheckpointError> {
    let Some(text) = checkpoint.meta.get("rigid_bodies") else {
        return Ok(None);
    };
    text.as_str()
        .and_then(|text| BASE64.decode(text).ok())
        .map(Some)
        .ok_or_else(|| CheckpointError::Implausible {
            path: path.to_path_buf(),
            reason: "its rigid_bodies are not base64 text".into(),
        })
}

/// Reads a checkpoint written by [`snow_checkpoint`].
fn read_snow(checkpoint: &Checkpoint, path: &Path) -> Result<SavedCheckpoint, CheckpointError> {
    let particles = Particles {
        position: checkpoint.array("position")?,
        velocity: checkpoint.array("velocity")?,
        mass: checkpoint.array("mass")?,
        volume0: checkpoint.array("volume0")?,
        elastic: checkpoint.array("elastic")?,
        plastic_j: checkpoint.array("plastic_j")?,
        stress: checkpoint.array("stress")?,
        velocity_gradient: checkpoint.array("velocity_gradient")?,
        material: checkpoint.array("material")?,
    };
    let counter = |name| counter(checkpoint, path, name);
    let (drift, escaped) = read_drift(checkpoint, path)?;
    Ok(SavedCheckpoint {
        frame: frame(checkpoint, path)?,
        scene_json: saved_scene(checkpoint),
        state: SolverState::Snow(Snapshot {
            time: f64::from_bits(counter("time_bits")?),
            steps: counter("steps")?,
            max_speed_squared: f32::from_bits(counter("max_speed_squared_bits")? as u32),
            max_wave_speed_squared: f32::from_bits(counter("max_wave_speed_squared_bits")? as u32),
            particles,
            drift,
            escaped,
            rigid: read_rigid_bodies(checkpoint, path)?,
        }),
    })
}

/// The spindrift of a snow checkpoint: none in one written before
/// spindrift existed (without the drift arrays), else all of it.
fn read_drift(checkpoint: &Checkpoint, path: &Path) -> Result<(Drift, Escaped), CheckpointError> {
    if checkpoint.array_bytes("drift_position").is_err() {
        return Ok((Drift::default(), Escaped::default()));
    }
    let drift = Drift {
        position: checkpoint.array("drift_position")?,
        velocity: checkpoint.array("drift_velocity")?,
        mass: checkpoint.array("drift_mass")?,
        volume: checkpoint.array("drift_volume")?,
        material: checkpoint.array("drift_material")?,
    };
    let escaped = Escaped {
        count: counter(checkpoint, path, "escaped_count")?,
        mass: f64::from_bits(counter(checkpoint, path, "escaped_mass_bits")?),
    };
    Ok((drift, escaped))
}

/// Reads a checkpoint written by [`flow_checkpoint`].
fn read_flow(checkpoint: &Checkpoint, path: &Path) -> Result<SavedCheckpoint, CheckpointError> {
    let counter = |name| counter(checkpoint, path, name);
    let snapshot = FlowSnapshot {
        substeps: counter("substeps")?,
        births: checkpoint.array("births")?,
        positions: checkpoint.array("positions")?,
        velocities: checkpoint.array("velocities")?,
        ages: checkpoint.array("ages")?,
        lifetimes: checkpoint.array("lifetimes")?,
        generations: checkpoint.array("generations")?,
        emitters: checkpoint.array("emitters")?,
        trail_capacity: counter("trail_capacity")? as u32,
        trail_head: counter("trail_head")? as u32,
        trail_points: checkpoint.array("trail_points")?,
        trail_lengths: checkpoint.array("trail_lengths")?,
        trail_generations: checkpoint.array("trail_generations")?,
    };
    Ok(SavedCheckpoint {
        frame: frame(checkpoint, path)?,
        scene_json: saved_scene(checkpoint),
        state: SolverState::Flow(snapshot),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_scene_read_back_from_its_checkpoint_text_is_the_same_scene() {
        // A block keyed through a turn, as the Blender add-on bakes one: its
        // quaternions' f32 values, written as JSON text and read back, must
        // parse to the very same numbers (serde_json's `float_roundtrip`),
        // or `--resume` refuses the scene that wrote the checkpoint.
        let keys = (0..=9).map(|k| {
            let angle = (k as f32 * 30.0 / 9.0).to_radians();
            firn_core::scene::Keyframe::new(f64::from(k) / 24.0, glam::Vec3::new(0.25, 0.15, -0.1))
                .rotated(glam::Quat::from_rotation_y(angle))
        });
        let mut scene = Scene::default();
        scene.colliders.push(
            firn_core::scene::Collider::cuboid(glam::Vec3::splat(0.5), glam::Vec3::splat(0.1))
                .keyframed(keys),
        );
        let written = scene_json(&scene);
        let read: serde_json::Value = serde_json::from_str(&written.to_string()).unwrap();
        assert!(same_physics(&read, &written));
    }

    #[test]
    fn scenes_that_differ_only_in_their_backend_simulate_the_same() {
        let before_compute = json!({ "name": "ball", "time": { "fps": 30.0 } });
        let on_gpu = json!({
            "name": "ball",
            "time": { "fps": 30.0 },
            "compute": { "backend": "gpu" }
        });
        let on_cpu = json!({
            "name": "ball",
            "time": { "fps": 30.0 },
            "compute": { "backend": "cpu" }
        });
        assert!(same_physics(&before_compute, &on_gpu));
        assert!(same_physics(&on_cpu, &on_gpu));
        let faster = json!({ "name": "ball", "time": { "fps": 60.0 } });
        assert!(!same_physics(&faster, &before_compute));
    }
}

/// What rank 0 of a run split between MPI ranks writes beside the ranks'
/// checkpoint pieces, once every piece is written: the frame, and the
/// pieces that hold its particles. A particle's key (the `key` array of
/// each piece) is its place in the one-process array, so the pieces,
/// merged by key, are the one process's checkpoint on any rank count.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PieceManifest {
    /// The frame the checkpoint was taken after.
    pub frame: u32,
    /// Particles over all pieces.
    pub particles: u64,
    /// The pieces, one per rank, relative to the run directory.
    pub pieces: Vec<String>,
}

/// Writes one rank's piece of a split run's checkpoint at `path`,
/// atomically: a snow checkpoint of its own particles (`snow`) and their
/// keys, each particle's place in the one-process array.
pub fn write_piece(
    snow: SnowView<'_>,
    keys: &[u64],
    frame: u32,
    scene_json: &serde_json::Value,
    path: &Path,
) -> Result<(), IoError> {
    let mut checkpoint = snow_checkpoint(snow, frame, scene_json);
    checkpoint.push_array("key", keys);
    checkpoint.write(path)
}

/// Writes `manifest` at `path`, atomically.
pub fn write_piece_manifest(manifest: &PieceManifest, path: &Path) -> Result<(), IoError> {
    firn_io::write_atomically(path, |out| {
        serde_json::to_writer_pretty(&mut *out, manifest).map_err(std::io::Error::other)?;
        out.write_all(b"\n")
    })
}

/// Reads the checkpoint pieces that the manifest at `path` names (paths
/// relative to `run_path`) and merges them by key into the one process's
/// checkpoint, refusing pieces that do not hold every particle exactly
/// once at one time.
pub fn read_pieces(
    path: &Path,
    run_path: &Path,
    scene: &Scene,
) -> Result<SavedCheckpoint, CheckpointError> {
    let implausible = |reason: String| CheckpointError::Implausible {
        path: path.to_path_buf(),
        reason,
    };
    let text = std::fs::read_to_string(path).map_err(|source| IoError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let manifest: PieceManifest = serde_json::from_str(&text)
        .map_err(|error| implausible(format!("it is not a piece manifest: {error}")))?;
    let mut merged: Option<(SavedCheckpoint, Vec<u64>)> = None;
    for piece in &manifest.pieces {
        let piece_path = run_path.join(piece);
        let checkpoint = Checkpoint::read(&piece_path)?;
        let saved = read_snow(&checkpoint, &piece_path)?;
        let SolverState::Snow(snapshot) = &saved.state else {
            unreachable!("read_snow reads snow");
        };
        let keys = checkpoint.array_of_len::<u64>("key", snapshot.particles.len())?;
        merged = Some(match merged {
            None => (saved, keys),
            Some((mut all, mut all_keys)) => {
                let (SolverState::Snow(whole), SolverState::Snow(part)) =
                    (&mut all.state, saved.state)
                else {
                    unreachable!("read_snow reads snow");
                };
                if saved.frame != all.frame || part.time.to_bits() != whole.time.to_bits() {
                    return Err(implausible(format!(
                        "piece {piece} is of frame {}, not {}",
                        saved.frame, all.frame
                    )));
                }
                whole.particles.append(part.particles);
                all_keys.extend(keys);
                (all, all_keys)
            }
        });
    }
    let (mut saved, keys) = merged.ok_or_else(|| implausible("it names no pieces".into()))?;
    let SolverState::Snow(snapshot) = &mut saved.state else {
        unreachable!("read_snow reads snow");
    };
    let mut order: Vec<u32> = (0..keys.len() as u32).collect();
    order.sort_unstable_by_key(|&p| keys[p as usize]);
    if let Some(place) = (0..keys.len()).find(|&place| keys[order[place] as usize] != place as u64)
    {
        return Err(implausible(format!(
            "its pieces do not hold every particle of {} exactly once (no particle {place})",
            keys.len()
        )));
    }
    if saved.frame != manifest.frame || keys.len() as u64 != manifest.particles {
        return Err(implausible(format!(
            "its pieces hold {} particles of frame {}, the manifest says {} of frame {}",
            keys.len(),
            saved.frame,
            manifest.particles,
            manifest.frame
        )));
    }
    snapshot
        .particles
        .permute(&order, &mut firn_mpm::PermuteBuffers::default());
    check_plausible(&saved, scene).map_err(implausible)?;
    Ok(saved)
}

/// The latest checkpoint of the run in `run` (one process's, or the
/// pieces of a run split between MPI ranks, whichever was taken after the
/// later frame), and the file it was read from.
pub fn read_latest(
    run: &RunDirectory,
    scene: &Scene,
) -> Result<(SavedCheckpoint, PathBuf), ResumeError> {
    let whole = run.checkpoint_path();
    let pieces = run.piece_manifest_path();
    let read_whole = || read(&whole, scene).map(|saved| (saved, whole.clone()));
    let read_split =
        || read_pieces(&pieces, run.path(), scene).map(|saved| (saved, pieces.clone()));
    let latest = match (whole.exists(), pieces.exists()) {
        (false, false) => return Err(ResumeError::NoCheckpoint { path: whole }),
        (true, false) => read_whole(),
        (false, true) => read_split(),
        (true, true) => read_whole().and_then(|one| {
            let split = read_split()?;
            Ok(if split.0.frame > one.0.frame {
                split
            } else {
                one
            })
        }),
    };
    Ok(latest.map_err(RunError::from)?)
}
