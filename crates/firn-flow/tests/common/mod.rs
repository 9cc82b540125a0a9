//! Scenes and random points shared by the flow tests.

#![allow(dead_code)]

use firn_core::Scene;
use firn_core::scene::FlowSettings;
use glam::DVec3;

/// A flow scene from the body of its [flow] table (and any [[flow.*]]
/// tables after it), in a cube of side `size`.
pub fn scene(flow: &str, size: f32, duration: f64, fps: f64) -> Scene {
    let text = format!(
        "format = 1\nkind = \"flow\"\n\n[domain]\nmax = [{size:?}, {size:?}, {size:?}]\n\n\
         [time]\nduration = {duration:?}\nfps = {fps:?}\n\n[flow]\n{flow}"
    );
    Scene::from_toml_str(&text, "test.toml").unwrap_or_else(|err| panic!("{err}\n{text}"))
}

/// The flow settings of a scene.
pub fn settings(scene: &Scene) -> FlowSettings {
    scene.kind.flow().expect("a flow scene").clone()
}

/// Reproducible uniform numbers in [0, 1).
pub struct Points {
    seed: u64,
    next: u64,
}

impl Points {
    pub fn new(seed: u64) -> Points {
        Points { seed, next: 0 }
    }

    pub fn unit(&mut self) -> f64 {
        self.next += 1;
        firn_flow::random::unit_f64(self.seed, self.next, 0, 0)
    }

    /// Uniform in the box `low..high`.
    pub fn in_box(&mut self, low: DVec3, high: DVec3) -> DVec3 {
        low + DVec3::new(self.unit(), self.unit(), self.unit()) * (high - low)
    }

    /// A uniformly random unit vector.
    pub fn direction(&mut self) -> DVec3 {
        let z = 2.0 * self.unit() - 1.0;
        let angle = std::f64::consts::TAU * self.unit();
        let ring = (1.0 - z * z).sqrt();
        DVec3::new(ring * angle.cos(), ring * angle.sin(), z)
    }
}

/// The [flow] body of the obstacle scene most field tests use: turbulence
/// and background in a 100 m box around two spheres whose influence zones do
/// not overlap, with a drifting noise domain.
pub const OBSTACLES: &str = "noise_share = 0.5
length_scale = 20.0
background_direction = [1.0, 0.3, 0.2]
background_strength = 1.0
evolution_rate = 0.3
seed = 3

[[flow.obstacles]]
center = [50.0, 50.0, 50.0]
radius = 12.0
influence = 8.0

[[flow.obstacles]]
center = [20.0, 75.0, 30.0]
radius = 5.0
influence = 5.0

[[flow.emitters]]
shape = \"box\"
center = [50.0, 50.0, 50.0]
size = [100.0, 100.0, 100.0]
count = 1
";
