//! The curl-noise particle flow of seed 002 (after Bridson, Hourihan and
//! Nordenstam 2007, "Curl-noise for procedural fluid flow"): plain data for a
//! scene with `kind = "flow"`.
//!
//! The velocity is the curl of a vector potential ψ, so it is divergence-free:
//!
//! - turbulence (seed eq. 1): N(x) = γ M (n((x+ε₁)/L), n((x+ε₂)/L), n((x+ε₃)/L)),
//!   three simplex-noise samples at decorrelating offsets ε;
//! - background: F(x) = ½ (1 − γ) M_f (p × x), whose curl is the uniform flow
//!   (1 − γ) M_f p (the seed writes D(x) = x × p, whose curl is −2p);
//! - sphere obstacles (seed eq. 2-3, in Bridson's form):
//!   ψ' = α ψ + (1 − α) n̂ (n̂ · ψ) with α = ramp(d / d0);
//! - velocity (seed eq. 4) v = s · curl ψ', with one global speed scale s.
//!
//! `firn-flow` simulates it; `docs/scene-format.md` documents the keys.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::model::Domain;

/// What a scene simulates.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SceneKind {
    /// Snow with the Material Point Method (the thesis; `firn-mpm`).
    #[default]
    Snow,
    /// Particles carried by a curl-noise flow (seed 002; `firn-flow`).
    Flow(Box<FlowSettings>),
}

impl SceneKind {
    /// The flow settings, for a flow scene.
    pub fn flow(&self) -> Option<&FlowSettings> {
        match self {
            SceneKind::Snow => None,
            SceneKind::Flow(settings) => Some(settings),
        }
    }

    /// The name used in scene files: `"snow"` or `"flow"`.
    pub fn name(&self) -> &'static str {
        match self {
            SceneKind::Snow => "snow",
            SceneKind::Flow(_) => "flow",
        }
    }
}

/// The curl-noise field, its obstacles, the particle emitters and the
/// integration settings (seed 002, section 2.2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlowSettings {
    /// γ in [0, 1]: the share of turbulence against the background flow
    /// (seed eq. 1; 0: background only, 1: noise only).
    pub noise_share: f32,
    /// M: strength of the turbulence potential (seed eq. 1). The turbulent
    /// velocity is the curl of γ M n(x / L); its root-mean-square speed is
    /// about 4.2 γ M / L.
    pub noise_strength: f32,
    /// L: length scale of the noise in metres (seed eq. 1; about 20 in the
    /// seed's 100-unit scene).
    pub length_scale: f32,
    /// p: unit direction of the background flow.
    pub background_direction: Vec3,
    /// M_f: speed of the background flow before the share (1 − γ) and the
    /// speed scale are applied.
    pub background_strength: f32,
    /// One global factor on the velocity (never a per-point normalisation,
    /// which would break divergence-freeness).
    pub speed_scale: f32,
    /// Seed of the noise offsets ε and of every particle's random numbers.
    pub seed: u64,
    /// The offsets ε₁, ε₂, ε₃ in metres; `None`: drawn from `seed`.
    pub offsets: Option<[Vec3; 3]>,
    /// How fast the turbulence changes: each noise component's domain drifts
    /// at this many noise cells (units of L) per second, each in its own
    /// direction. 0: a steady field.
    pub evolution_rate: f32,
    /// How the curl is taken.
    pub curl: FlowCurl,
    /// How particles are moved through the field.
    pub integrator: FlowIntegrator,
    /// Integration steps per output frame.
    pub substeps: u32,
    /// Sphere obstacles the flow slides around.
    pub obstacles: Vec<FlowObstacle>,
    /// Where particles come from.
    pub emitters: Vec<FlowEmitter>,
}

impl FlowSettings {
    /// The defaults of the scene format for a domain whose longest edge is
    /// `extent` metres, with no obstacles and no emitters: the noise length
    /// scale L is a fifth of the extent (as in the seed's scene, L ≈ 20 in
    /// 100 units) and the turbulence strength M is L / 4, so that the
    /// turbulence's root-mean-square speed (about 4.2 γ M / L) is about γ
    /// times the background speed of 1. The rest: γ = 0.5, background along
    /// +x, speed scale 1, seed 1, offsets drawn from the seed, a steady
    /// field, the analytic curl, RK2 and 2 substeps per frame.
    pub fn for_extent(extent: f32) -> FlowSettings {
        let length_scale = FlowSettings::default_length_scale(extent);
        FlowSettings {
            noise_share: 0.5,
            noise_strength: FlowSettings::default_noise_strength(length_scale),
            length_scale,
            background_direction: Vec3::X,
            background_strength: 1.0,
            speed_scale: 1.0,
            seed: 1,
            offsets: None,
            evolution_rate: 0.0,
            curl: FlowCurl::Analytic,
            integrator: FlowIntegrator::Rk2,
            substeps: 2,
            obstacles: Vec::new(),
            emitters: Vec::new(),
        }
    }

    /// [`FlowSettings::for_extent`] of the longest edge of `domain`: the
    /// settings a scene file over that domain gets for the keys it leaves out.
    pub fn for_domain(domain: &Domain) -> FlowSettings {
        FlowSettings::for_extent((domain.max - domain.min).max_element())
    }

    /// The speed of the background flow, (1 − γ) M_f s, m/s.
    pub fn background_speed(&self) -> f32 {
        (1.0 - self.noise_share) * self.background_strength * self.speed_scale
    }

    /// About the root-mean-square speed of the turbulence, 4.2 γ M s / L,
    /// m/s (simplex noise's gradient has an rms of about 4.2 per noise cell).
    pub fn turbulence_speed(&self) -> f32 {
        4.2 * self.noise_share * self.noise_strength * self.speed_scale / self.length_scale
    }

    /// The default noise length scale L for a domain whose longest edge is
    /// `extent`: a fifth of it.
    pub fn default_length_scale(extent: f32) -> f32 {
        extent / 5.0
    }

    /// The default turbulence strength M for a noise length scale L: L / 4.
    pub fn default_noise_strength(length_scale: f32) -> f32 {
        length_scale / 4.0
    }

    /// The default step of the finite-difference curl for a noise length
    /// scale L: L / 1000.
    pub fn default_curl_step(length_scale: f32) -> f32 {
        length_scale / 1000.0
    }
}

impl Default for FlowSettings {
    /// The defaults of the scene format for a 100-unit domain
    /// ([`FlowSettings::for_extent`]`(100.0)`: L = 20, M = 5), with no
    /// obstacles and no emitters.
    fn default() -> FlowSettings {
        FlowSettings::for_extent(100.0)
    }
}

/// How the curl of the potential is computed (seed eq. 4).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "mode", rename_all = "kebab-case")]
pub enum FlowCurl {
    /// Exact, from the analytic derivatives of the noise and of the obstacle
    /// modulation (the default; cheaper and divergence-free to round-off).
    Analytic,
    /// Central differences of the potential, as the seed does.
    FiniteDifference {
        /// The difference step in metres.
        step: f32,
    },
}

/// The particle integrator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FlowIntegrator {
    /// Second-order Runge-Kutta (midpoint): two field evaluations per step.
    Rk2,
    /// Classic fourth-order Runge-Kutta: four field evaluations per step.
    Rk4,
}

/// A solid sphere the flow goes around (Bridson et al. 2007, section 3.2).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlowObstacle {
    /// Centre.
    pub center: Vec3,
    /// Radius.
    pub radius: f32,
    /// d0: distance from the surface over which the flow turns tangential.
    pub influence: f32,
}

impl FlowObstacle {
    /// A sphere whose influence reaches one radius from its surface (the
    /// default `influence`).
    pub fn new(center: Vec3, radius: f32) -> FlowObstacle {
        FlowObstacle {
            center,
            radius,
            influence: radius,
        }
    }

    /// The same obstacle with influence distance d0 = `influence` metres.
    pub fn influence(mut self, influence: f32) -> FlowObstacle {
        self.influence = influence;
        self
    }
}

/// A source of particles.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlowEmitter {
    /// The region particles are born in, uniformly.
    pub shape: FlowEmitterShape,
    /// A steady rate or a fixed number.
    pub emission: FlowEmission,
    /// Seconds a particle lives before it is born again at the emitter;
    /// `None`: forever.
    pub lifetime: Option<f32>,
    /// Relative spread of the lifetime in [0, 1): each life lasts
    /// lifetime × (1 + spread × u) with u uniform in [−1, 1).
    pub lifetime_spread: f32,
    /// Extra velocity at birth, added to the flow's and fading as
    /// exp(−age / velocity_decay).
    pub velocity: Vec3,
    /// Seconds over which `velocity` fades by a factor e.
    pub velocity_decay: f32,
}

impl FlowEmitter {
    /// An emitter over `shape` with the defaults of the scene format: its
    /// particles live forever (no lifetime, spread 0) and are born with no
    /// extra velocity (decay time 1 s).
    pub fn new(shape: FlowEmitterShape, emission: FlowEmission) -> FlowEmitter {
        FlowEmitter {
            shape,
            emission,
            lifetime: None,
            lifetime_spread: 0.0,
            velocity: Vec3::ZERO,
            velocity_decay: 1.0,
        }
    }

    /// `count` particles born in `shape` at time 0 (`count = ...`).
    pub fn count(shape: FlowEmitterShape, count: u32) -> FlowEmitter {
        FlowEmitter::new(shape, FlowEmission::Count(count))
    }

    /// `rate` particles born per second in `shape` (`rate = ...`).
    pub fn rate(shape: FlowEmitterShape, rate: f32) -> FlowEmitter {
        FlowEmitter::new(shape, FlowEmission::Rate(rate))
    }

    /// The same emitter whose particles live `seconds` before they are born
    /// again.
    pub fn lifetime(mut self, seconds: f32) -> FlowEmitter {
        self.lifetime = Some(seconds);
        self
    }

    /// The same emitter with a relative lifetime spread in [0, 1).
    pub fn lifetime_spread(mut self, spread: f32) -> FlowEmitter {
        self.lifetime_spread = spread;
        self
    }

    /// The same emitter with an extra birth velocity that fades by a factor
    /// e every `decay` seconds.
    pub fn velocity(mut self, velocity: Vec3, decay: f32) -> FlowEmitter {
        self.velocity = velocity;
        self.velocity_decay = decay;
        self
    }

    /// Particle slots the emitter needs over a run of `duration` seconds.
    ///
    /// A `count` emitter has exactly that many. A `rate` emitter with a
    /// lifetime has ceil(rate × lifetime) (a particle that expires is born
    /// again at once, so on average `rate` particles are born per second);
    /// without a lifetime it has one per birth up to the end of the run,
    /// floor(rate × duration) + 1.
    pub fn slots(&self, duration: f64) -> u64 {
        match self.emission {
            FlowEmission::Count(count) => u64::from(count),
            FlowEmission::Rate(rate) => {
                let rate = f64::from(rate);
                let slots = match self.lifetime {
                    Some(lifetime) => (rate * f64::from(lifetime)).ceil(),
                    None => (rate * duration.max(0.0)).floor() + 1.0,
                };
                if slots.is_finite() {
                    slots.clamp(1.0, u64::MAX as f64) as u64
                } else {
                    u64::MAX
                }
            }
        }
    }
}

/// The region an emitter fills.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "kebab-case")]
pub enum FlowEmitterShape {
    /// An axis-aligned box.
    Box {
        /// Centre.
        center: Vec3,
        /// Edge lengths along x, y, z.
        size: Vec3,
    },
    /// A ball.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
    },
    /// A flat disc (no thickness).
    Disc {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
        /// Unit normal of the disc's plane.
        normal: Vec3,
    },
}

impl FlowEmitterShape {
    /// Centre of the region.
    pub fn center(&self) -> Vec3 {
        match *self {
            FlowEmitterShape::Box { center, .. }
            | FlowEmitterShape::Sphere { center, .. }
            | FlowEmitterShape::Disc { center, .. } => center,
        }
    }

    /// Axis-aligned bounding box as (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match *self {
            FlowEmitterShape::Box { center, size } => (center - 0.5 * size, center + 0.5 * size),
            FlowEmitterShape::Sphere { center, radius } => (center - radius, center + radius),
            FlowEmitterShape::Disc {
                center,
                radius,
                normal,
            } => {
                // Per axis, the disc reaches radius · sqrt(1 − n_axis²).
                let half = (Vec3::ONE - normal * normal).max(Vec3::ZERO).powf(0.5) * radius;
                (center - half, center + half)
            }
        }
    }
}

/// How many particles an emitter makes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FlowEmission {
    /// Particles born per second, one after another from time 0.
    Rate(f32),
    /// A fixed number, all born at time 0.
    Count(u32),
}
