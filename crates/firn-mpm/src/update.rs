//! The particle update after the gather (steps 7 to 10), block by block
//! and 16 particles at a time: the nodes around a block are copied once
//! into a dense local array, each particle's grid velocity and ∇v_p are
//! interpolated from it (two particles at once where the transfer has a
//! paired form), then the trial F̂_E, plasticity (with an SVD where a
//! particle yields) and stress of the whole batch run in SIMD lanes
//! ([`crate::constitutive::ElasticUpdate`]), and so do the collisions, the
//! advection and the checks. With AVX2 the matrices go in and out of the
//! lanes by 8x8 transposes ([`Mat3s::load_eight`]).
//!
//! Batches are formed from a block's particles (the last one is padded with
//! undeformed particles), and every lane does the same IEEE operations, so
//! a particle's new state does not depend on the batch it lands in, the
//! thread count or the instruction set ([`Simd`]): AVX-512, AVX2 and
//! portable code give the same bits.

use std::marker::PhantomData;

use firn_core::math::lanes::{F32s, Mat3s, Simd, U32s, Vec3s};
use glam::{Mat3, Vec3};
use rayon::prelude::*;

use crate::binning::{Bins, OccupiedBlock};
use crate::constitutive::{ElasticUpdate, MaterialConstants, MaterialLanes};
use crate::contact::Colliders;
use crate::grid::{Grid, Node};
use crate::local_nodes::LocalNodes;
use crate::particles::Particles;

/// Particles per batch: one AVX-512 register of `f32`.
pub const BATCH: usize = 16;

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
    #[inline(always)]
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
    pub colliders: &'a Colliders<'a>,
    /// Lower domain corner, widened by the tolerance for leaving.
    pub lower: Vec3,
    /// Upper domain corner, widened likewise.
    pub upper: Vec3,
}

/// What the grid gave one particle, with the particle's F_E, for a whole
/// batch.
struct Interpolated {
    velocity: Vec3s<BATCH>,
    velocity_gradient: Mat3s<BATCH>,
    elastic: Mat3s<BATCH>,
    plastic_j: F32s<BATCH>,
    volume0: F32s<BATCH>,
    materials: MaterialLanes<BATCH>,
}

impl Interpolated {
    /// A batch of undeformed particles of material `padding`: what a block's
    /// first batch starts from, so that unused lanes hold finite values.
    fn padded(padding: &MaterialConstants) -> Interpolated {
        Interpolated {
            velocity: Vec3s::splat(Vec3::ZERO),
            velocity_gradient: Mat3s::splat(Mat3::ZERO),
            elastic: Mat3s::splat(Mat3::IDENTITY),
            plastic_j: F32s::splat(1.0),
            volume0: F32s::splat(0.0),
            materials: MaterialLanes::splat(padding),
        }
    }
}

/// Steps 7 and 9 for a batch over a substep of `dt`, compiled for the
/// chosen instruction set.
#[inline(always)]
fn elastic_update(simd: Simd, batch: &Interpolated, dt: f32) -> ElasticUpdate<BATCH> {
    match simd {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Simd::Avx512` is only used where the CPU has AVX-512F
        // (checked by `checked_simd`).
        Simd::Avx512 => unsafe { elastic_update_avx512(batch, dt) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above, for AVX2.
        Simd::Avx2 => unsafe { elastic_update_avx2(batch, dt) },
        _ => elastic_update_portable(batch, dt),
    }
}

/// The trial F̂_E = (I + Δt ∇v_p) F_E is formed in the lanes too, with the
/// operations glam's `Mat3` does in the same order (so the bits of
/// `(Mat3::IDENTITY + gradient * dt) * elastic`).
#[inline(always)]
fn elastic_update_portable(batch: &Interpolated, dt: f32) -> ElasticUpdate<BATCH> {
    let step = Mat3s::splat(Mat3::IDENTITY).add(&batch.velocity_gradient.scale(F32s::splat(dt)));
    ElasticUpdate::new(
        &step.mul_mat(&batch.elastic),
        batch.plastic_j,
        batch.volume0,
        &batch.materials,
    )
}

/// [`elastic_update_portable`] in 512-bit registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn elastic_update_avx512(batch: &Interpolated, dt: f32) -> ElasticUpdate<BATCH> {
    elastic_update_portable(batch, dt)
}

/// [`elastic_update_portable`] in 256-bit registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn elastic_update_avx2(batch: &Interpolated, dt: f32) -> ElasticUpdate<BATCH> {
    elastic_update_portable(batch, dt)
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
pub(crate) fn checked_simd(simd: Simd) -> Simd {
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

/// The particle arrays, shared by the tasks of the block-by-block gather.
///
/// Sound only because every particle belongs to exactly one occupied block
/// ([`Bins::order`] is a permutation) and each block is one task: no two
/// tasks ever reach the same particle.
struct ParticleArrays<'a> {
    position: *mut Vec3,
    velocity: *mut Vec3,
    elastic: *mut Mat3,
    plastic_j: *mut f32,
    stress: *mut Mat3,
    velocity_gradient: *mut Mat3,
    volume0: &'a [f32],
    material: &'a [u16],
    _particles: PhantomData<&'a mut Particles>,
}

// SAFETY: shared across the gather's tasks only, which touch disjoint
// particles (see the type's documentation).
unsafe impl Sync for ParticleArrays<'_> {}

impl<'a> ParticleArrays<'a> {
    fn new(particles: &'a mut Particles) -> ParticleArrays<'a> {
        ParticleArrays {
            position: particles.position.as_mut_ptr(),
            velocity: particles.velocity.as_mut_ptr(),
            elastic: particles.elastic.as_mut_ptr(),
            plastic_j: particles.plastic_j.as_mut_ptr(),
            stress: particles.stress.as_mut_ptr(),
            velocity_gradient: particles.velocity_gradient.as_mut_ptr(),
            volume0: &particles.volume0,
            material: &particles.material,
            _particles: PhantomData,
        }
    }

    /// Particle `p`'s mutable state.
    ///
    /// # Safety
    /// No other reference to particle `p` may exist while the result lives.
    #[inline(always)]
    unsafe fn state(&self, p: usize) -> ParticleState<'_> {
        assert!(p < self.volume0.len(), "particle {p} out of range");
        // SAFETY: in bounds (all arrays have the same length, checked by
        // `Particles`' users); exclusive by the caller's contract.
        unsafe {
            ParticleState {
                position: &mut *self.position.add(p),
                velocity: &mut *self.velocity.add(p),
                elastic: &mut *self.elastic.add(p),
                plastic_j: &mut *self.plastic_j.add(p),
                stress: &mut *self.stress.add(p),
                velocity_gradient: &mut *self.velocity_gradient.add(p),
            }
        }
    }
}

/// How a transfer scheme reads the grid at a particle (step 8): from a
/// copy of the nodes around the particle's block, made once per block.
/// Its methods are `#[inline(always)]` in every implementation, so that
/// the whole particle update compiles into one function per instruction set.
pub(crate) trait Interpolation: Sync {
    /// What the copy keeps of each node.
    type LocalNode: Copy + Default + Send;

    /// The grid read.
    fn grid(&self) -> &Grid;

    /// The part of `node` the copy keeps.
    fn local_node(node: &Node) -> Self::LocalNode;

    /// The new velocity and ∇v_p of a particle at `position` with the old
    /// `velocity`.
    fn interpolate(
        &self,
        local: &LocalNodes<Self::LocalNode>,
        position: Vec3,
        velocity: Vec3,
    ) -> (Vec3, Mat3);

    /// [`Interpolation::interpolate`] for two particles (position, old
    /// velocity) at once, on the gather's instruction set `simd`; the same
    /// bits as one by one.
    #[inline(always)]
    fn interpolate_pair(
        &self,
        local: &LocalNodes<Self::LocalNode>,
        _simd: Simd,
        particles: [(Vec3, Vec3); 2],
    ) -> [(Vec3, Mat3); 2] {
        particles.map(|(position, velocity)| self.interpolate(local, position, velocity))
    }
}

/// Steps 7-10 for every particle, block by block in parallel: the nodes
/// around a block are copied once, each particle reads them through
/// `interpolation`; the rest is the snow model and the advection, 16
/// particles of the block per batch.
pub(crate) fn gather_with<I: Interpolation>(
    particles: &mut Particles,
    bins: &Bins,
    context: &UpdateContext,
    simd: Simd,
    interpolation: &I,
) -> GatherStats {
    let simd = checked_simd(simd);
    let arrays = ParticleArrays::new(particles);
    let grid = interpolation.grid();
    let table = grid.page_table();
    let gather_block = |local: &mut LocalNodes<I::LocalNode>, block: &OccupiedBlock| {
        local.copy_from(&table, &grid.nodes, block.coord, I::local_node);
        let block = Block {
            arrays: &arrays,
            particles: bins.particles_of(block),
            context,
            interpolation,
            local,
        };
        match simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Simd::Avx512` is only used where the CPU has AVX-512F
            // (`checked_simd`); the block's particles are this task's alone.
            Simd::Avx512 => unsafe { update_block_avx512(&block) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above, for AVX2.
            Simd::Avx2 => unsafe { update_block_avx2(&block) },
            // SAFETY: the block's particles are this task's alone.
            _ => unsafe { update_block(&block, Simd::Portable) },
        }
    };
    bins.occupied
        .par_iter()
        .map_init(LocalNodes::for_gather, gather_block)
        .reduce(GatherStats::default, GatherStats::merge)
}

/// One block's particles and what their update reads.
struct Block<'a, I: Interpolation> {
    arrays: &'a ParticleArrays<'a>,
    particles: &'a [u32],
    context: &'a UpdateContext<'a>,
    interpolation: &'a I,
    local: &'a LocalNodes<I::LocalNode>,
}

/// Steps 7-10 for the particles of one block, batch by batch.
///
/// # Safety
/// No other task may touch the block's particles meanwhile.
#[inline(always)]
unsafe fn update_block<I: Interpolation>(block: &Block<I>, simd: Simd) -> GatherStats {
    let mut stats = GatherStats::default();
    // Filled once per block: each batch overwrites the lanes it uses (the
    // material lanes only where the block mixes materials; otherwise they
    // hold its one material from here on), and the lanes past the end of a
    // short last batch keep finite values that nothing reads back.
    let material = block.uniform_material();
    let padding = material.unwrap_or(&block.context.materials[0]);
    let mut interpolated = Interpolated::padded(padding);
    let per_lane = material.is_none();
    for batch in block.particles.chunks(BATCH) {
        // SAFETY: by the caller's contract.
        stats =
            stats.merge(unsafe { update_batch(block, batch, &mut interpolated, per_lane, simd) });
    }
    stats
}

/// [`update_block`] compiled for AVX-512 throughout: the interpolation and
/// the particle bookkeeping get its 3-operand encodings too. No fused
/// multiply-add is enabled, so the bits stay those of portable code.
///
/// # Safety
/// The CPU must have AVX-512F, and as for [`update_block`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn update_block_avx512<I: Interpolation>(block: &Block<I>) -> GatherStats {
    // SAFETY: by the caller's contract.
    unsafe { update_block(block, Simd::Avx512) }
}

/// [`update_block_avx512`] for AVX2.
///
/// # Safety
/// The CPU must have AVX2, and as for [`update_block`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn update_block_avx2<I: Interpolation>(block: &Block<I>) -> GatherStats {
    // SAFETY: by the caller's contract.
    unsafe { update_block(block, Simd::Avx2) }
}

impl<I: Interpolation> Block<'_, I> {
    /// The material of every particle of the block, if they share one (the
    /// common case: a batch then needs no material lanes filled).
    #[inline(always)]
    fn uniform_material(&self) -> Option<&MaterialConstants> {
        let material = self.arrays.material;
        let first = material[*self.particles.first()? as usize];
        self.particles
            .iter()
            .all(|&p| material[p as usize] == first)
            .then(|| &self.context.materials[usize::from(first)])
    }
}

/// Steps 7-10 for one batch of particle indices. The batch's material lanes
/// are filled particle by particle if `per_lane`, else they already hold
/// the block's one material.
///
/// # Safety
/// No other task may touch these particles meanwhile.
#[inline(always)]
unsafe fn update_batch<I: Interpolation>(
    block: &Block<I>,
    batch: &[u32],
    interpolated: &mut Interpolated,
    per_lane: bool,
    simd: Simd,
) -> GatherStats {
    let (arrays, context) = (block.arrays, block.context);
    // Matrices move in and out of the lanes eight at a time by AVX2
    // shuffles where the CPU has them, else one lane at a time: the same
    // values either way.
    let transposes = matches!(simd, Simd::Avx2 | Simd::Avx512) && cfg!(target_arch = "x86_64");
    let motion = |p: u32| {
        // SAFETY: exclusive by the caller's contract; the borrow ends here.
        let state = unsafe { arrays.state(p as usize) };
        (*state.position, *state.velocity)
    };
    for (pair, particles) in batch.chunks(2).enumerate() {
        let results = match *particles {
            [a, b] => {
                block
                    .interpolation
                    .interpolate_pair(block.local, simd, [motion(a), motion(b)])
            }
            _ => {
                let (position, velocity) = motion(particles[0]);
                let alone = block
                    .interpolation
                    .interpolate(block.local, position, velocity);
                [alone, alone]
            }
        };
        for ((lane, &p), (new_velocity, gradient)) in (2 * pair..).zip(particles).zip(&results) {
            interpolated.velocity.set_lane(lane, *new_velocity);
            if !transposes {
                interpolated.velocity_gradient.set_lane(lane, *gradient);
            }
            // Stored now, while at hand: nothing reads the old one again.
            // SAFETY: as above.
            *unsafe { arrays.state(p as usize) }.velocity_gradient = *gradient;
        }
    }
    if transposes {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above; `transposes` only where the CPU has AVX2.
        unsafe {
            load_matrices_avx2(arrays, batch, interpolated)
        };
    }
    for (lane, &p) in batch.iter().enumerate() {
        let p = p as usize;
        // SAFETY: as above.
        let state = unsafe { arrays.state(p) };
        if !transposes {
            interpolated.elastic.set_lane(lane, *state.elastic);
        }
        interpolated.plastic_j.0[lane] = *state.plastic_j;
        interpolated.volume0.0[lane] = arrays.volume0[p];
        if per_lane {
            interpolated
                .materials
                .set_lane(lane, &context.materials[arrays.material[p] as usize]);
        }
    }
    let update = elastic_update(simd, interpolated, context.dt);
    if transposes {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        unsafe {
            store_matrices_avx2(arrays, batch, &update)
        };
    } else {
        for (lane, &p) in batch.iter().enumerate() {
            // SAFETY: as above.
            let state = unsafe { arrays.state(p as usize) };
            *state.elastic = update.elastic.lane(lane);
            *state.stress = update.stress.lane(lane);
        }
    }
    // SAFETY: as above.
    unsafe { finish_batch(block, batch, interpolated, &update) }
}

/// Step 10 and the bookkeeping for a batch whose new F_E and stress are
/// stored, in lanes: collides at the predicted positions, advects, stores
/// J_P, velocities and positions, and reports the largest speed and wave
/// speed and the first particle in trouble.
///
/// # Safety
/// No other task may touch these particles meanwhile.
#[inline(always)]
unsafe fn finish_batch<I: Interpolation>(
    block: &Block<I>,
    batch: &[u32],
    interpolated: &Interpolated,
    update: &ElasticUpdate<BATCH>,
) -> GatherStats {
    let (arrays, context) = (block.arrays, block.context);
    let mut position = Vec3s::splat(Vec3::ZERO);
    for (lane, &p) in batch.iter().enumerate() {
        // SAFETY: exclusive by the caller's contract; the borrow ends here.
        position.set_lane(lane, *unsafe { arrays.state(p as usize) }.position);
    }
    let dt = F32s::splat(context.dt);
    let mut velocity = interpolated.velocity;
    let predicted = position + velocity.scale(dt);
    context
        .colliders
        .collide_lanes(&predicted, &mut velocity, batch.len());
    let position = position + velocity.scale(dt);

    let speed_squared = velocity.length_squared();
    let wave_speed_squared = interpolated.materials.wave_speed_squared * update.hardening_factor;
    let finite = position
        .finite_mask()
        .and(velocity.finite_mask())
        .and(update.elastic.finite_mask())
        .and(wave_speed_squared.finite_mask());
    let inside = |x: F32s<BATCH>, lower: f32, upper: f32| {
        F32s::splat(lower).le(x).and(x.le(F32s::splat(upper)))
    };
    let (lower, upper) = (context.lower, context.upper);
    let inside = inside(position.x, lower.x, upper.x)
        .and(inside(position.y, lower.y, upper.y))
        .and(inside(position.z, lower.z, upper.z));

    let mut stats = GatherStats::default();
    for (lane, &p) in batch.iter().enumerate() {
        // SAFETY: as above.
        let state = unsafe { arrays.state(p as usize) };
        *state.velocity = velocity.lane(lane);
        *state.position = position.lane(lane);
        *state.plastic_j = update.plastic_j.lane(lane);
        stats.max_speed_squared = stats.max_speed_squared.max(speed_squared.lane(lane));
        stats.max_wave_speed_squared = stats
            .max_wave_speed_squared
            .max(wave_speed_squared.lane(lane));
        if finite.0[lane] & inside.0[lane] == 0 {
            let problem = ParticleProblem {
                particle: p as usize,
                kind: problem_kind(finite, lane),
                position: position.lane(lane),
            };
            stats = stats.merge(GatherStats {
                problem: Some(problem),
                ..GatherStats::default()
            });
        }
    }
    stats
}

/// Why lane `lane`, which failed a check, is in trouble.
#[inline(always)]
fn problem_kind(finite: U32s<BATCH>, lane: usize) -> ProblemKind {
    if finite.0[lane] == 0 {
        ProblemKind::NonFinite
    } else {
        ProblemKind::LeftDomain
    }
}

/// Loads the batch's ∇v_p (stored by the interpolation) and F_E into the
/// lanes, eight particles per transpose; lanes past the batch's end repeat
/// its last particle, so they stay finite.
///
/// # Safety
/// The CPU must have AVX2, and no other task may touch these particles.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn load_matrices_avx2(
    arrays: &ParticleArrays,
    batch: &[u32],
    interpolated: &mut Interpolated,
) {
    for first in (0..batch.len()).step_by(8) {
        let particle = |lane: usize| batch[(first + lane).min(batch.len() - 1)] as usize;
        let eight = |array: *mut Mat3| -> [&Mat3; 8] {
            // SAFETY: the batch's particles are in bounds (binning) and this
            // task's alone (the caller's contract); only read here.
            std::array::from_fn(|lane| unsafe { &*array.add(particle(lane)) })
        };
        interpolated
            .velocity_gradient
            .load_eight(first, eight(arrays.velocity_gradient));
        interpolated
            .elastic
            .load_eight(first, eight(arrays.elastic));
    }
}

/// Stores the batch's new F_E and V_p^0 τ_p from the lanes, eight particles
/// per transpose.
///
/// # Safety
/// As for [`load_matrices_avx2`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn store_matrices_avx2(
    arrays: &ParticleArrays,
    batch: &[u32],
    update: &ElasticUpdate<BATCH>,
) {
    for (chunk, first) in batch.chunks(8).zip((0..).step_by(8)) {
        let targets = |array: *mut Mat3| {
            chunk.iter().map(move |&p| {
                // SAFETY: as in `load_matrices_avx2`; each particle's
                // reference is used and dropped before the next is made.
                unsafe { &mut *array.add(p as usize) }
            })
        };
        update.elastic.store_eight(first, targets(arrays.elastic));
        update.stress.store_eight(first, targets(arrays.stress));
    }
}
