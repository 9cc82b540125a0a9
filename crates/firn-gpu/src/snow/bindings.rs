//! The bindings of the snow programs, named in one place: each line gives a
//! binding's number, name, access and WGSL type, and its doc becomes the
//! comment above the generated declaration ([`crate::bindings`]). The
//! structs (`Params`, `StepState`, ...) are in `shaders/snow/layout.wgsl`
//! and `shaders/common/*.wgsl`, mirrored in `layout.rs`.

use crate::bindings::bind_group;

bind_group! {
    /// The snow step's one bind group (group 0): every kernel of
    /// [`SNOW_STEP`](crate::shaders::SNOW_STEP) sees all of it.
    pub struct StepBindings("snow step", group 0) {
        /// The run's constants and the frame's time window.
        0 => params: Uniform "Params",
        /// What the substeps of a frame share: Δt, time, trouble flags.
        1 => state: ReadWrite "StepState",
        /// The snow model's constants of each material.
        2 => materials: Read "array<Material>",
        /// The colliders: the scene's, then the six walls.
        3 => colliders: Read "array<Collider>",
        /// The keyframes of keyframed colliders, two vectors a key: the
        /// position (xyz) and time (w), then the orientation quaternion.
        4 => collider_keys: Read "array<vec4<f32>>",
        /// xyz: position; w: mass.
        5 => position_mass: ReadWrite "array<vec4<f32>>",
        /// xyz: velocity; w: initial volume V_p^0.
        6 => velocity_volume: ReadWrite "array<vec4<f32>>",
        /// F_E.
        7 => elastic: ReadWrite "array<mat3x3<f32>>",
        /// C_p (APIC) or grad v_p (PIC/FLIP).
        8 => affine: ReadWrite "array<mat3x3<f32>>",
        /// V_p^0 tau_p.
        9 => stress: ReadWrite "array<mat3x3<f32>>",
        /// J_P and the material index.
        10 => plastic: ReadWrite "array<PlasticState>",
        /// Grid word planes, the low and the high words of each 64-bit
        /// fixed-point sum (`fixed_point.wgsl`): the mass's low words.
        11 => mass_lo: ReadWrite "array<atomic<u32>>",
        /// The mass's high words.
        12 => mass_hi: ReadWrite "array<atomic<u32>>",
        /// Momentum x; after the grid update, the bits of v_i's x.
        13 => px_lo: ReadWrite "array<atomic<u32>>",
        /// Momentum x's high words; after the grid update, the bits of v_i*'s x.
        14 => px_hi: ReadWrite "array<atomic<u32>>",
        /// Momentum y; after the grid update, the bits of v_i's y.
        15 => py_lo: ReadWrite "array<atomic<u32>>",
        /// Momentum y's high words; after the grid update, the bits of v_i*'s y.
        16 => py_hi: ReadWrite "array<atomic<u32>>",
        /// Momentum z; after the grid update, the bits of v_i's z.
        17 => pz_lo: ReadWrite "array<atomic<u32>>",
        /// Momentum z's high words; after the grid update, the bits of v_i*'s z.
        18 => pz_hi: ReadWrite "array<atomic<u32>>",
        /// PIC/FLIP's force impulse dt f x (APIC binds a 16-byte stand-in).
        19 => fx_lo: ReadWrite "array<atomic<u32>>",
        /// The force impulse x's high words.
        20 => fx_hi: ReadWrite "array<atomic<u32>>",
        /// The force impulse dt f y.
        21 => fy_lo: ReadWrite "array<atomic<u32>>",
        /// The force impulse y's high words.
        22 => fy_hi: ReadWrite "array<atomic<u32>>",
        /// The force impulse dt f z.
        23 => fz_lo: ReadWrite "array<atomic<u32>>",
        /// The force impulse z's high words.
        24 => fz_hi: ReadWrite "array<atomic<u32>>",
        /// Per allocated block of the grid, at its slot s: `[3s]`: its
        /// particles; `[3s + 1]`: its first slot in sorted order; `[3s + 2]`:
        /// the block's index in the domain (`snow/nodes.wgsl`).
        25 => bins: ReadWrite "array<atomic<u32>>",
        /// `[3p]`: the grid slot of particle p's block; `[3p + 1]`: its rank
        /// in the block; `[3s + 2]`: the particle in sorted slot s.
        26 => particle_bins: ReadWrite "array<u32>",
        /// `[0..3)`: dispatch size of the binned scatter; `[3]`: work items;
        /// then per item its block's grid slot and first sorted slot.
        27 => work: ReadWrite "array<u32>",
        /// The mesh colliders' fields, one after another: a rigid mesh's
        /// grid of signed distances (f32 bits), a deforming one's region
        /// with the narrow bands of its current mesh frames
        /// (`common/deforming.wgsl`).
        28 => collider_fields: Read "array<u32>",
        /// The wind's air field (`flow/field.wgsl`; zeroes without wind).
        29 => field_constants: Uniform "FieldConstants",
        /// The spheres the wind flows around, the first
        /// `field_constants.obstacle_count` of them.
        30 => obstacles: Uniform "array<Obstacle, 8>",
        /// The wind's drag and noise domains (`snow/wind.wgsl`).
        31 => wind: Uniform "WindParams",
        /// Spindrift's settings and the frame's first substep index
        /// (`snow/spindrift.wgsl`; zeroes without spindrift).
        32 => spindrift: Uniform "SpindriftParams",
        /// The semi-implicit solve's node vectors x, r, z and p, one plane
        /// of nodes each (`snow/implicit.wgsl`; a 16-byte stand-in for the
        /// explicit integrator).
        33 => solve_vectors: ReadWrite "array<vec4<f32>>",
        /// Its vectors S p and S z and the contact constraints, one plane
        /// of nodes each (two buffers, so neither grows past the adapter's
        /// storage-binding limit as fast as one would).
        34 => solve_products: ReadWrite "array<vec4<f32>>",
        /// The stress differential of each particle for the solve's
        /// products with H.
        35 => linearized: ReadWrite "array<StressDifferential>",
        /// The solve's scalars and the workgroups' partial sums.
        36 => solve: ReadWrite "SolveState",
        /// Each collider's pose at the end of the substep, which
        /// `begin_step` writes for the contacts of the substep.
        37 => collider_poses: ReadWrite "array<ColliderPose>",
        /// The sparse grid's block table: per block of the domain, its
        /// slot this substep or `NO_SLOT` (`snow/nodes.wgsl`, built by
        /// `snow/blocks.wgsl`).
        38 => blocks: ReadWrite "array<atomic<u32>>",
        /// `[0..3)`: the node kernels' dispatch size, one workgroup per
        /// allocated block; from `[4]` on: per chunk of 1024 blocks, its
        /// marked blocks, then its first slot.
        39 => block_chunks: ReadWrite "array<u32>",
        /// In a run split between processes (`snow/parts.wgsl`): the
        /// number of grid blocks whose sums are traded, then their slots
        /// (a 16-byte stand-in in one process).
        40 => trade_slots: Read "array<u32>",
        /// Those blocks' sums, packed to send or received to add.
        41 => traded: ReadWrite "array<u32>",
        /// The rigid bodies placed where they are at the start of the
        /// substep, which the host writes before each (`snow/coupling.wgsl`;
        /// a 16-byte stand-in without bodies).
        42 => rigid_bodies: Read "array<PlacedBody>",
        /// Per rigid body, the snow's momentum gain and its moment about
        /// the body's centre of mass in the substep: six 64-bit
        /// fixed-point sums, low word before high word.
        43 => body_sums: ReadWrite "array<atomic<u32>>",
    }
}

bind_group! {
    /// The arrays of the parity entry points
    /// ([`SNOW_PARITY`](crate::shaders::SNOW_PARITY), group 0), which run
    /// single library functions for the tests against the CPU.
    pub struct ParityBindings("snow parity", group 0) {
        /// Input matrices.
        0 => matrices_in: Read "array<mat3x3<f32>>",
        /// Input vectors.
        1 => vectors_in: Read "array<vec4<f32>>",
        /// Output matrices.
        2 => matrices_out: ReadWrite "array<mat3x3<f32>>",
        /// Output vectors.
        3 => vectors_out: ReadWrite "array<vec4<f32>>",
        /// The material of the snow model's entry point.
        4 => parity_material: Read "array<Material>",
        /// The colliders of the collider entry point.
        5 => colliders: Read "array<Collider>",
        /// Their keyframes, as the snow step's `collider_keys`.
        6 => collider_keys: Read "array<vec4<f32>>",
        /// Their fields, as the snow step's `collider_fields`.
        7 => collider_fields: Read "array<u32>",
        /// Poses of the colliders, as the snow step's `collider_poses`
        /// (the collider entry point places its own).
        8 => collider_poses: ReadWrite "array<ColliderPose>",
    }
}
