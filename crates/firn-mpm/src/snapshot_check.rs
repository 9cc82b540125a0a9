//! Whether a [`Snapshot`] can continue a simulation of a scene, checked the
//! same way by every backend before it takes the snapshot on.

use firn_core::scene::Scene;

use crate::simulation::{SimulationError, Snapshot};

impl Snapshot {
    /// `Ok` when this snapshot can continue a simulation of `scene`: some
    /// particles, their arrays of one length, and every particle and drift
    /// particle of a material the scene has.
    pub fn check(&self, scene: &Scene) -> Result<(), SimulationError> {
        let mismatch = |what: &str| Err(SimulationError::SnapshotMismatch(what.into()));
        let particles = &self.particles;
        let count = particles.len();
        let lengths = [
            particles.velocity.len(),
            particles.mass.len(),
            particles.volume0.len(),
            particles.elastic.len(),
            particles.plastic_j.len(),
            particles.stress.len(),
            particles.velocity_gradient.len(),
            particles.material.len(),
        ];
        if count == 0 || lengths.iter().any(|&len| len != count) {
            return mismatch("particle arrays are empty or of different lengths");
        }
        let materials = scene.materials.len();
        if particles.material.iter().any(|&m| m as usize >= materials) {
            return mismatch("a particle refers to an unknown material");
        }
        let drift = &self.drift;
        if !drift.is_consistent() || drift.material.iter().any(|&m| m as usize >= materials) {
            return mismatch("the drift arrays differ in length or refer to an unknown material");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::Simulation;
    use crate::view::tests::ball;

    #[test]
    fn snapshots_that_do_not_fit_the_scene_are_refused() {
        let scene = ball();
        let snapshot = Simulation::new(scene.clone()).unwrap().snapshot();
        assert!(snapshot.check(&scene).is_ok());
        let mut short = snapshot.clone();
        short.particles.mass.pop();
        let mut unknown = snapshot.clone();
        unknown.particles.material[0] = 1;
        let mut drift = snapshot;
        drift.drift.material.push(0);
        for refused in [short, unknown, drift] {
            let error = refused.check(&scene).unwrap_err().to_string();
            assert!(error.contains("the checkpoint does not match"), "{error}");
        }
    }
}
