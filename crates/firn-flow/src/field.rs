//! The velocity field v = s · curl ψ' of seed 002 (after Bridson et al. 2007).
//!
//! The vector potential is turbulence plus background (seed §2.2):
//!
//! ```text
//! ψ(x, t) = γ M (n(q₁), n(q₂), n(q₃)) + ½ (1 − γ) M_f (p × (x − o))       (eq. 1)
//! q_c = (x + ε_c) / L + t · w_c
//! ```
//!
//! - n is simplex noise ([`crate::noise`]); the offsets ε_c decorrelate the
//!   three components (sampling them at one point makes the particles drift,
//!   seed §3.1); w_c is the drift of component c's noise domain, `evolution_rate`
//!   noise cells per second in a direction of its own, so the turbulence
//!   changes shape over time while staying divergence-free at every instant.
//! - curl(p × x) = 2p, so the background term gives the uniform flow
//!   (1 − γ) M_f p. The seed writes D(x) = x × p, whose curl is −2p (a flow
//!   against p at twice the speed); firn uses −½ D so that
//!   `background_strength` is the speed along `background_direction`.
//! - The origin o of the background potential does not change its curl, but
//!   it does change how an obstacle bends it; o is the centre of the sphere
//!   that modulates the point ([`crate::obstacles`]), or the world origin in
//!   a scene without spheres. The flow then passes each sphere symmetrically.
//!
//! The velocity is v = s · curl ψ' (seed eq. 4) with one global speed scale
//! s: never normalised point by point, which would break divergence-freeness.
//! The curl is exact by default, from the analytic noise gradients and the
//! product rule through the obstacle modulation; the finite-difference mode
//! takes central differences of ψ' with a settable step, as the seed does.

use firn_core::scene::{FlowCurl, FlowObstacle, FlowSettings};
use glam::{DVec3, Vec3};

use crate::integrate::Simd;
use crate::lanes::{F32s, Real, V3, add3, cross3, scale3, sub3};
use crate::noise::NOISE_SCALE;
use crate::obstacles::{self, Sphere};
use crate::random;

/// Streams of the seed's random numbers used by the field (particles use
/// their ids; these ids are out of their range).
const FIELD_ID: u64 = u64::MAX;

/// Default offsets ε_c / L are uniform in this many noise cells either way:
/// far beyond the noise's correlation length of about one cell.
const OFFSET_SPAN: f64 = 16.0;

/// The curl-noise velocity field of a flow scene, evaluated at any point and
/// time, in `f32` (the bits the simulation uses) or `f64` (the reference).
#[derive(Clone, Debug, PartialEq)]
pub struct FlowField {
    /// γ M.
    turbulence: f64,
    /// 1 / L.
    inv_length: f64,
    /// (1 − γ) M_f.
    background: f64,
    /// p.
    direction: DVec3,
    /// s.
    speed: f64,
    /// ε_c / L, in noise cells.
    offsets: [DVec3; 3],
    /// w_c, in noise cells per second.
    drift: [DVec3; 3],
    obstacles: Vec<FlowObstacle>,
    curl: FlowCurl,
}

/// Where each component's noise domain sits, in noise cells: the offsets
/// ε_c / L and the drift velocities w_c of seed eq. 1, drawn from the
/// scene's seed unless the scene gives the offsets. Shared with the GPU
/// backend, which must draw the same numbers.
pub fn noise_domains(settings: &FlowSettings) -> ([DVec3; 3], [DVec3; 3]) {
    let length = f64::from(settings.length_scale);
    let seed = settings.seed;
    let offsets = match settings.offsets {
        Some(offsets) => offsets.map(|offset| offset.as_dvec3() / length),
        None => std::array::from_fn(|c| {
            DVec3::from_array(std::array::from_fn(|axis| {
                let u = random::unit_f64(seed, FIELD_ID, c as u64, axis as u64);
                (2.0 * u - 1.0) * OFFSET_SPAN
            }))
        }),
    };
    let rate = f64::from(settings.evolution_rate);
    let drift = std::array::from_fn(|c| {
        // A uniformly random direction per component.
        let u = random::unit_f64(seed, FIELD_ID, 3 + c as u64, 0);
        let v = random::unit_f64(seed, FIELD_ID, 3 + c as u64, 1);
        let z = 2.0 * u - 1.0;
        let ring = (1.0 - z * z).max(0.0).sqrt();
        let angle = std::f64::consts::TAU * v;
        DVec3::new(ring * angle.cos(), ring * angle.sin(), z) * rate
    });
    (offsets, drift)
}

impl FlowField {
    /// The field of a flow scene's settings (seed eq. 1-4).
    pub fn new(settings: &FlowSettings) -> FlowField {
        let length = f64::from(settings.length_scale);
        let (offsets, drift) = noise_domains(settings);
        let gamma = f64::from(settings.noise_share);
        FlowField {
            turbulence: gamma * f64::from(settings.noise_strength),
            inv_length: 1.0 / length,
            background: (1.0 - gamma) * f64::from(settings.background_strength),
            direction: settings.background_direction.as_dvec3(),
            speed: f64::from(settings.speed_scale),
            offsets,
            drift,
            obstacles: settings.obstacles.clone(),
            curl: settings.curl,
        }
    }

    /// How the curl is taken.
    pub fn curl(&self) -> FlowCurl {
        self.curl
    }

    /// The same field with the curl taken another way.
    pub fn with_curl(mut self, curl: FlowCurl) -> FlowField {
        self.curl = curl;
        self
    }

    /// The offsets ε₁, ε₂, ε₃ in metres (seed eq. 1).
    pub fn offsets(&self) -> [Vec3; 3] {
        self.offsets
            .map(|offset| (offset / self.inv_length).as_vec3())
    }

    /// The velocity at `x` and time `t`, in `f32`: bit for bit what the
    /// simulation uses.
    pub fn velocity(&self, x: Vec3, t: f64) -> Vec3 {
        let prepared = self.prepare::<F32s<1>>(t);
        let v = velocity_lanes(&prepared, [F32s([x.x]), F32s([x.y]), F32s([x.z])]);
        Vec3::new(v[0].0[0], v[1].0[0], v[2].0[0])
    }

    /// The velocities at `positions` at time `t`, into `velocities` (of the
    /// same length), in batches of the lanes of `simd` where the CPU has it:
    /// bit for bit [`FlowField::velocity`] at each point.
    pub fn velocities(&self, simd: Simd, t: f64, positions: &[Vec3], velocities: &mut [Vec3]) {
        assert_eq!(
            positions.len(),
            velocities.len(),
            "one velocity per position"
        );
        crate::integrate::evaluate(simd, self, t, positions, velocities);
    }

    /// The modulated potential ψ'(x, t), in `f32`.
    pub fn potential(&self, x: Vec3, t: f64) -> Vec3 {
        let prepared = self.prepare::<F32s<1>>(t);
        let x = [F32s([x.x]), F32s([x.y]), F32s([x.z])];
        let sphere = prepared.sphere_for(x);
        let psi = potential_lanes(&prepared, x, sphere.as_ref());
        Vec3::new(psi[0].0[0], psi[1].0[0], psi[2].0[0])
    }

    /// The velocity at `x` and time `t`, evaluated in `f64`.
    pub fn velocity_f64(&self, x: DVec3, t: f64) -> DVec3 {
        let prepared = self.prepare::<f64>(t);
        DVec3::from_array(velocity_lanes(&prepared, x.to_array()))
    }

    /// The modulated potential ψ'(x, t), evaluated in `f64`.
    pub fn potential_f64(&self, x: DVec3, t: f64) -> DVec3 {
        let prepared = self.prepare::<f64>(t);
        let x = x.to_array();
        let sphere = prepared.sphere_for(x);
        DVec3::from_array(potential_lanes(&prepared, x, sphere.as_ref()))
    }

    /// The constants of the field at time `t`, in lane type `R`.
    pub(crate) fn prepare<R: Real>(&self, t: f64) -> Prepared<R> {
        let v3 = |v: DVec3| [R::splat(v.x), R::splat(v.y), R::splat(v.z)];
        // The drifted offsets are formed in f64, so long runs keep precision.
        let offsets = std::array::from_fn(|c| v3(self.offsets[c] + self.drift[c] * t));
        let spheres = self
            .obstacles
            .iter()
            .map(|obstacle| {
                let radius = f64::from(obstacle.radius);
                let influence = f64::from(obstacle.influence);
                let reach = (radius + influence) * (1.0 + obstacles::REACH_MARGIN);
                Sphere {
                    center: v3(obstacle.center.as_dvec3()),
                    radius: R::splat(radius),
                    inv_influence: R::splat(1.0 / influence),
                    reach_squared: R::splat(reach * reach),
                }
            })
            .collect();
        let (finite_difference, step) = match self.curl {
            FlowCurl::Analytic => (false, 1.0),
            FlowCurl::FiniteDifference { step } => (true, f64::from(step)),
        };
        Prepared {
            inv_length: R::splat(self.inv_length),
            turbulence: R::splat(self.turbulence * NOISE_SCALE),
            turbulence_gradient: R::splat(self.turbulence * NOISE_SCALE * self.inv_length),
            background: R::splat(self.background),
            half_background: R::splat(0.5 * self.background),
            direction: v3(self.direction),
            speed: R::splat(self.speed),
            offsets,
            spheres,
            finite_difference,
            step: R::splat(step),
            inv_two_steps: R::splat(0.5 / step),
        }
    }
}

/// The field's constants at one time, in lane type `R`.
#[derive(Clone, Debug)]
pub(crate) struct Prepared<R: Real> {
    inv_length: R,
    /// γ M times the noise's scale (the lanes' noise is unscaled).
    turbulence: R,
    /// γ M / L times the noise's scale.
    turbulence_gradient: R,
    background: R,
    half_background: R,
    direction: V3<R>,
    speed: R,
    offsets: [V3<R>; 3],
    spheres: Vec<Sphere<R>>,
    finite_difference: bool,
    step: R,
    inv_two_steps: R,
}

impl<R: Real> Prepared<R> {
    /// The sphere that modulates each lane, if the scene has spheres.
    #[inline(always)]
    fn sphere_for(&self, x: V3<R>) -> Option<Sphere<R>> {
        (!self.spheres.is_empty()).then(|| obstacles::most_influential(&self.spheres, x).0)
    }

    /// The noise coordinate of component c.
    #[inline(always)]
    fn noise_point(&self, x: V3<R>, c: usize) -> V3<R> {
        [
            x[0] * self.inv_length + self.offsets[c][0],
            x[1] * self.inv_length + self.offsets[c][1],
            x[2] * self.inv_length + self.offsets[c][2],
        ]
    }
}

/// The velocity in lanes, by the field's curl mode.
#[inline(always)]
pub(crate) fn velocity_lanes<R: Real>(prepared: &Prepared<R>, x: V3<R>) -> V3<R> {
    if prepared.finite_difference {
        velocity_finite_difference(prepared, x)
    } else {
        velocity_analytic(prepared, x)
    }
}

/// The exact curl: three noise samples with gradients give ψ and its
/// Jacobian; the obstacle terms are only computed when some lane is within
/// some sphere's influence distance.
#[inline(always)]
fn velocity_analytic<R: Real>(prepared: &Prepared<R>, x: V3<R>) -> V3<R> {
    // Written out, not a loop over arrays set to zero first (which became a
    // call to `memset` per evaluation) nor closures (which do not inherit
    // the caller's target features).
    let (n0, g0) = R::simplex(prepared.noise_point(x, 0));
    let (n1, g1) = R::simplex(prepared.noise_point(x, 1));
    let (n2, g2) = R::simplex(prepared.noise_point(x, 2));
    let psi = [
        prepared.turbulence * n0,
        prepared.turbulence * n1,
        prepared.turbulence * n2,
    ];
    // jacobian[c] = ∇ψ_c, a row of ∂ψ/∂x.
    let gradient = prepared.turbulence_gradient;
    let jacobian = [
        scale3(gradient, g0),
        scale3(gradient, g1),
        scale3(gradient, g2),
    ];
    let mut v = add3(
        [
            jacobian[2][1] - jacobian[1][2],
            jacobian[0][2] - jacobian[2][0],
            jacobian[1][0] - jacobian[0][1],
        ],
        scale3(prepared.background, prepared.direction),
    );
    // Lanes with d / d0 ≥ 1 get α = 1 and unchanged bits, so the terms are
    // skipped when no lane of the batch is within reach of a sphere.
    let near =
        !prepared.spheres.is_empty() && R::any(obstacles::within_reach(&prepared.spheres, x));
    if near {
        let (sphere, _) = obstacles::most_influential(&prepared.spheres, x);
        let rel = sub3(x, sphere.center);
        let p = prepared.direction;
        let half = prepared.half_background;
        // ψ with the background about the sphere's centre; its Jacobian adds
        // ½ M [p]×, whose transpose applied to n̂ is ½ M (n̂ × p).
        let psi = add3(psi, scale3(half, cross3(p, rel)));
        v = obstacles::modulate_curl(&sphere, x, psi, &jacobian, half, p, v);
    }
    scale3(prepared.speed, v)
}

/// ψ'(x) with the given modulating sphere (the caller picks it once per
/// point, so a difference stencil sees one smooth function).
#[inline(always)]
fn potential_lanes<R: Real>(prepared: &Prepared<R>, x: V3<R>, sphere: Option<&Sphere<R>>) -> V3<R> {
    let turbulence = [
        prepared.turbulence * R::simplex(prepared.noise_point(x, 0)).0,
        prepared.turbulence * R::simplex(prepared.noise_point(x, 1)).0,
        prepared.turbulence * R::simplex(prepared.noise_point(x, 2)).0,
    ];
    let p = prepared.direction;
    let half = prepared.half_background;
    match sphere {
        None => add3(turbulence, scale3(half, cross3(p, x))),
        Some(sphere) => {
            let rel = sub3(x, sphere.center);
            let psi = add3(turbulence, scale3(half, cross3(p, rel)));
            obstacles::modulate_potential(sphere, x, psi)
        }
    }
}

/// Central differences of ψ' (seed eq. 4) with the field's step.
#[inline(always)]
fn velocity_finite_difference<R: Real>(prepared: &Prepared<R>, x: V3<R>) -> V3<R> {
    let sphere = prepared.sphere_for(x);
    let zero = R::splat(0.0);
    // samples[2j] = ψ'(x + h e_j), samples[2j + 1] = ψ'(x − h e_j). One loop
    // over the six points (not unrolled) keeps the code small.
    let mut samples = [[zero; 3]; 6];
    for (k, sample) in samples.iter_mut().enumerate() {
        let mut y = x;
        let j = k / 2;
        y[j] = if k % 2 == 0 {
            y[j] + prepared.step
        } else {
            y[j] - prepared.step
        };
        *sample = potential_lanes(prepared, y, sphere.as_ref());
    }
    // columns[j] = ∂ψ'/∂x_j.
    let column = |j: usize| {
        scale3(
            prepared.inv_two_steps,
            sub3(samples[2 * j], samples[2 * j + 1]),
        )
    };
    let columns = [column(0), column(1), column(2)];
    let curl = [
        columns[1][2] - columns[2][1],
        columns[2][0] - columns[0][2],
        columns[0][1] - columns[1][0],
    ];
    scale3(prepared.speed, curl)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> FlowSettings {
        FlowSettings {
            obstacles: vec![FlowObstacle {
                center: Vec3::new(50.0, 50.0, 50.0),
                radius: 10.0,
                influence: 8.0,
            }],
            ..FlowSettings::default()
        }
    }

    #[test]
    fn f32_and_f64_agree() {
        let field = FlowField::new(&settings());
        for x in [
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(50.0, 62.0, 49.0),
            Vec3::new(37.0, 55.0, 51.0),
        ] {
            let v = field.velocity(x, 0.5);
            let v64 = field.velocity_f64(x.as_dvec3(), 0.5);
            assert!(
                (v.as_dvec3() - v64).length() < 1e-4 * v64.length().max(1.0),
                "{v} {v64}"
            );
        }
    }

    #[test]
    fn background_only_flows_along_p_at_its_strength() {
        let field = FlowField::new(&FlowSettings {
            noise_share: 0.0,
            background_direction: Vec3::new(0.0, 0.6, 0.8),
            background_strength: 2.0,
            speed_scale: 1.5,
            ..FlowSettings::default()
        });
        let v = field.velocity_f64(DVec3::new(3.0, -40.0, 7.0), 2.0);
        // p is stored in f32.
        assert!((v - DVec3::new(0.0, 1.8, 2.4)).length() < 1e-6, "{v}");
    }
}
