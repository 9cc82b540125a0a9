//! Changing a flow's field while it runs (an interactive viewer's panel):
//! the new settings are checked as a scene is, and the emitters and
//! substeps, which the particle slots and the clock are planned from, stay.

use firn_core::scene::{FlowSettings, Scene, SceneKind};

use super::{FlowError, FlowSimulation, push_out_all, refresh_velocities};
use crate::field::FlowField;
use firn_core::scene::SceneError;

impl FlowSimulation {
    /// Replaces the field's parameters while the flow runs (an interactive
    /// viewer's parameter panel), from the next substep on: γ, M, L, the
    /// background flow, the speed scale, the evolution rate, the curl, the
    /// integrator, the seed and the obstacles. Checked as a scene is
    /// ([`scene_with_settings`]); the emitters and substeps cannot change.
    /// The particles keep their state, except that those inside a (new or
    /// grown) sphere are pushed out of it and every velocity is taken from
    /// the new field, as at the start of a run.
    pub fn set_settings(&mut self, settings: FlowSettings) -> Result<(), FlowError> {
        let scene = scene_with_settings(&self.scene, settings)?;
        let settings = scene.kind.flow().ok_or(FlowError::NotAFlowScene)?;
        self.field = FlowField::new(settings);
        self.settings = settings.clone();
        self.scene = scene;
        push_out_all(&self.settings, &mut self.particles.positions);
        let time = self.time();
        refresh_velocities(
            self.simd,
            &self.field,
            &self.settings,
            time,
            &mut self.particles,
        );
        Ok(())
    }
}

/// `scene` with its flow settings replaced by `settings`, for a change while
/// the flow runs (both backends check it so). The background direction is
/// normalised, as the scene loader does; then every rule of the scene format
/// applies ([`Scene::validate`]). The emitters cannot change (the particle
/// slots and births are planned from them), nor can the substeps per frame
/// (the clock counts them); the error's key names the field.
pub fn scene_with_settings(scene: &Scene, mut settings: FlowSettings) -> Result<Scene, FlowError> {
    let running = scene.kind.flow().ok_or(FlowError::NotAFlowScene)?;
    check_fixed_settings(running, &settings)?;
    let direction = settings.background_direction;
    let length = direction.length();
    if length > 0.0 && length.is_finite() {
        settings.background_direction = direction / length;
    }
    let mut changed = scene.clone();
    changed.kind = SceneKind::Flow(Box::new(settings));
    changed
        .validate()
        .map_err(|error| FlowError::Scene(Box::new(error)))?;
    Ok(changed)
}

/// The settings a running flow cannot change: its emitters and substeps.
fn check_fixed_settings(running: &FlowSettings, new: &FlowSettings) -> Result<(), FlowError> {
    if new.emitters != running.emitters {
        return Err(refusal(
            "flow.emitters",
            "flow.emitters cannot change while the flow runs: the particles' slots and births \
             are planned from them"
                .into(),
            "keep settings().emitters; to try other emitters, restart from a scene with them",
        ));
    }
    if new.substeps != running.substeps {
        return Err(refusal(
            "flow.substeps",
            format!(
                "flow.substeps cannot change while the flow runs (it is {}, {} was given): the \
                 clock counts substeps",
                running.substeps, new.substeps
            ),
            "keep settings().substeps; to try another, restart from a scene with it",
        ));
    }
    Ok(())
}

/// A refused change, keyed like a scene error so a panel can point at the field.
fn refusal(key: &str, message: String, hint: &str) -> FlowError {
    FlowError::Scene(Box::new(SceneError {
        file: String::new(),
        line: None,
        column: None,
        key: Some(key.to_string()),
        message,
        hint: hint.to_string(),
    }))
}
