//! Changing a running simulation's materials or wind (an interactive
//! viewer's parameter panel), or throwing a rigid body in: which changes
//! are allowed, checked once here for both backends (`firn-gpu` calls
//! [`scene_with_materials`] and [`scene_with_wind`] too).

use firn_core::scene::{Material, RigidBody, Scene, SceneError, Wind};

use crate::simulation::SimulationError;

/// `scene` with its materials replaced by `materials`, for a change while
/// the simulation runs. Refused, with an error whose key names the field:
///
/// - another number of materials or other names, or another order (bodies
///   and particles refer to materials by index);
/// - another density ρ0 (the particles' masses were sampled from it, so a
///   new ρ0 would not reach them);
/// - anything the scene loader refuses ([`Scene::validate`], e.g. ν ≥ 0.5).
pub fn scene_with_materials(
    scene: &Scene,
    materials: &[Material],
) -> Result<Scene, SimulationError> {
    check_same_materials(&scene.materials, materials)?;
    let mut changed = scene.clone();
    changed.materials = materials.to_vec();
    changed
        .validate()
        .map_err(|error| SimulationError::Materials(Box::new(error)))?;
    Ok(changed)
}

/// `scene` with its wind replaced by `wind`, for a change while the
/// simulation runs: any wind the scene loader accepts ([`Scene::validate`]),
/// also where the scene had none.
pub fn scene_with_wind(scene: &Scene, wind: &Wind) -> Result<Scene, SimulationError> {
    let mut changed = scene.clone();
    changed.wind = Some(wind.clone());
    changed
        .validate()
        .map_err(|error| SimulationError::Wind(Box::new(error)))?;
    Ok(changed)
}

/// `body` checked as a rigid body joining `scene` while it runs: by the
/// scene loader's rules for a body ([`Scene::validate`]: its shape, mass and
/// contact, and that it starts clear of the colliders and the walls; the
/// other bodies have moved since their start, so it is not held to those).
pub fn check_new_rigid_body(scene: &Scene, body: &RigidBody) -> Result<(), SimulationError> {
    let mut alone = scene.clone();
    alone.rigid_bodies = vec![body.clone()];
    alone
        .validate()
        .map_err(|error| SimulationError::RigidBody(Box::new(error)))
}

/// The materials may change their parameters, but not their number, names,
/// order or density.
fn check_same_materials(running: &[Material], new: &[Material]) -> Result<(), SimulationError> {
    if new.len() != running.len() {
        return Err(refusal(
            "materials".into(),
            format!(
                "materials: {} given, but the running scene has {}; materials cannot be added \
                 or removed while it runs",
                new.len(),
                running.len()
            ),
            "pass every material of scene().materials, in its order, with changed parameters",
        ));
    }
    running
        .iter()
        .zip(new)
        .enumerate()
        .try_for_each(|(index, (old, new))| check_same_material(index, old, new))
}

/// Material `index` may change its parameters, but not its name or density.
fn check_same_material(
    index: usize,
    old: &Material,
    new: &Material,
) -> Result<(), SimulationError> {
    if new.name != old.name {
        let key = format!("materials.{}", new.name);
        return Err(refusal(
            key.clone(),
            format!(
                "{key} is not material {index} of the running scene, which is \"{}\"; \
                 materials cannot be renamed or reordered while it runs",
                old.name
            ),
            "keep the names and order of scene().materials",
        ));
    }
    if new.density.to_bits() != old.density.to_bits() {
        let key = format!("materials.{}.density", old.name);
        return Err(refusal(
            key.clone(),
            format!(
                "{key} cannot change while the simulation runs (it is {}, {} was given): \
                 the particles' masses were sampled from it",
                old.density, new.density
            ),
            "keep density; to try another one, restart from a scene with it",
        ));
    }
    Ok(())
}

/// A refused change, keyed like a scene error so a panel can point at the field.
fn refusal(key: String, message: String, hint: &str) -> SimulationError {
    SimulationError::Materials(Box::new(SceneError {
        file: String::new(),
        line: None,
        column: None,
        key: Some(key),
        message,
        hint: hint.to_string(),
    }))
}
