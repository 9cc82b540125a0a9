//! Turning solver state into files: per-frame caches and checkpoints.

use std::path::Path;

use firn_core::scene::{Attribute as SceneAttribute, CacheFormat, Scene};
use firn_io::{Attribute, Checkpoint, FrameData, IoError, PvdCollection, write_ply, write_vtp};
use firn_mpm::{Particles, Simulation, Snapshot};

/// Attribute arrays computed for output (those not stored by the solver).
struct DerivedAttributes {
    density: Vec<f32>,
    elastic_j: Vec<f32>,
    material: Vec<u32>,
}

/// Creates the cache folders for the scene's formats inside `directory`.
pub fn prepare_cache_dirs(scene: &Scene, directory: &Path) -> Result<(), IoError> {
    for format in &scene.output.formats {
        firn_io::ensure_writable_dir(&directory.join(cache_folder(*format)))?;
    }
    Ok(())
}

fn cache_folder(format: CacheFormat) -> &'static str {
    match format {
        CacheFormat::Ply => "ply",
        CacheFormat::Vtk => "vtk",
    }
}

/// Writes one frame's caches into `directory`; returns their relative paths.
pub fn write_frame(
    simulation: &Simulation,
    index: u32,
    directory: &Path,
    pvd: &mut PvdCollection,
) -> Result<Vec<String>, IoError> {
    let scene = simulation.scene();
    let particles = simulation.particles();
    let wanted = &scene.output.attributes;
    let derived = DerivedAttributes {
        density: if wanted.contains(&SceneAttribute::Density) {
            simulation.densities()
        } else {
            Vec::new()
        },
        elastic_j: if wanted.contains(&SceneAttribute::ElasticJ) {
            simulation.elastic_j()
        } else {
            Vec::new()
        },
        material: particles.material.iter().map(|&m| m as u32).collect(),
    };
    let mut frame = FrameData::new(index, simulation.time(), &particles.position);
    for attribute in wanted {
        frame = frame.with_attribute(attribute_data(*attribute, particles, &derived));
    }
    write_caches(scene, &frame, directory, pvd)
}

/// Writes `frame` in every cache format of the scene into `directory`;
/// returns the files' paths relative to `directory`.
pub fn write_caches(
    scene: &Scene,
    frame: &FrameData,
    directory: &Path,
    pvd: &mut PvdCollection,
) -> Result<Vec<String>, IoError> {
    let mut files = Vec::new();
    for format in &scene.output.formats {
        let extension = match format {
            CacheFormat::Ply => "ply",
            CacheFormat::Vtk => "vtp",
        };
        let name = format!(
            "{}/frame_{:05}.{extension}",
            cache_folder(*format),
            frame.index
        );
        let path = directory.join(&name);
        match format {
            CacheFormat::Ply => write_ply(&path, frame)?,
            CacheFormat::Vtk => {
                write_vtp(&path, frame)?;
                pvd.remove_after(frame.time - 1e-12);
                pvd.push(frame.time, name.clone());
                pvd.write(&directory.join("particles.pvd"))?;
            }
        }
        files.push(name);
    }
    Ok(files)
}

fn attribute_data<'a>(
    attribute: SceneAttribute,
    particles: &'a Particles,
    derived: &'a DerivedAttributes,
) -> Attribute<'a> {
    match attribute {
        SceneAttribute::Velocity => Attribute::vector("velocity", &particles.velocity),
        SceneAttribute::PlasticJ => Attribute::scalar("plastic_j", &particles.plastic_j),
        SceneAttribute::ElasticJ => Attribute::scalar("elastic_j", &derived.elastic_j),
        SceneAttribute::Density => Attribute::scalar("density", &derived.density),
        SceneAttribute::Mass => Attribute::scalar("mass", &particles.mass),
        SceneAttribute::Material => Attribute::integer("material", &derived.material),
    }
}

/// Writes a checkpoint of `simulation` taken after frame `frame`.
pub fn write_checkpoint(
    simulation: &Simulation,
    frame: u32,
    scene_json: &serde_json::Value,
    path: &Path,
) -> Result<(), IoError> {
    let snapshot = simulation.snapshot();
    let mut checkpoint = Checkpoint::new(serde_json::json!({
        "frame": frame,
        "time_bits": snapshot.time.to_bits(),
        "steps": snapshot.steps,
        "max_speed_squared_bits": snapshot.max_speed_squared.to_bits(),
        "max_wave_speed_squared_bits": snapshot.max_wave_speed_squared.to_bits(),
        "scene": scene_json,
    }));
    let p = &snapshot.particles;
    checkpoint.push_array("position", &p.position);
    checkpoint.push_array("velocity", &p.velocity);
    checkpoint.push_array("mass", &p.mass);
    checkpoint.push_array("volume0", &p.volume0);
    checkpoint.push_array("elastic", &p.elastic);
    checkpoint.push_array("plastic_j", &p.plastic_j);
    checkpoint.push_array("stress", &p.stress);
    checkpoint.push_array("velocity_gradient", &p.velocity_gradient);
    checkpoint.push_array("material", &p.material);
    checkpoint.write(path)
}

/// A checkpoint read back: the frame it was taken after and the solver state.
pub struct RestoredCheckpoint {
    /// Frame index the checkpoint follows.
    pub frame: u32,
    /// The resolved scene the run was started with.
    pub scene_json: serde_json::Value,
    /// Solver state.
    pub snapshot: Snapshot,
}

/// Reads a checkpoint written by [`write_checkpoint`].
pub fn read_checkpoint(path: &Path) -> Result<RestoredCheckpoint, String> {
    let checkpoint = Checkpoint::read(path).map_err(|error| error.to_string())?;
    let meta = &checkpoint.meta;
    let field = |name: &str| {
        meta.get(name)
            .and_then(serde_json::Value::as_u64)
            .ok_or_else(|| format!("checkpoint {} lacks `{name}`", path.display()))
    };
    let particles = Particles {
        position: checkpoint.array("position").map_err(|e| e.to_string())?,
        velocity: checkpoint.array("velocity").map_err(|e| e.to_string())?,
        mass: checkpoint.array("mass").map_err(|e| e.to_string())?,
        volume0: checkpoint.array("volume0").map_err(|e| e.to_string())?,
        elastic: checkpoint.array("elastic").map_err(|e| e.to_string())?,
        plastic_j: checkpoint.array("plastic_j").map_err(|e| e.to_string())?,
        stress: checkpoint.array("stress").map_err(|e| e.to_string())?,
        velocity_gradient: checkpoint
            .array("velocity_gradient")
            .map_err(|e| e.to_string())?,
        material: checkpoint.array("material").map_err(|e| e.to_string())?,
    };
    Ok(RestoredCheckpoint {
        frame: field("frame")? as u32,
        scene_json: meta.get("scene").cloned().unwrap_or_default(),
        snapshot: Snapshot {
            time: f64::from_bits(field("time_bits")?),
            steps: field("steps")?,
            max_speed_squared: f32::from_bits(field("max_speed_squared_bits")? as u32),
            max_wave_speed_squared: f32::from_bits(field("max_wave_speed_squared_bits")? as u32),
            particles,
        },
    })
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

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

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
