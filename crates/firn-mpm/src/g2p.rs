//! Grid to particle, the gather (thesis §3.4 steps 7 to 10): each
//! particle reads its new velocity and ∇v_p from the grid (step 8: the
//! PIC/FLIP blend v_p = (1 − α) v_PIC + α v_FLIP with cubic B-splines, or
//! APIC's v_p and C_p with quadratic ones), then its deformation update
//! F̂_E = (I + Δt ∇v_p) F_E, plasticity and stress (step 7, eq. 34-43,
//! [`crate::snow_model`]), the particle collisions (step 9) and the
//! advection x_p += Δt v_p (step 10). [`crate::reference::grid_to_particles`]
//! is the plain form of this stage.
//!
//! It runs block by block and 16 particles at a time: the nodes around a
//! block are copied once into a dense local array, each particle's grid
//! velocity and ∇v_p are interpolated from it (two particles at once where
//! the transfer has a paired form), then the trial F̂_E, plasticity (with an
//! SVD where a particle yields) and stress of the whole batch run in SIMD
//! lanes ([`ElasticUpdate`]), and so do the collisions, the advection and
//! the checks. With AVX2 the matrices go in and out of the lanes by 8x8
//! transposes ([`Avx2::load_eight`]). Each block runs compiled for the
//! chosen instruction set ([`Isa::run`]), and so does the snow model.
//!
//! Batches are formed from a block's particles (the last one is padded with
//! undeformed particles), and every lane does the same IEEE operations, so
//! a particle's new state does not depend on the batch it lands in, the
//! thread count or the instruction set ([`Simd`]): AVX-512, AVX2 and
//! portable code give the same bits.

use firn_core::math::isa::{Isa, Kernel};
use firn_core::math::lanes::{F32s, Mat3s, Simd, Vec3s};
use std::ops::Range;

use glam::{Mat3, Vec3};

use crate::binning::{Bins, OccupiedBlock};
use crate::contact::Colliders;
use crate::disjoint::{BlockParticles, update_by_block};
use crate::grid::{Grid, Node};
use crate::local_nodes::LocalNodes;
use crate::particles::Particles;
use crate::snow_model::{ElasticUpdate, MaterialConstants, MaterialLanes};

mod apic;
mod checks;
#[cfg(target_arch = "x86_64")]
mod lanes;
mod pic_flip;

use apic::ApicInterpolation;
use checks::problem_kind;
pub use checks::{GatherStats, ParticleProblem, ProblemKind};
#[cfg(target_arch = "x86_64")]
use lanes::{load_matrices, store_matrices};
use pic_flip::PicFlipInterpolation;

/// Particles per batch: one AVX-512 register of `f32`.
pub const BATCH: usize = 16;

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
    /// In a part of a split run, each particle's key (its place in the whole
    /// run's order), which picks the particle a failure names; `None` in one
    /// process, where the index does.
    pub keys: Option<&'a [u64]>,
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

/// Steps 7 and 9 for a batch over a substep of `dt`, as a [`Kernel`]: each
/// instruction set's copy is a function of its own, shared by both
/// transfer schemes and never inlined into their block loops, so the
/// 16-lane snow model is compiled three times rather than six; one call
/// per 16 particles costs nothing beside the SVD.
struct ElasticStep<'a> {
    batch: &'a Interpolated,
    dt: f32,
}

impl Kernel for ElasticStep<'_> {
    type Output = ElasticUpdate<BATCH>;
    #[inline(always)]
    fn run(self, _: Isa) -> ElasticUpdate<BATCH> {
        elastic_update_lanes(self.batch, self.dt)
    }
}

/// The trial F̂_E = (I + Δt ∇v_p) F_E is formed in the lanes too, with the
/// operations glam's `Mat3` does in the same order (so the bits of
/// `(Mat3::IDENTITY + gradient * dt) * elastic`).
#[inline(always)]
fn elastic_update_lanes(batch: &Interpolated, dt: f32) -> ElasticUpdate<BATCH> {
    let step = Mat3s::splat(Mat3::IDENTITY).add(&batch.velocity_gradient.scale(F32s::splat(dt)));
    ElasticUpdate::new(
        &step.mul_mat(&batch.elastic),
        batch.plastic_j,
        batch.volume0,
        &batch.materials,
    )
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

/// How a transfer scheme reads the grid at a particle (step 8): from a
/// copy of the nodes around the particle's block, made once per block.
/// Its methods are `#[inline(always)]` in every implementation, so that
/// the particle update of each scheme compiles into one function per
/// instruction set (which calls that set's [`elastic_update`]).
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
    /// velocity) at once, on the gather's instruction set `isa`; the same
    /// bits as one by one.
    #[inline(always)]
    fn interpolate_pair(
        &self,
        local: &LocalNodes<Self::LocalNode>,
        _isa: Isa,
        particles: [(Vec3, Vec3); 2],
    ) -> [(Vec3, Mat3); 2] {
        // Spelled out, not `map`ped: `array::map` can be compiled as a
        // function of its own, outside the caller's instruction set.
        let [(position_a, velocity_a), (position_b, velocity_b)] = particles;
        [
            self.interpolate(local, position_a, velocity_a),
            self.interpolate(local, position_b, velocity_b),
        ]
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
    let isa = Isa::of(simd);
    let grid = interpolation.grid();
    let table = grid.page_table();
    let gather_block = |local: &mut LocalNodes<I::LocalNode>,
                        block: &OccupiedBlock,
                        particles: BlockParticles<'_>| {
        local.copy_from(&table, &grid.nodes, block.coord, I::local_node);
        isa.run(Block {
            particles,
            context,
            interpolation,
            local,
        })
    };
    update_by_block(
        particles,
        bins,
        LocalNodes::for_gather,
        gather_block,
        GatherStats::merge,
        GatherStats::default,
    )
}

/// One block's particles and what their update reads.
struct Block<'a, I: Interpolation> {
    particles: BlockParticles<'a>,
    context: &'a UpdateContext<'a>,
    interpolation: &'a I,
    local: &'a LocalNodes<I::LocalNode>,
}

/// Steps 7-10 for the particles of one block, batch by batch, compiled
/// for each instruction set throughout: with AVX-512 the interpolation and
/// the particle bookkeeping get its 3-operand encodings too. No fused
/// multiply-add is enabled, so the bits stay those of portable code.
impl<I: Interpolation> Kernel for Block<'_, I> {
    type Output = GatherStats;
    #[inline(always)]
    fn run(mut self, isa: Isa) -> GatherStats {
        update_block(&mut self, isa)
    }
}

/// Steps 7-10 for the particles of one block, batch by batch.
#[inline(always)]
fn update_block<I: Interpolation>(block: &mut Block<I>, isa: Isa) -> GatherStats {
    let mut stats = GatherStats::default();
    // Filled once per block: each batch overwrites the lanes it uses (the
    // material lanes only where the block mixes materials; otherwise they
    // hold its one material from here on), and the lanes past the end of a
    // short last batch keep finite values that nothing reads back.
    let material = block.uniform_material();
    let padding = material.unwrap_or(&block.context.materials[0]);
    let mut interpolated = Interpolated::padded(padding);
    let per_lane = material.is_none();
    let count = block.particles.len();
    for start in (0..count).step_by(BATCH) {
        let batch = start..count.min(start + BATCH);
        stats = stats.merge(update_batch(block, batch, &mut interpolated, per_lane, isa));
    }
    stats
}

impl<I: Interpolation> Block<'_, I> {
    /// The material of every particle of the block, if they share one (the
    /// common case: a batch then needs no material lanes filled).
    #[inline(always)]
    fn uniform_material(&self) -> Option<&MaterialConstants> {
        let particles = &self.particles;
        if particles.len() == 0 {
            return None;
        }
        let first = particles.material(0);
        (0..particles.len())
            .all(|k| particles.material(k) == first)
            .then(|| &self.context.materials[usize::from(first)])
    }
}

/// Steps 7-10 for the particles at places `batch` of the block. The
/// batch's material lanes are filled particle by particle if `per_lane`,
/// else they already hold the block's one material.
#[inline(always)]
fn update_batch<I: Interpolation>(
    block: &mut Block<I>,
    batch: Range<usize>,
    interpolated: &mut Interpolated,
    per_lane: bool,
    isa: Isa,
) -> GatherStats {
    let context = block.context;
    // Matrices move in and out of the lanes eight at a time by AVX2
    // shuffles where the CPU has them, else one lane at a time: the same
    // values either way.
    let transposes = isa.avx2();
    let particles = &mut block.particles;
    let motion = |particles: &mut BlockParticles, k: usize| {
        let state = particles.state(k);
        (*state.position, *state.velocity)
    };
    for first in batch.clone().step_by(2) {
        let pair = first + 1 < batch.end;
        let results = if pair {
            let motions = [motion(particles, first), motion(particles, first + 1)];
            block
                .interpolation
                .interpolate_pair(block.local, isa, motions)
        } else {
            let (position, velocity) = motion(particles, first);
            let alone = block
                .interpolation
                .interpolate(block.local, position, velocity);
            [alone, alone]
        };
        for (k, (new_velocity, gradient)) in (first..).zip(results).take(1 + usize::from(pair)) {
            let lane = k - batch.start;
            interpolated.velocity.set_lane(lane, new_velocity);
            if transposes.is_none() {
                interpolated.velocity_gradient.set_lane(lane, gradient);
            }
            // Stored now, while at hand: nothing reads the old one again.
            *particles.state(k).velocity_gradient = gradient;
        }
    }
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = transposes {
        load_matrices(avx2, particles, batch.clone(), interpolated);
    }
    for (lane, k) in batch.clone().enumerate() {
        let volume0 = particles.volume0(k);
        let material = particles.material(k);
        let state = particles.state(k);
        if transposes.is_none() {
            interpolated.elastic.set_lane(lane, *state.elastic);
        }
        interpolated.plastic_j.0[lane] = *state.plastic_j;
        interpolated.volume0.0[lane] = volume0;
        if per_lane {
            interpolated
                .materials
                .set_lane(lane, &context.materials[usize::from(material)]);
        }
    }
    let update = isa.run(ElasticStep {
        batch: interpolated,
        dt: context.dt,
    });
    if let Some(avx2) = transposes {
        #[cfg(target_arch = "x86_64")]
        store_matrices(avx2, particles, batch.clone(), &update);
    } else {
        for (lane, k) in batch.clone().enumerate() {
            let state = particles.state(k);
            *state.elastic = update.elastic.lane(lane);
            *state.stress = update.stress.lane(lane);
        }
    }
    finish_batch(particles, context, batch, interpolated, &update)
}

/// Step 10 and the bookkeeping for a batch whose new F_E and stress are
/// stored, in lanes: collides at the predicted positions, advects, stores
/// J_P, velocities and positions, and reports the largest speed and wave
/// speed and the first particle in trouble.
#[inline(always)]
fn finish_batch(
    particles: &mut BlockParticles,
    context: &UpdateContext,
    batch: Range<usize>,
    interpolated: &Interpolated,
    update: &ElasticUpdate<BATCH>,
) -> GatherStats {
    let mut position = Vec3s::splat(Vec3::ZERO);
    for (lane, k) in batch.clone().enumerate() {
        position.set_lane(lane, *particles.state(k).position);
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
    for (lane, k) in batch.enumerate() {
        let state = particles.state(k);
        *state.velocity = velocity.lane(lane);
        *state.position = position.lane(lane);
        *state.plastic_j = update.plastic_j.lane(lane);
        stats.max_speed_squared = stats.max_speed_squared.max(speed_squared.lane(lane));
        stats.max_wave_speed_squared = stats
            .max_wave_speed_squared
            .max(wave_speed_squared.lane(lane));
        if finite.0[lane] & inside.0[lane] == 0 {
            let particle = particles.index(k);
            let problem = ParticleProblem {
                particle,
                order: context.keys.map_or(particle as u64, |keys| keys[particle]),
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

/// Steps 7-10 for PIC/FLIP with FLIP share `flip`:
/// v_p = (1 − α) Σ w_ip v_i^{n+1} + α (v_p + Σ w_ip (v_i^{n+1} − v_i)) and
/// ∇v_p = Σ v_i^{n+1} (∇w_ip)ᵀ.
pub fn gather_pic_flip(
    grid: &Grid,
    bins: &Bins,
    particles: &mut Particles,
    flip: f32,
    context: &UpdateContext,
    simd: Simd,
) -> GatherStats {
    let interpolation = PicFlipInterpolation { grid, flip };
    gather_with(particles, bins, context, simd, &interpolation)
}

/// Steps 7-10 for APIC: v_p = Σ w_ip v_i, C_p = (4/h²) Σ w_ip v_i (x_i − x_p)ᵀ,
/// and ∇v_p = C_p.
pub fn gather_apic(
    grid: &Grid,
    bins: &Bins,
    particles: &mut Particles,
    context: &UpdateContext,
    simd: Simd,
) -> GatherStats {
    gather_with(particles, bins, context, simd, &ApicInterpolation { grid })
}
