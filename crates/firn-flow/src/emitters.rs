//! Where and when particles are born (the seed's particles start in a region
//! and are moved by the field; firn adds rates, lifetimes and rebirth).
//!
//! Every draw comes from [`crate::random`] keyed by (seed, particle id,
//! generation), so a particle's birth place and lifetime do not depend on
//! the thread count or on other particles.

use firn_core::scene::{FlowEmission, FlowEmitter, FlowEmitterShape};
use glam::Vec3;

use crate::random;

/// Random streams of one life.
const STREAM_POSITION: u64 = 0;
const STREAM_LIFETIME: u64 = 3;

/// A uniformly random point of the emitter's region for life `generation`
/// of particle `id`.
pub fn birth_position(emitter: &FlowEmitter, seed: u64, id: u64, generation: u64) -> Vec3 {
    let u = |k: u64| random::unit(seed, id, generation, STREAM_POSITION + k);
    match emitter.shape {
        FlowEmitterShape::Box { center, size } => {
            center + (Vec3::new(u(0), u(1), u(2)) - 0.5) * size
        }
        FlowEmitterShape::Sphere { center, radius } => {
            // Uniform in the ball: direction uniform on the sphere, radius ∝ cbrt(u).
            let z = 2.0 * u(0) - 1.0;
            let angle = std::f32::consts::TAU * u(1);
            let ring = (1.0 - z * z).max(0.0).sqrt();
            let direction = Vec3::new(ring * angle.cos(), ring * angle.sin(), z);
            center + direction * radius * u(2).cbrt()
        }
        FlowEmitterShape::Disc {
            center,
            radius,
            normal,
        } => {
            // Uniform over the area: radius ∝ sqrt(u).
            let (tangent, bitangent) = normal.any_orthonormal_pair();
            let angle = std::f32::consts::TAU * u(0);
            let r = radius * u(1).sqrt();
            center + (tangent * angle.cos() + bitangent * angle.sin()) * r
        }
    }
}

/// How long life `generation` of particle `id` lasts, in seconds
/// (infinite without a lifetime).
pub fn lifetime(emitter: &FlowEmitter, seed: u64, id: u64, generation: u64) -> f32 {
    match emitter.lifetime {
        None => f32::INFINITY,
        Some(lifetime) => {
            let u = random::unit(seed, id, generation, STREAM_LIFETIME);
            lifetime * (1.0 + emitter.lifetime_spread * (2.0 * u - 1.0))
        }
    }
}

/// Particles a `rate` emitter has made by time `t` (particle k is born at
/// k / rate), at most `slots`; a `count` emitter makes all at time 0.
pub fn births_by(emitter: &FlowEmitter, slots: u64, t: f64) -> u64 {
    match emitter.emission {
        FlowEmission::Count(count) => u64::from(count),
        FlowEmission::Rate(rate) => {
            let born = (t * f64::from(rate) + 1e-9).floor() + 1.0;
            (born.max(0.0) as u64).min(slots)
        }
    }
}

/// The time particle `k` of a `rate` emitter is born (0 for `count`).
pub fn birth_time(emitter: &FlowEmitter, k: u64) -> f64 {
    match emitter.emission {
        FlowEmission::Count(_) => 0.0,
        FlowEmission::Rate(rate) => k as f64 / f64::from(rate),
    }
}

/// The birth velocity's displacement over (age, age + dt): the integral of
/// u₀ exp(−a / τ), added after the flow's step.
pub fn kick(emitter: &FlowEmitter, age: f32, dt: f32) -> Vec3 {
    if emitter.velocity == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let tau = emitter.velocity_decay;
    let faded = (-age / tau).exp() - (-(age + dt) / tau).exp();
    emitter.velocity * (tau * faded)
}

/// The birth velocity still left at `age`.
pub fn kick_velocity(emitter: &FlowEmitter, age: f32) -> Vec3 {
    if emitter.velocity == Vec3::ZERO {
        return Vec3::ZERO;
    }
    emitter.velocity * (-age / emitter.velocity_decay).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn emitter(shape: FlowEmitterShape) -> FlowEmitter {
        FlowEmitter {
            shape,
            emission: FlowEmission::Rate(10.0),
            lifetime: Some(2.0),
            lifetime_spread: 0.5,
            velocity: Vec3::ZERO,
            velocity_decay: 1.0,
        }
    }

    #[test]
    fn births_stay_inside_their_shapes() {
        let center = Vec3::new(1.0, 2.0, 3.0);
        let shapes = [
            FlowEmitterShape::Box {
                center,
                size: Vec3::new(2.0, 4.0, 6.0),
            },
            FlowEmitterShape::Sphere {
                center,
                radius: 2.0,
            },
            FlowEmitterShape::Disc {
                center,
                radius: 2.0,
                normal: Vec3::new(0.0, 0.6, 0.8),
            },
        ];
        for shape in shapes {
            let emitter = emitter(shape);
            let mut mean = Vec3::ZERO;
            for id in 0..4000 {
                let x = birth_position(&emitter, 5, id, 1);
                let (low, high) = shape.bounds();
                assert!(
                    x.cmpge(low - 1e-5).all() && x.cmple(high + 1e-5).all(),
                    "{x}"
                );
                match shape {
                    FlowEmitterShape::Sphere { radius, .. } => {
                        assert!(x.distance(center) <= radius * 1.0001)
                    }
                    FlowEmitterShape::Disc { normal, .. } => {
                        assert!((x - center).dot(normal).abs() < 1e-5)
                    }
                    FlowEmitterShape::Box { .. } => {}
                }
                mean += x / 4000.0;
            }
            assert!(mean.distance(center) < 0.1, "{shape:?}: {mean}");
            let life = lifetime(&emitter, 5, 9, 2);
            assert!((1.0..=3.0).contains(&life), "{life}");
        }
    }

    #[test]
    fn rate_births_follow_the_schedule() {
        let emitter = emitter(FlowEmitterShape::Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        });
        assert_eq!(births_by(&emitter, 20, 0.0), 1);
        assert_eq!(births_by(&emitter, 20, 0.25), 3);
        assert_eq!(
            births_by(&emitter, 20, 0.3),
            4,
            "k = 3 is born at exactly 0.3"
        );
        assert_eq!(births_by(&emitter, 20, 100.0), 20);
        assert_eq!(birth_time(&emitter, 3), 0.3);
    }

    #[test]
    fn kick_integrates_the_fading_velocity() {
        let mut emitter = emitter(FlowEmitterShape::Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        });
        emitter.velocity = Vec3::new(2.0, 0.0, 0.0);
        emitter.velocity_decay = 0.5;
        // Over all time the displacement is u₀ τ.
        let total: f32 = (0..10_000)
            .map(|i| kick(&emitter, i as f32 * 0.01, 0.01).x)
            .sum();
        assert!((total - 1.0).abs() < 1e-3, "{total}");
        assert_eq!(kick_velocity(&emitter, 0.0), emitter.velocity);
    }
}
