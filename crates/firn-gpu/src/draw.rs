//! A running simulation's particle arrays as a renderer on the same device
//! reads them, so that `firn view` draws straight from the simulation's
//! buffers with no copy to the host.
//!
//! Every array is a storage buffer of 32-bit words; a quantity of particle
//! `i` starts at word `i * stride + offset`.
//!
//! `GpuSnow::particle_arrays` and `GpuFlow::particle_arrays` fill these from
//! the buffers their substeps write: read them between `advance_to` calls
//! (on the same queue, so a renderer's commands submitted after `advance_to`
//! see its results). Particle `i` is the same particle as `i` of the
//! simulation's `snapshot()`.

/// One per-particle quantity in a storage buffer: `stride` 32-bit words per
/// particle, the quantity starting `offset` words into each particle's record.
#[derive(Clone, Copy, Debug)]
pub struct StridedArray<'a> {
    /// The storage buffer.
    pub buffer: &'a wgpu::Buffer,
    /// Words per particle.
    pub stride: u32,
    /// Words from the start of a particle's record to the quantity.
    pub offset: u32,
}

/// A simulation's particles on the GPU.
#[derive(Clone, Copy, Debug)]
pub struct ParticleArrays<'a> {
    /// Live particles (the first `count` of every array).
    pub count: u32,
    /// Positions: x, y, z as `f32`.
    pub positions: StridedArray<'a>,
    /// Velocities: x, y, z as `f32`.
    pub velocities: StridedArray<'a>,
    /// The snow state that density and plastic J are computed from (snow only).
    pub snow: Option<SnowArrays<'a>>,
    /// The trail rings (flows that keep trails only).
    pub trails: Option<TrailArrays<'a>>,
}

/// The snow state per particle: enough for the density
/// ρ_p = m_p / (V⁰_p det F_E J_P) and for J_P.
#[derive(Clone, Copy, Debug)]
pub struct SnowArrays<'a> {
    /// Mass m_p as `f32`.
    pub mass: StridedArray<'a>,
    /// Initial volume V⁰_p as `f32`.
    pub volume0: StridedArray<'a>,
    /// F_E: three columns of x, y, z, each padded to four words (12 words).
    pub elastic: StridedArray<'a>,
    /// Plastic volume change J_P as `f32`.
    pub plastic_j: StridedArray<'a>,
}

/// Every particle's ring of recent positions (seed 002, §2.3), one point per
/// recorded frame, as `firn_flow::Trails` keeps them (the snapshot's
/// `trail_head`, `trail_points` and `trail_lengths`).
#[derive(Clone, Copy, Debug)]
pub struct TrailArrays<'a> {
    /// Rings, particle-major: `capacity` points of x, y, z (`f32`) each, so
    /// slot `s` of particle `i`'s ring starts at word `3 * (i * capacity + s)`.
    pub points: &'a wgpu::Buffer,
    /// Valid points per ring (`u32`, at most `capacity`): the ring's newest
    /// `lengths[i]` slots hold particle `i`'s positions of its current life
    /// (a particle born again since the last recording still shows the
    /// previous life's trail; the next recording starts a new one).
    pub lengths: &'a wgpu::Buffer,
    /// Points kept per ring.
    pub capacity: u32,
    /// Ring slot of the newest point, the same for every ring (all record at
    /// the same frames): the k-th newest point (k = 0 for the newest, up to
    /// `lengths[i] - 1` for the oldest) is in slot `(head + capacity - k) %
    /// capacity`.
    pub head: u32,
    /// Particles that have a ring (the first `count`: those alive at the
    /// last recording); particles born since have none yet.
    pub count: u32,
}
