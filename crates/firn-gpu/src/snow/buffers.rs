//! The snow run's GPU buffers: materials, colliders, particles, the sparse
//! grid's block table and word planes and the binning's buffers, and how
//! they fill the step's bind group by name ([`SnowBuffers::bindings`]).
//! The grid's buffers hold 64 nodes per block of its capacity
//! (`shaders/snow/nodes.wgsl`).

use firn_core::scene::{Collider, Transfer};
use firn_mpm::Particles;

use super::bindings::StepBindings;
use super::binning::BinningBuffers;
use super::blocks::BlockBuffers;
use super::coupling::BodyBuffers;
use super::layout::{GpuCollider, GpuMat3, GpuPlastic, SolveHeader, pack_colliders};
use super::sequences::SequenceRegion;
use super::wind::WindBuffers;
use crate::buffers::{storage_buffer, zeroed_storage_buffer};
use crate::context::GpuContext;

/// Per-particle arrays on the GPU.
pub struct ParticleBuffers {
    /// xyz: position; w: mass.
    pub position_mass: wgpu::Buffer,
    /// xyz: velocity; w: initial volume V_p^0.
    pub velocity_volume: wgpu::Buffer,
    /// F_E.
    pub elastic: wgpu::Buffer,
    /// C_p (APIC) or ∇v_p (PIC/FLIP).
    pub affine: wgpu::Buffer,
    /// V_p^0 τ_p.
    pub stress: wgpu::Buffer,
    /// J_P and the material word: the material index and the phase
    /// (snow, drift, escaped; [`super::spindrift`]).
    pub plastic: wgpu::Buffer,
}

impl ParticleBuffers {
    /// Uploads the particles, each with its material word
    /// ([`super::spindrift::material_word`]), into buffers with room for
    /// `capacity` particles (at least as many as there are).
    pub fn upload(
        context: &GpuContext,
        particles: &Particles,
        material_words: &[u32],
        capacity: usize,
    ) -> ParticleBuffers {
        let arrays = ParticleArrays::of(particles, material_words);
        let room = capacity.max(particles.len());
        let buffer = |label: &str, element: usize, contents: &[u8]| {
            let mut bytes = contents.to_vec();
            bytes.resize(room * element, 0);
            storage_buffer(context, label, &bytes)
        };
        ParticleBuffers {
            position_mass: buffer(
                "position and mass",
                16,
                bytemuck::cast_slice(&arrays.position_mass),
            ),
            velocity_volume: buffer(
                "velocity and volume",
                16,
                bytemuck::cast_slice(&arrays.velocity_volume),
            ),
            elastic: buffer(
                "elastic gradient",
                MAT3_BYTES,
                bytemuck::cast_slice(&arrays.elastic),
            ),
            affine: buffer(
                "affine velocity",
                MAT3_BYTES,
                bytemuck::cast_slice(&arrays.affine),
            ),
            stress: buffer("stress", MAT3_BYTES, bytemuck::cast_slice(&arrays.stress)),
            plastic: buffer("plastic state", 8, bytemuck::cast_slice(&arrays.plastic)),
        }
    }

    /// Writes the particles over the first ones of the buffers, which
    /// must have room for them.
    pub fn write(&self, context: &GpuContext, particles: &Particles, material_words: &[u32]) {
        let arrays = ParticleArrays::of(particles, material_words);
        let queue = &context.queue;
        queue.write_buffer(
            &self.position_mass,
            0,
            bytemuck::cast_slice(&arrays.position_mass),
        );
        queue.write_buffer(
            &self.velocity_volume,
            0,
            bytemuck::cast_slice(&arrays.velocity_volume),
        );
        queue.write_buffer(&self.elastic, 0, bytemuck::cast_slice(&arrays.elastic));
        queue.write_buffer(&self.affine, 0, bytemuck::cast_slice(&arrays.affine));
        queue.write_buffer(&self.stress, 0, bytemuck::cast_slice(&arrays.stress));
        queue.write_buffer(&self.plastic, 0, bytemuck::cast_slice(&arrays.plastic));
    }
}

/// Bytes of a `mat3x3<f32>` in storage layout.
const MAT3_BYTES: usize = size_of::<GpuMat3>();

/// The particles as the GPU stores them, array by array.
struct ParticleArrays {
    position_mass: Vec<[f32; 4]>,
    velocity_volume: Vec<[f32; 4]>,
    elastic: Vec<GpuMat3>,
    affine: Vec<GpuMat3>,
    stress: Vec<GpuMat3>,
    plastic: Vec<GpuPlastic>,
}

impl ParticleArrays {
    /// The arrays of `particles`, each with its material word.
    fn of(particles: &Particles, material_words: &[u32]) -> ParticleArrays {
        let n = particles.len();
        let matrices =
            |list: &[glam::Mat3]| list.iter().map(|&m| GpuMat3::from(m)).collect::<Vec<_>>();
        ParticleArrays {
            position_mass: (0..n)
                .map(|p| particles.position[p].extend(particles.mass[p]).into())
                .collect(),
            velocity_volume: (0..n)
                .map(|p| particles.velocity[p].extend(particles.volume0[p]).into())
                .collect(),
            elastic: matrices(&particles.elastic),
            affine: matrices(&particles.velocity_gradient),
            stress: matrices(&particles.stress),
            plastic: (0..n)
                .map(|p| GpuPlastic {
                    plastic_j: particles.plastic_j[p],
                    material: material_words[p],
                })
                .collect(),
        }
    }
}

/// Grid quantities' word planes: a low and a high word per quantity.
const PLANES: usize = 14;

/// The grid's word planes, in the order of the quantities
/// (`QUANTITY_*` in `shaders/snow/fixed_point.wgsl`: mass, momentum x, y,
/// z, force impulse x, y, z), low word before high word. APIC binds
/// 16-byte stand-ins for the force planes it never touches.
pub struct GridBuffers {
    planes: [wgpu::Buffer; PLANES],
    used: usize,
}

impl GridBuffers {
    /// Zeroed planes for `nodes` nodes. The force planes are also the
    /// semi-implicit solve's sums of its products with H (`implicit`), so
    /// APIC has them too then.
    pub fn new(
        context: &GpuContext,
        nodes: u64,
        transfer: Transfer,
        implicit: bool,
    ) -> GridBuffers {
        let used = match transfer {
            Transfer::Apic if !implicit => 8,
            Transfer::Apic | Transfer::PicFlip => PLANES,
        };
        let planes = std::array::from_fn(|plane| {
            let bytes = if plane < used { nodes * 4 } else { 16 };
            zeroed_storage_buffer(context, "grid word plane", bytes)
        });
        GridBuffers { planes, used }
    }

    /// Zeroes the planes the substep sums into, before its scatter.
    pub fn clear(&self, encoder: &mut wgpu::CommandEncoder) {
        for plane in &self.planes[..self.used] {
            encoder.clear_buffer(plane, 0, None);
        }
    }
}

/// The semi-implicit solve's buffers (`shaders/snow/implicit.wgsl`):
/// 16-byte stand-ins for the explicit integrator.
pub struct SolveBuffers {
    /// The node vectors x, r, z and p.
    pub vectors: wgpu::Buffer,
    /// The node vectors S p and S z, and the constraints.
    pub products: wgpu::Buffer,
    /// One `StressDifferential` per particle.
    pub linearized: wgpu::Buffer,
    /// `SolveState`: the scalars, then one partial sum per node workgroup.
    pub state: wgpu::Buffer,
}

/// Node vectors of the solve in `SolveBuffers::vectors`, one plane of
/// `vec4` per node each.
pub const SOLVE_VECTORS: u64 = 4;

/// Node vectors in `SolveBuffers::products`.
pub const SOLVE_PRODUCTS: u64 = 3;

/// Bytes of a `StressDifferential` in storage layout: four `mat3x3` and a
/// `vec4`'s worth of scalars.
pub const LINEARIZED_BYTES: u64 = 4 * 48 + 32;

impl SolveBuffers {
    /// Zeroed buffers for `particles` particles on `nodes` nodes, full size
    /// only when `implicit`.
    pub fn new(context: &GpuContext, particles: u64, nodes: u64, implicit: bool) -> SolveBuffers {
        let size = |bytes: u64| if implicit { bytes } else { 16 };
        let node_groups = nodes.div_ceil(64);
        SolveBuffers {
            vectors: zeroed_storage_buffer(
                context,
                "solve vectors",
                size(SOLVE_VECTORS * 16 * nodes),
            ),
            products: zeroed_storage_buffer(
                context,
                "solve products",
                size(SOLVE_PRODUCTS * 16 * nodes),
            ),
            linearized: zeroed_storage_buffer(
                context,
                "stress differentials",
                size(LINEARIZED_BYTES * particles),
            ),
            state: zeroed_storage_buffer(
                context,
                "solve state",
                size_of::<SolveHeader>() as u64 + 4 * node_groups,
            ),
        }
    }
}

/// The colliders as the kernels read them (`layout.rs`: `pack_colliders`).
pub struct ColliderBuffers {
    /// The colliders: the scene's, then the six walls.
    pub colliders: wgpu::Buffer,
    /// Keyframes, two vectors a key: position and time, then the
    /// orientation quaternion.
    pub keys: wgpu::Buffer,
    /// The mesh colliders' fields: rigid meshes' signed distances,
    /// deforming meshes' regions (`sequences.rs`).
    pub fields: wgpu::Buffer,
    /// Each collider's pose in the current substep (`ColliderPose` in
    /// `colliders.wgsl`, four vectors), which the kernels write.
    pub poses: wgpu::Buffer,
    /// The deforming colliders' regions of `fields` and the mesh frames
    /// they hold.
    pub(super) sequences: Vec<SequenceRegion>,
}

impl ColliderBuffers {
    /// Packs and uploads `colliders` (for a run: the scene's, then the
    /// walls, as `firn_mpm::contact::ColliderSet::colliders` lists them).
    pub fn of(context: &GpuContext, colliders: &[Collider]) -> ColliderBuffers {
        ColliderBuffers::with_bodies(context, colliders, &[]).0
    }

    /// [`ColliderBuffers::of`] `colliders`, and the rigid bodies' shapes
    /// (`bodies`, as `super::coupling::body_colliders` makes them) packed
    /// with them: returned in body order, their mesh fields among the
    /// colliders' fields.
    pub fn with_bodies(
        context: &GpuContext,
        colliders: &[Collider],
        bodies: &[Collider],
    ) -> (ColliderBuffers, Vec<GpuCollider>) {
        let all: Vec<Collider> = colliders.iter().chain(bodies).cloned().collect();
        let mut packed = pack_colliders(&all);
        let shapes = packed.colliders.split_off(colliders.len());
        let buffers = ColliderBuffers {
            colliders: storage_buffer(context, "colliders", &packed.colliders),
            keys: storage_buffer(context, "collider keys", &packed.keys),
            fields: storage_buffer(context, "collider fields", &packed.fields),
            poses: zeroed_storage_buffer(context, "collider poses", 64 * colliders.len() as u64),
            sequences: packed.sequences,
        };
        (buffers, shapes)
    }
}

/// Every buffer of a run but the parameters and the step state.
pub struct SnowBuffers {
    /// One `GpuMaterial` per scene material, rewritten when the materials change.
    pub materials: wgpu::Buffer,
    /// The colliders.
    pub colliders: ColliderBuffers,
    /// The particles.
    pub particles: ParticleBuffers,
    /// The grid's block table.
    pub blocks: BlockBuffers,
    /// The grid.
    pub grid: GridBuffers,
    /// The counting sort's buffers.
    pub binning: BinningBuffers,
    /// The wind's field and drag.
    pub wind: WindBuffers,
    /// Spindrift's parameters (`SpindriftParams`).
    pub spindrift: wgpu::Buffer,
    /// The semi-implicit solve's buffers.
    pub solve: SolveBuffers,
    /// The blocks whose sums a part of a split run trades.
    pub trade: TradeBuffers,
    /// The rigid bodies as placed for the substep, and their sums.
    pub bodies: BodyBuffers,
}

/// The grid sums a part of a split run trades (`shaders/snow/parts.wgsl`):
/// 16-byte stand-ins in one process.
pub struct TradeBuffers {
    /// The number of listed blocks, then their slots.
    pub slots: wgpu::Buffer,
    /// Their sums.
    pub words: wgpu::Buffer,
    /// Blocks the buffers have room for.
    pub capacity: u32,
}

impl TradeBuffers {
    /// Zeroed buffers with room for `blocks` blocks of `block_words` words.
    pub fn new(context: &GpuContext, blocks: u32, block_words: u32) -> TradeBuffers {
        let blocks64 = u64::from(blocks);
        TradeBuffers {
            slots: zeroed_storage_buffer(context, "traded slots", 4 * (1 + blocks64)),
            words: zeroed_storage_buffer(
                context,
                "traded sums",
                4 * blocks64 * u64::from(block_words),
            ),
            capacity: blocks,
        }
    }
}

impl SnowBuffers {
    /// The step's bindings: these buffers with `params` and `state`, each
    /// at its name.
    pub fn bindings<'a>(
        &'a self,
        params: &'a wgpu::Buffer,
        state: &'a wgpu::Buffer,
    ) -> StepBindings<'a> {
        let [
            mass_lo,
            mass_hi,
            px_lo,
            px_hi,
            py_lo,
            py_hi,
            pz_lo,
            pz_hi,
            fx_lo,
            fx_hi,
            fy_lo,
            fy_hi,
            fz_lo,
            fz_hi,
        ] = self.grid.planes.each_ref();
        let particles = &self.particles;
        StepBindings {
            params,
            state,
            materials: &self.materials,
            colliders: &self.colliders.colliders,
            collider_keys: &self.colliders.keys,
            collider_fields: &self.colliders.fields,
            collider_poses: &self.colliders.poses,
            blocks: &self.blocks.table,
            block_chunks: &self.blocks.chunks,
            position_mass: &particles.position_mass,
            velocity_volume: &particles.velocity_volume,
            elastic: &particles.elastic,
            affine: &particles.affine,
            stress: &particles.stress,
            plastic: &particles.plastic,
            mass_lo,
            mass_hi,
            px_lo,
            px_hi,
            py_lo,
            py_hi,
            pz_lo,
            pz_hi,
            fx_lo,
            fx_hi,
            fy_lo,
            fy_hi,
            fz_lo,
            fz_hi,
            bins: &self.binning.bins,
            particle_bins: &self.binning.particle_bins,
            work: &self.binning.work,
            field_constants: &self.wind.field_constants,
            obstacles: &self.wind.obstacles,
            wind: &self.wind.params,
            spindrift: &self.spindrift,
            solve_vectors: &self.solve.vectors,
            solve_products: &self.solve.products,
            linearized: &self.solve.linearized,
            solve: &self.solve.state,
            trade_slots: &self.trade.slots,
            traded: &self.trade.words,
            rigid_bodies: &self.bodies.placed,
            body_sums: &self.bodies.sums,
        }
    }
}
