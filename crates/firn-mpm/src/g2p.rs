//! Grid to particle, the gather (thesis §3.4 steps 7 to 10): each
//! particle reads its new velocity and ∇v_p from the grid (step 8: the
//! PIC/FLIP blend v_p = (1 − α) v_PIC + α v_FLIP with cubic B-splines, or
//! APIC's v_p and C_p with quadratic ones), then its deformation update
//! F̂_E = (I + Δt ∇v_p) F_E, plasticity and stress (step 7, eq. 34-43,
//! [`crate::constitutive`]), the particle collisions (step 9) and the
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

use firn_core::math::bspline::{StencilValues, cubic_weights, quadratic_values};
#[cfg(target_arch = "x86_64")]
use firn_core::math::isa::Vec4Pair;
use firn_core::math::isa::{Avx2, Isa, Kernel, PairLanes, PortablePairs};
use firn_core::math::lanes::{F32s, Mat3s, Simd, U32s, Vec3s};
use std::ops::Range;

use glam::{Mat3, Vec3, Vec4};

use crate::binning::{Bins, OccupiedBlock};
use crate::constitutive::{ElasticUpdate, MaterialConstants, MaterialLanes};
use crate::contact::Colliders;
use crate::disjoint::{BlockParticles, ParticleMatrix, update_by_block};
use crate::grid::{Grid, Node};
use crate::local_nodes::{CUBIC_SPAN, LocalNodes, QUADRATIC_SPAN, at};
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
    /// The first particle in trouble (the lowest
    /// [`ParticleProblem::order`]), if any.
    pub problem: Option<ParticleProblem>,
}

/// A particle whose state went wrong.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleProblem {
    /// Particle index.
    pub particle: usize,
    /// The particle's place in the whole run's order: its index, or in a
    /// part of a split run its key ([`UpdateContext::keys`]).
    pub order: u64,
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
            (Some(a), Some(b)) => Some(if a.order <= b.order { a } else { b }),
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
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn load_matrices(
    avx2: Avx2,
    particles: &BlockParticles,
    batch: Range<usize>,
    interpolated: &mut Interpolated,
) {
    let last = batch.end - 1;
    for first in (0..batch.len()).step_by(8) {
        let places = std::array::from_fn(|lane| (batch.start + first + lane).min(last));
        avx2.load_eight(
            &mut interpolated.velocity_gradient,
            first,
            particles.matrices(ParticleMatrix::VelocityGradient, places),
        );
        avx2.load_eight(
            &mut interpolated.elastic,
            first,
            particles.matrices(ParticleMatrix::Elastic, places),
        );
    }
}

/// Stores the batch's new F_E and V_p^0 τ_p from the lanes, eight particles
/// per transpose.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn store_matrices(
    avx2: Avx2,
    particles: &mut BlockParticles,
    batch: Range<usize>,
    update: &ElasticUpdate<BATCH>,
) {
    for first in (0..batch.len()).step_by(8) {
        let places = batch.start + first..batch.end.min(batch.start + first + 8);
        avx2.store_eight(
            &update.elastic,
            first,
            particles.matrices_mut(ParticleMatrix::Elastic, places.clone()),
        );
        avx2.store_eight(
            &update.stress,
            first,
            particles.matrices_mut(ParticleMatrix::Stress, places),
        );
    }
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

/// The PIC/FLIP blend with cubic B-splines, read from [`LocalNodes`].
struct PicFlipInterpolation<'a> {
    grid: &'a Grid,
    /// FLIP share α.
    flip: f32,
}

impl Interpolation for PicFlipInterpolation<'_> {
    type LocalNode = Node;

    #[inline(always)]
    fn grid(&self) -> &Grid {
        self.grid
    }

    #[inline(always)]
    fn local_node(node: &Node) -> Node {
        *node
    }

    #[inline(always)]
    fn interpolate(
        &self,
        local: &LocalNodes<Node>,
        position: Vec3,
        velocity: Vec3,
    ) -> (Vec3, Mat3) {
        self.blend(PortablePairs, local, position, velocity)
    }

    #[inline(always)]
    fn interpolate_pair(
        &self,
        local: &LocalNodes<Node>,
        isa: Isa,
        particles: [(Vec3, Vec3); 2],
    ) -> [(Vec3, Mat3); 2] {
        let [(position_a, velocity_a), (position_b, velocity_b)] = particles;
        match isa.avx2() {
            #[cfg(target_arch = "x86_64")]
            Some(avx2) => [
                self.blend(avx2, local, position_a, velocity_a),
                self.blend(avx2, local, position_b, velocity_b),
            ],
            _ => [
                self.blend(PortablePairs, local, position_a, velocity_a),
                self.blend(PortablePairs, local, position_b, velocity_b),
            ],
        }
    }
}

impl PicFlipInterpolation<'_> {
    /// v_p = (1 − α) v_PIC + α (v_p + Δv_FLIP) (step 8) and ∇v_p (step 7)
    /// of a particle at `position` with the old `velocity`, from its
    /// stencil sums ([`PicFlipSums`]) in `lanes`.
    #[inline(always)]
    fn blend<P: PairLanes>(
        &self,
        lanes: P,
        local: &LocalNodes<Node>,
        position: Vec3,
        velocity: Vec3,
    ) -> (Vec3, Mat3) {
        let sums = PicFlipSums::of(lanes, local, self.grid, position);
        let flip = self.flip;
        let [old, new] = lanes.halves(sums.velocities);
        let pic = new.truncate();
        let change = (new - old).truncate();
        // The slopes are per cell: ∇w_ip is theirs over h.
        let inverse_h = 1.0 / self.grid.layout.cell_size;
        let column = |sums: P::Pair| (lanes.halves(sums)[1] * inverse_h).truncate();
        let gradient = Mat3::from_cols(
            column(sums.gradient[0]),
            column(sums.gradient[1]),
            column(sums.gradient[2]),
        );
        (pic * (1.0 - flip) + (velocity + change) * flip, gradient)
    }
}

/// One particle's sums over its 4x4x4 stencil (eq. 41 and the PIC/FLIP
/// blend), each over both node vectors (v_i, v_i^{n+1}) at once, as a
/// pair ([`Node::pair`]): Σ w_ip (v_i, v_i^{n+1}), whose halves give
/// v_PIC = Σ w_ip v_i^{n+1} and Δv_FLIP = Σ w_ip v_i^{n+1} − Σ w_ip v_i,
/// and per axis a the sums Σ (h ∂w_ip/∂x_a) (·, v_i^{n+1}), whose high
/// halves over h are the columns of ∇v_p = Σ v_i^{n+1} (∇w_ip)ᵀ. The
/// fourth lanes of each half carry nothing that is read.
struct PicFlipSums<P: PairLanes> {
    velocities: P::Pair,
    gradient: [P::Pair; 3],
}

impl<P: PairLanes> PicFlipSums<P> {
    /// The sums of a particle at `position`, from the nodes around its
    /// block, by the tensor product of the weights w_ijk = w_i^x w_j^y w_k^z:
    /// along z per stencil row, the rows along y per slab, the slabs along
    /// x (the slopes take a weight's place on their axis). Every instruction
    /// set does these lane-wise operations in this order, so the same bits.
    #[inline(always)]
    fn of(lanes: P, local: &LocalNodes<Node>, grid: &Grid, position: Vec3) -> PicFlipSums<P> {
        let weights = cubic_weights(grid.layout.to_grid(position));
        let window = local.window::<4, CUBIC_SPAN>(weights.base);
        let ((wx, sx), (wy, sy), (wz, sz)) = (weights.along(0), weights.along(1), weights.along(2));
        let zero = lanes.splat(0.0);
        // Per slab i: Σ_jk w_j w_k, Σ_jk s_j w_k and Σ_jk w_j s_k of its nodes.
        let mut slabs = [zero; 4];
        let mut slabs_y = [zero; 4];
        let mut slabs_z = [zero; 4];
        for i in 0..4 {
            let mut rows = [zero; 4];
            let mut rows_z = [zero; 4];
            for j in 0..4 {
                let mut nodes = [zero; 4];
                for (k, node) in nodes.iter_mut().enumerate() {
                    *node = window[at(i, j, k)].pair(lanes);
                }
                rows[j] = weighted_sum(lanes, &nodes, &wz);
                rows_z[j] = weighted_sum(lanes, &nodes, &sz);
            }
            slabs[i] = weighted_sum(lanes, &rows, &wy);
            slabs_y[i] = weighted_sum(lanes, &rows, &sy);
            slabs_z[i] = weighted_sum(lanes, &rows_z, &wy);
        }
        PicFlipSums {
            velocities: weighted_sum(lanes, &slabs, &wx),
            gradient: [
                weighted_sum(lanes, &slabs, &sx),
                weighted_sum(lanes, &slabs_y, &wx),
                weighted_sum(lanes, &slabs_z, &wx),
            ],
        }
    }
}

/// Σ_n weights[n] terms[n], added in order n = 0, 1, 2, 3.
#[inline(always)]
fn weighted_sum<P: PairLanes>(lanes: P, terms: &[P::Pair; 4], weights: &[f32; 4]) -> P::Pair {
    let mut sum = terms[0] * lanes.splat(weights[0]);
    for n in 1..4 {
        sum = sum + terms[n] * lanes.splat(weights[n]);
    }
    sum
}

/// APIC with quadratic B-splines, read from [`LocalNodes`].
struct ApicInterpolation<'a> {
    grid: &'a Grid,
}

impl Interpolation for ApicInterpolation<'_> {
    type LocalNode = Vec4;

    #[inline(always)]
    fn grid(&self) -> &Grid {
        self.grid
    }

    #[inline(always)]
    fn local_node(node: &Node) -> Vec4 {
        node.velocity_new
    }

    #[inline(always)]
    fn interpolate(&self, local: &LocalNodes<Vec4>, position: Vec3, _: Vec3) -> (Vec3, Mat3) {
        let weights = quadratic_values(self.grid.layout.to_grid(position));
        let sums = StencilSums::of(local, &weights);
        sums.velocity_and_affine(weights.offset, self.inverse_inertia_h())
    }

    #[inline(always)]
    fn interpolate_pair(
        &self,
        local: &LocalNodes<Vec4>,
        isa: Isa,
        particles: [(Vec3, Vec3); 2],
    ) -> [(Vec3, Mat3); 2] {
        // Arrays spelled out, not `map`ped: `array::map` can be compiled as
        // a function of its own, outside the caller's instruction set.
        let weights_at =
            |(position, _): (Vec3, Vec3)| quadratic_values(self.grid.layout.to_grid(position));
        let weights = [weights_at(particles[0]), weights_at(particles[1])];
        let sums = match isa.avx2() {
            #[cfg(target_arch = "x86_64")]
            Some(avx2) => StencilSums::of_pair(avx2, local, [&weights[0], &weights[1]]),
            _ => [
                StencilSums::of(local, &weights[0]),
                StencilSums::of(local, &weights[1]),
            ],
        };
        let result =
            |n: usize| sums[n].velocity_and_affine(weights[n].offset, self.inverse_inertia_h());
        [result(0), result(1)]
    }
}

impl ApicInterpolation<'_> {
    /// 4/h: C_p = (4/h²) Σ w_ip v_i (x_i − x_p)ᵀ from the moment in cells
    /// (the offset in world units is cells · h).
    #[inline(always)]
    fn inverse_inertia_h(&self) -> f32 {
        4.0 / self.grid.layout.cell_size
    }
}

/// Weighted velocities w_ip v_i summed per x-slab, y-row and z-column of a
/// particle's 3x3x3 stencil: their totals give v_p, their first moments
/// C_p ([`StencilSums::velocity_and_affine`]).
#[derive(Clone, Copy)]
struct StencilSums {
    slabs: [Vec4; 3],
    rows: [Vec4; 3],
    columns: [Vec4; 3],
}

impl StencilSums {
    /// The sums of one particle with stencil `weights`, from the nodes
    /// around its block.
    #[inline(always)]
    fn of(local: &LocalNodes<Vec4>, weights: &StencilValues<3>) -> StencilSums {
        let window = local.window::<3, QUADRATIC_SPAN>(weights.base);
        let mut sums = StencilSums {
            slabs: [Vec4::ZERO; 3],
            rows: [Vec4::ZERO; 3],
            columns: [Vec4::ZERO; 3],
        };
        for (i, slab) in sums.slabs.iter_mut().enumerate() {
            for (j, row) in sums.rows.iter_mut().enumerate() {
                let wxy = weights.values[i].x * weights.values[j].y;
                for (k, column) in sums.columns.iter_mut().enumerate() {
                    let weighted = window[at(i, j, k)] * (wxy * weights.values[k].z);
                    *slab += weighted;
                    *row += weighted;
                    *column += weighted;
                }
            }
        }
        sums
    }

    /// [`StencilSums::of`] for two particles at once, one per 128-bit half
    /// of each 256-bit register: lane by lane the same operations, so the
    /// same bits.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn of_pair(
        avx2: Avx2,
        local: &LocalNodes<Vec4>,
        weights: [&StencilValues<3>; 2],
    ) -> [StencilSums; 2] {
        let [a, b] = weights;
        let splats = |x: f32, y: f32| avx2.pair(Vec4::splat(x), Vec4::splat(y));
        // No `array::map` here: it can be compiled as a function of its own,
        // without AVX2.
        let windows = [
            local.window::<3, QUADRATIC_SPAN>(a.base),
            local.window::<3, QUADRATIC_SPAN>(b.base),
        ];
        let z_weight = |k: usize| splats(a.values[k].z, b.values[k].z);
        let z_weights = [z_weight(0), z_weight(1), z_weight(2)];
        let mut slabs = [avx2.zero_pair(); 3];
        let mut rows = [avx2.zero_pair(); 3];
        let mut columns = [avx2.zero_pair(); 3];
        for (i, slab) in slabs.iter_mut().enumerate() {
            for (j, row) in rows.iter_mut().enumerate() {
                let wxy = splats(a.values[i].x * a.values[j].y, b.values[i].x * b.values[j].y);
                for (k, column) in columns.iter_mut().enumerate() {
                    let nodes = avx2.pair(windows[0][at(i, j, k)], windows[1][at(i, j, k)]);
                    let weighted = nodes * (wxy * z_weights[k]);
                    *slab = *slab + weighted;
                    *row = *row + weighted;
                    *column = *column + weighted;
                }
            }
        }
        let halves = |pairs: [Vec4Pair; 3]| {
            let [p0, p1, p2] = [pairs[0].halves(), pairs[1].halves(), pairs[2].halves()];
            [[p0[0], p1[0], p2[0]], [p0[1], p1[1], p2[1]]]
        };
        let ([slabs_a, slabs_b], [rows_a, rows_b], [columns_a, columns_b]) =
            (halves(slabs), halves(rows), halves(columns));
        [
            StencilSums {
                slabs: slabs_a,
                rows: rows_a,
                columns: columns_a,
            },
            StencilSums {
                slabs: slabs_b,
                rows: rows_b,
                columns: columns_b,
            },
        ]
    }

    /// v_p = Σ w_ip v_i and `scale` Σ w_ip v_i (x_i − x_p)ᵀ in cells, for a
    /// particle `offset` cells from its stencil's first node.
    #[inline(always)]
    fn velocity_and_affine(&self, offset: Vec3, scale: f32) -> (Vec3, Mat3) {
        let slabs = self.slabs;
        let velocity = slabs[0] + slabs[1] + slabs[2];
        // Σ w v (n − offset) along one axis, from the sums at n = 0, 1, 2,
        // scaled in the SIMD lanes (the bits of glam's `Mat3 * f32`).
        let moment = |sums: [Vec4; 3], offset: f32| {
            ((sums[1] + sums[2] * 2.0 - velocity * offset) * scale).truncate()
        };
        let affine = Mat3::from_cols(
            moment(self.slabs, offset.x),
            moment(self.rows, offset.y),
            moment(self.columns, offset.z),
        );
        (velocity.truncate(), affine)
    }
}
