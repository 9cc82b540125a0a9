//! The particle update after the gather (steps 7 to 10), 16 particles at a
//! time: each particle's grid velocity and ∇v_p are interpolated one by one,
//! then the SVD, plasticity and stress of the whole batch run in SIMD lanes
//! ([`crate::constitutive::ElasticUpdate`]), then each particle collides and
//! moves.
//!
//! Batches are formed from particle indices alone (the last one is padded
//! with undeformed particles), and every lane does the same IEEE operations,
//! so a particle's new state does not depend on the thread count or on the
//! instruction set ([`Simd`]): AVX-512, AVX2 and portable code give the same
//! bits.

use firn_core::math::lanes::{F32s, Mat3s, Simd};
use glam::{Mat3, Vec3};
use rayon::prelude::*;

use crate::constitutive::{ElasticUpdate, MaterialConstants, MaterialLanes};
use crate::contact::{PlacedCollider, collide_all};
use crate::particles::Particles;

/// Particles per batch: one AVX-512 register of `f32`.
pub const BATCH: usize = 16;

/// Batches per parallel work item (rayon splits no finer).
const BATCHES_PER_TASK: usize = 32;

/// What the gather learned about the particles, for the next Δt and for
/// catching a simulation that blows up.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GatherStats {
    /// Largest |v_p|².
    pub max_speed_squared: f32,
    /// Largest squared elastic wave speed, hardening included.
    pub max_wave_speed_squared: f32,
    /// The first (lowest-index) particle in trouble, if any.
    pub problem: Option<ParticleProblem>,
}

/// A particle whose state went wrong.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleProblem {
    /// Particle index.
    pub particle: usize,
    /// What went wrong.
    pub kind: ProblemKind,
    /// Where the particle was.
    pub position: Vec3,
}

/// Kinds of particle trouble.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProblemKind {
    /// Position, velocity or deformation became NaN or infinite.
    NonFinite,
    /// The particle moved outside the domain.
    LeftDomain,
}

impl GatherStats {
    /// Combines two partial results; order-independent, hence deterministic.
    fn merge(self, other: GatherStats) -> GatherStats {
        let problem = match (self.problem, other.problem) {
            (Some(a), Some(b)) => Some(if a.particle <= b.particle { a } else { b }),
            (a, b) => a.or(b),
        };
        GatherStats {
            max_speed_squared: self.max_speed_squared.max(other.max_speed_squared),
            max_wave_speed_squared: self
                .max_wave_speed_squared
                .max(other.max_wave_speed_squared),
            problem,
        }
    }
}

/// Everything the particle update needs besides the particle itself.
#[derive(Clone, Copy)]
pub struct UpdateContext<'a> {
    /// Substep Δt.
    pub dt: f32,
    /// Materials by index.
    pub materials: &'a [MaterialConstants],
    /// Colliders at the end of the step.
    pub colliders: &'a [PlacedCollider],
    /// Lower domain corner, widened by the tolerance for leaving.
    pub lower: Vec3,
    /// Upper domain corner, widened likewise.
    pub upper: Vec3,
}

/// What the grid gave one particle, and the trial F̂_E it implies, for a whole
/// batch.
struct Interpolated {
    velocity: [Vec3; BATCH],
    velocity_gradient: [Mat3; BATCH],
    trial_elastic: Mat3s<BATCH>,
    plastic_j: F32s<BATCH>,
    volume0: F32s<BATCH>,
    materials: MaterialLanes<BATCH>,
}

impl Interpolated {
    /// A batch of undeformed particles of material `padding`, which the lanes
    /// past the end of the particle array keep.
    fn padded(padding: &MaterialConstants) -> Interpolated {
        Interpolated {
            velocity: [Vec3::ZERO; BATCH],
            velocity_gradient: [Mat3::ZERO; BATCH],
            trial_elastic: Mat3s::splat(Mat3::IDENTITY),
            plastic_j: F32s::splat(1.0),
            volume0: F32s::splat(0.0),
            materials: MaterialLanes::splat(padding),
        }
    }
}

/// Steps 7 and 9 for a batch, compiled for the chosen instruction set.
fn elastic_update(simd: Simd, batch: &Interpolated) -> ElasticUpdate<BATCH> {
    match simd {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Simd::Avx512` is only used where the CPU has AVX-512F
        // (checked by `checked_simd`).
        Simd::Avx512 => unsafe { elastic_update_avx512(batch) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above, for AVX2.
        Simd::Avx2 => unsafe { elastic_update_avx2(batch) },
        _ => elastic_update_portable(batch),
    }
}

#[inline(always)]
fn elastic_update_portable(batch: &Interpolated) -> ElasticUpdate<BATCH> {
    ElasticUpdate::new(
        &batch.trial_elastic,
        batch.plastic_j,
        batch.volume0,
        &batch.materials,
    )
}

/// [`elastic_update_portable`] in 512-bit registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn elastic_update_avx512(batch: &Interpolated) -> ElasticUpdate<BATCH> {
    elastic_update_portable(batch)
}

/// [`elastic_update_portable`] in 256-bit registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn elastic_update_avx2(batch: &Interpolated) -> ElasticUpdate<BATCH> {
    elastic_update_portable(batch)
}

/// The instruction set the solver uses unless told otherwise: AVX2 where the
/// CPU has it, even beside AVX-512. The batched SVD is a chain of dependent
/// square roots and divisions; with AVX2 a batch of 16 is two independent
/// 8-lane chains that overlap in the pipeline, while one 16-lane AVX-512 chain
/// waits out every latency (`firn bench --simd avx2|avx512` measures both:
/// AVX2 was 1 to 5 % faster on the 2-core Xeon of docs/benchmarks.md).
pub fn preferred_simd() -> Simd {
    match Simd::detect() {
        Simd::Avx512 | Simd::Avx2 => Simd::Avx2,
        Simd::Portable => Simd::Portable,
    }
}

/// `simd` where the running CPU has it, else portable code.
fn checked_simd(simd: Simd) -> Simd {
    if simd.is_available() {
        simd
    } else {
        Simd::Portable
    }
}

/// One particle's state, borrowed from the particle arrays.
struct ParticleState<'a> {
    position: &'a mut Vec3,
    velocity: &'a mut Vec3,
    elastic: &'a mut Mat3,
    plastic_j: &'a mut f32,
    stress: &'a mut Mat3,
    velocity_gradient: &'a mut Mat3,
}

/// Step 10 and the bookkeeping for particle `index` (lane `lane` of its
/// batch): stores the new elastic state, collides at the predicted position,
/// advects, and reports speed, wave speed and trouble.
fn finish_particle(
    index: usize,
    lane: usize,
    state: ParticleState,
    batch: &Interpolated,
    update: &ElasticUpdate<BATCH>,
    constants: &MaterialConstants,
    context: &UpdateContext,
) -> GatherStats {
    let elastic = update.elastic.lane(lane);
    *state.elastic = elastic;
    *state.plastic_j = update.plastic_j.lane(lane);
    *state.stress = update.stress.lane(lane);
    *state.velocity_gradient = batch.velocity_gradient[lane];

    let velocity = batch.velocity[lane];
    let predicted = *state.position + velocity * context.dt;
    let velocity = collide_all(context.colliders, predicted, velocity);
    *state.velocity = velocity;
    *state.position += velocity * context.dt;

    let position = *state.position;
    let wave_speed_squared = constants.wave_speed_squared * update.hardening_factor.lane(lane);
    let finite = position.is_finite()
        && velocity.is_finite()
        && elastic.is_finite()
        && wave_speed_squared.is_finite();
    let inside = position.cmpge(context.lower).all() && position.cmple(context.upper).all();
    let problem = match (finite, inside) {
        (false, _) => Some(ProblemKind::NonFinite),
        (true, false) => Some(ProblemKind::LeftDomain),
        (true, true) => None,
    };
    GatherStats {
        max_speed_squared: velocity.length_squared(),
        max_wave_speed_squared: wave_speed_squared,
        problem: problem.map(|kind| ParticleProblem {
            particle: index,
            kind,
            position,
        }),
    }
}

/// Steps 7-10 for every particle, batches in parallel: `interpolate` reads
/// the grid at a particle (position, old velocity) and returns its new
/// velocity and ∇v_p; the rest is the snow model and the advection.
pub(crate) fn gather_with(
    particles: &mut Particles,
    context: &UpdateContext,
    simd: Simd,
    interpolate: impl Fn(Vec3, Vec3) -> (Vec3, Mat3) + Sync,
) -> GatherStats {
    let simd = checked_simd(simd);
    (
        particles.position.par_chunks_mut(BATCH),
        particles.velocity.par_chunks_mut(BATCH),
        particles.elastic.par_chunks_mut(BATCH),
        particles.plastic_j.par_chunks_mut(BATCH),
        particles.stress.par_chunks_mut(BATCH),
        particles.velocity_gradient.par_chunks_mut(BATCH),
        particles.volume0.par_chunks(BATCH),
        particles.material.par_chunks(BATCH),
    )
        .into_par_iter()
        .enumerate()
        .with_min_len(BATCHES_PER_TASK)
        .map(
            |(
                chunk,
                (
                    position,
                    velocity,
                    elastic,
                    plastic_j,
                    stress,
                    velocity_gradient,
                    volume0,
                    material,
                ),
            )| {
                let mut batch = Interpolated::padded(&context.materials[0]);
                for lane in 0..position.len() {
                    let (new_velocity, gradient) = interpolate(position[lane], velocity[lane]);
                    let trial = (Mat3::IDENTITY + gradient * context.dt) * elastic[lane];
                    batch.velocity[lane] = new_velocity;
                    batch.velocity_gradient[lane] = gradient;
                    batch.trial_elastic.set_lane(lane, trial);
                    batch.plastic_j.0[lane] = plastic_j[lane];
                    batch.volume0.0[lane] = volume0[lane];
                    batch
                        .materials
                        .set_lane(lane, &context.materials[material[lane] as usize]);
                }
                let update = elastic_update(simd, &batch);
                let mut stats = GatherStats::default();
                for lane in 0..position.len() {
                    let state = ParticleState {
                        position: &mut position[lane],
                        velocity: &mut velocity[lane],
                        elastic: &mut elastic[lane],
                        plastic_j: &mut plastic_j[lane],
                        stress: &mut stress[lane],
                        velocity_gradient: &mut velocity_gradient[lane],
                    };
                    let constants = &context.materials[material[lane] as usize];
                    let index = chunk * BATCH + lane;
                    stats = stats.merge(finish_particle(
                        index, lane, state, &batch, &update, constants, context,
                    ));
                }
                stats
            },
        )
        .reduce(GatherStats::default, GatherStats::merge)
}
