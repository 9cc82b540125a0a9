//! Particle ↔ grid transfers: the scatter (thesis steps 1 and 3), the grid
//! update (steps 4 and 5) and the gather with the particle update (steps 7
//! to 10), for both transfer schemes.
//!
//! - PIC/FLIP with cubic B-splines (Stomakhin et al. 2013, the thesis): the
//!   scatter sums mass, momentum and the elastic force
//!   f_i = −Σ_p V_p^0 τ_p ∇w_ip (eq. 31-33); the gather blends
//!   v_p = (1 − α) v_PIC + α v_FLIP (step 8).
//! - APIC with quadratic B-splines (Jiang et al. 2015, in the MLS-MPM form of
//!   Hu et al. 2018): the scatter sums w_ip (m_p v_p + (m_p C_p −
//!   Δt V_p^0 M_p⁻¹ τ_p)(x_i − x_p)) with M_p⁻¹ = 4/h², which conserves angular
//!   momentum; the gather rebuilds v_p and C_p = M_p⁻¹ Σ_i w_ip v_i (x_i − x_p)ᵀ.

use std::marker::PhantomData;

use glam::{IVec3, Mat3, Vec3, Vec4};
use rayon::prelude::*;

use firn_core::math::bspline::{
    QuadraticLanes, StencilValues, StencilWeights, cubic_weights, quadratic_values,
};
#[cfg(target_arch = "x86_64")]
use firn_core::math::lanes::lanes_to_rows_avx2;
use firn_core::math::lanes::{F32s, Mat3s, Simd, Vec3s, lanes_to_rows};

use crate::binning::{Bins, OccupiedBlock};
use crate::contact::Colliders;
use crate::grid::{Grid, GridLayout, Node};
use crate::local_nodes::{CUBIC_SPAN, LocalNodes, QUADRATIC_SPAN, at};
use crate::particles::Particles;
use crate::update::{GatherStats, Interpolation, UpdateContext, checked_simd, gather_with};

/// Writes into grid nodes from several threads at once. The nodes are stored
/// slot by slot, [`BLOCK_NODES`] per block: the grid's [`Node`]s, or the
/// implicit solver's per-node vectors.
///
/// Sound only because [`scatter_by_colour`] hands each thread a set of nodes
/// no other thread touches at the same time (see [`crate::binning`] for why
/// same-coloured blocks never share a node).
pub(crate) struct NodeWriter<'a, T> {
    nodes: *mut T,
    len: usize,
    _grid: PhantomData<&'a mut [T]>,
}

// SAFETY: the writer is only shared across threads by the driver below,
// whose callers never touch the same node from two threads; the nodes
// themselves may move between threads (`T: Send`).
unsafe impl<T: Send> Sync for NodeWriter<'_, T> {}

impl<'a, T> NodeWriter<'a, T> {
    fn new(nodes: &'a mut [T]) -> NodeWriter<'a, T> {
        NodeWriter {
            nodes: nodes.as_mut_ptr(),
            len: nodes.len(),
            _grid: PhantomData,
        }
    }

    /// Applies `change` to node `index`.
    #[inline(always)]
    pub(crate) fn update(&self, index: usize, change: impl FnOnce(&mut T)) {
        assert!(index < self.len, "node {index} outside the grid");
        // SAFETY: in bounds (checked above); no other thread writes this node
        // now (the drivers' disjointness), and no reference outlives the call.
        change(unsafe { &mut *self.nodes.add(index) });
    }
}

/// Runs `scatter` on every occupied block, colour by colour; blocks of one
/// colour run in parallel, so each node sums its contributions in the same
/// order whatever the thread count.
pub(crate) fn scatter_by_colour<T: Send>(
    nodes: &mut [T],
    bins: &Bins,
    scatter: impl Fn(&[u32], &NodeWriter<T>) + Sync,
) {
    scatter_blocks_by_colour(nodes, bins, |block, writer| {
        scatter(bins.particles_of(block), writer)
    });
}

/// [`scatter_by_colour`], handing over the occupied block itself.
fn scatter_blocks_by_colour<T: Send>(
    nodes: &mut [T],
    bins: &Bins,
    scatter: impl Fn(&OccupiedBlock, &NodeWriter<T>) + Sync,
) {
    let writer = NodeWriter::new(nodes);
    for colour in &bins.colours {
        colour
            .par_iter()
            .for_each(|&block| scatter(&bins.occupied[block as usize], &writer));
    }
}

/// Runs `visit` on the 64 nodes of every block with storage (the active
/// blocks of the last [`Grid::allocate`]), blocks in parallel.
pub(crate) fn for_each_active_block(grid: &mut Grid, visit: impl Fn(IVec3, &mut [Node]) + Sync) {
    grid.par_blocks_mut()
        .with_min_len(16)
        .for_each(|(block, nodes)| visit(block, nodes));
}

/// Steps 1 and 3 for PIC/FLIP: mass, momentum and elastic force on the
/// grid, summed per block in [`LocalNodes`].
pub fn scatter_pic_flip(grid: &mut Grid, bins: &Bins, particles: &Particles) {
    let (table, nodes) = grid.parts_mut();
    let layout = table.layout;
    let inverse_h = 1.0 / layout.cell_size;
    scatter_blocks_by_colour(nodes, bins, |block, writer| {
        let mut local = LocalNodes::<Node>::around(block.coord);
        for &p in bins.particles_of(block) {
            let p = p as usize;
            let weights = cubic_weights(layout.to_grid(particles.position[p]));
            let mass = particles.mass[p];
            let momentum_mass = (particles.velocity[p] * mass).extend(mass);
            let stress = particles.stress[p];
            let window = local.window_mut::<4, CUBIC_SPAN>(weights.base);
            for i in 0..4 {
                for j in 0..4 {
                    for k in 0..4 {
                        let sum = &mut window[at(i, j, k)];
                        let w = weights.weight(i, j, k);
                        let force = -(stress * (weights.gradient(i, j, k) * inverse_h));
                        sum.velocity_mass += momentum_mass * w;
                        sum.velocity_new += force.extend(0.0);
                    }
                }
            }
        }
        local.add_nodes_to(&table, writer);
    });
}

/// Steps 1 and 3 for APIC: mass and affine momentum including the force
/// impulse, summed per block in a [`LocalNodes`] of `Vec4`s (momentum, mass).
/// With AVX2 (`simd` not portable, where the CPU has it) two of a stencil
/// row's three nodes are added in one 256-bit register; every lane does
/// the same IEEE operations either way, so the sums have the same bits.
pub fn scatter_apic(grid: &mut Grid, bins: &Bins, particles: &Particles, dt: f32, simd: Simd) {
    let (table, nodes) = grid.parts_mut();
    let scatter = ApicScatter {
        layout: table.layout,
        dt,
        particles,
    };
    let simd = checked_simd(simd);
    scatter_blocks_by_colour(nodes, bins, |block, writer| {
        let mut local = LocalNodes::around(block.coord);
        let block_particles = bins.particles_of(block);
        match simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: AVX-512F CPUs have AVX2 too, and `checked_simd` only
            // keeps an instruction set the CPU has.
            Simd::Avx2 | Simd::Avx512 => unsafe { scatter.block_avx2(&mut local, block_particles) },
            _ => scatter.block::<false>(&mut local, block_particles),
        }
        local.add_momentum_to(&table, writer);
    });
}

/// What the APIC scatter reads.
struct ApicScatter<'a> {
    layout: GridLayout,
    dt: f32,
    particles: &'a Particles,
}

impl ApicScatter<'_> {
    /// Sums the particles `block` into `local`, eight at a time: their terms
    /// in SIMD lanes ([`ApicScatter::terms`]), then each particle's stencil,
    /// rows added in AVX2 registers if `AVX2`.
    #[inline(always)]
    fn block<const AVX2: bool>(&self, local: &mut LocalNodes<Vec4>, block: &[u32]) {
        for group in block.chunks(TERM_LANES) {
            let terms = self.terms::<AVX2>(group);
            for terms in &terms[..group.len()] {
                terms.add_to::<AVX2>(local);
            }
        }
    }

    /// The terms of the (up to eight) particles `group`, in SIMD lanes with
    /// the operations glam does per particle (so the same bits), then turned
    /// into one [`ParticleTerms`] each; lanes past the group's end repeat its
    /// last particle.
    #[inline(always)]
    fn terms<const AVX2: bool>(&self, group: &[u32]) -> [ParticleTerms; TERM_LANES] {
        let particles = self.particles;
        let particle = |lane: usize| group[lane.min(group.len() - 1)] as usize;
        let mut position = Vec3s::splat(Vec3::ZERO);
        let mut velocity = Vec3s::splat(Vec3::ZERO);
        let mut mass = F32s::splat(0.0);
        let mut gradient = Mat3s::splat(Mat3::ZERO);
        let mut stress = Mat3s::splat(Mat3::ZERO);
        for lane in 0..TERM_LANES {
            let p = particle(lane);
            position.set_lane(lane, particles.position[p]);
            velocity.set_lane(lane, particles.velocity[p]);
            mass.0[lane] = particles.mass[p];
            if !AVX2 {
                gradient.set_lane(lane, particles.velocity_gradient[p]);
                stress.set_lane(lane, particles.stress[p]);
            }
        }
        if AVX2 {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `AVX2` is only set inside `block_avx2`.
            unsafe {
                let (gradients, stresses) = (&particles.velocity_gradient, &particles.stress);
                gradient.load_eight(0, std::array::from_fn(|lane| &gradients[particle(lane)]));
                stress.load_eight(0, std::array::from_fn(|lane| &stresses[particle(lane)]));
            };
        }

        let layout = self.layout;
        let h = layout.cell_size;
        let splat = F32s::<TERM_LANES>::splat;
        let to_grid = |x: F32s<TERM_LANES>, origin: f32| (x - splat(origin)) / splat(h);
        let weights = [
            QuadraticLanes::at(to_grid(position.x, layout.origin.x)),
            QuadraticLanes::at(to_grid(position.y, layout.origin.y)),
            QuadraticLanes::at(to_grid(position.z, layout.origin.z)),
        ];
        let offset = Vec3s::new(weights[0].offset, weights[1].offset, weights[2].offset);
        // Maps a node offset in cells to momentum: (m C − Δt M⁻¹ V0 τ) h.
        let inverse_inertia = 4.0 / (h * h);
        let affine = gradient
            .scale(mass)
            .sub(&stress.scale(splat(self.dt * inverse_inertia)))
            .scale(splat(h));
        // Node (i, j, k) gets w (m v + affine ((i, j, k) − offset), m).
        let at_base = velocity.scale(mass) - affine.mul_vec(offset);

        let zero = splat(0.0);
        let [x, y, z] = [affine.x_axis, affine.y_axis, affine.z_axis];
        let [wx, wy, wz] = [weights[0].values, weights[1].values, weights[2].values];
        let values = [
            [at_base.x, at_base.y, at_base.z, mass, x.x, x.y, x.z, zero],
            [y.x, y.y, y.z, zero, z.x, z.y, z.z, zero],
            [wx[0], wy[0], wz[0], wx[1], wy[1], wz[1], wx[2], wy[2]],
            [
                wz[2],
                weights[0].first_node,
                weights[1].first_node,
                weights[2].first_node,
                zero,
                zero,
                zero,
                zero,
            ],
        ];
        let mut terms = [ParticleTerms::default(); TERM_LANES];
        for (part, values) in values.iter().enumerate() {
            for (terms, row) in terms.iter_mut().zip(rows_of::<AVX2>(values)) {
                terms.rows[part] = row;
            }
        }
        terms
    }

    /// [`ApicScatter::block`] compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn block_avx2(&self, local: &mut LocalNodes<Vec4>, block: &[u32]) {
        self.block::<true>(local, block);
    }
}

/// Particles whose scatter terms are computed together in SIMD lanes.
const TERM_LANES: usize = 8;

/// [`lanes_to_rows`], by AVX2 shuffles if `AVX2`.
#[inline(always)]
fn rows_of<const AVX2: bool>(values: &[F32s<TERM_LANES>; 8]) -> [[f32; 8]; TERM_LANES] {
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        // SAFETY: `AVX2` is only set inside `block_avx2`.
        return unsafe { lanes_to_rows_avx2(values) };
    }
    lanes_to_rows(values)
}

/// One particle's scatter terms, as four rows of eight floats (what
/// [`ApicScatter::terms`] writes): (m v − affine · offset, m) and the affine
/// map's x column; its y and z columns; the weights w_n^x, w_n^y, w_n^z of
/// nodes 0, 1 and (but for w_2^z) 2; w_2^z and the first node.
#[derive(Clone, Copy, Default)]
#[repr(align(32))]
struct ParticleTerms {
    rows: [[f32; 8]; 4],
}

impl ParticleTerms {
    /// Adds the terms to the particle's stencil in `local`: node (i, j, k)
    /// gets w_i^x w_j^y w_k^z (m v + affine ((i, j, k) − offset), m), the
    /// affine part growing by one column per stencil step; with `AVX2`
    /// two of a row's nodes are added in one 256-bit register.
    #[inline(always)]
    fn add_to<const AVX2: bool>(&self, local: &mut LocalNodes<Vec4>) {
        let [moments, columns, weights, last] = &self.rows;
        let first_node = IVec3::new(last[1] as i32, last[2] as i32, last[3] as i32);
        let at_base = Vec4::from_slice(&moments[..4]);
        let x_step = Vec4::from_slice(&moments[4..]);
        let y_step = Vec4::from_slice(&columns[..4]);
        let z_step = Vec4::from_slice(&columns[4..]);
        let (wx, wy) = (
            [weights[0], weights[3], weights[6]],
            [weights[1], weights[4], weights[7]],
        );
        let row = StencilRow {
            steps: [0, 1, 2].map(|k| z_step * k as f32),
            weights: [weights[2], weights[5], last[0]],
        };
        let window = local.window_mut::<3, QUADRATIC_SPAN>(first_node);
        for i in 0..3 {
            let at_i = at_base + x_step * i as f32;
            for j in 0..3 {
                let at_ij = at_i + y_step * j as f32;
                let wxy = wx[i] * wy[j];
                let sums = (&mut window[at(i, j, 0)..at(i, j, 3)])
                    .try_into()
                    .expect("a stencil row has three nodes");
                if AVX2 {
                    // SAFETY: `AVX2` is only set inside `block_avx2`.
                    unsafe { row.add_avx2(sums, at_ij, wxy) };
                } else {
                    row.add(sums, at_ij, wxy);
                }
            }
        }
    }
}

/// A particle's terms along a stencil row (i, j, 0…2): node k gets
/// (a_ij + steps[k]) (w_xy weights[k]).
struct StencilRow {
    /// The affine part's growth along z: k times its z column.
    steps: [Vec4; 3],
    /// The z weights w_k.
    weights: [f32; 3],
}

impl StencilRow {
    /// Adds the row's three terms to `sums`.
    #[inline(always)]
    fn add(&self, sums: &mut [Vec4; 3], at_ij: Vec4, wxy: f32) {
        for ((sum, step), weight) in sums.iter_mut().zip(self.steps).zip(self.weights) {
            *sum += (at_ij + step) * (wxy * weight);
        }
    }

    /// [`StencilRow::add`] with nodes 0 and 1 in one 256-bit register: the
    /// same operations lane by lane, so the same bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    fn add_avx2(&self, sums: &mut [Vec4; 3], at_ij: Vec4, wxy: f32) {
        use std::arch::x86_64::*;
        let first_two = |v: [Vec4; 3]| _mm256_set_m128(v[1].into(), v[0].into());
        let steps = first_two(self.steps);
        let weights = first_two(self.weights.map(Vec4::splat));
        let at = _mm256_set_m128(at_ij.into(), at_ij.into());
        let terms = _mm256_mul_ps(
            _mm256_add_ps(at, steps),
            _mm256_mul_ps(_mm256_set1_ps(wxy), weights),
        );
        let first = sums.as_mut_ptr().cast::<f32>();
        // SAFETY: `sums` holds 12 floats; nodes 0 and 1 are its first 8.
        unsafe { _mm256_storeu_ps(first, _mm256_add_ps(_mm256_loadu_ps(first), terms)) };
        sums[2] += (at_ij + self.steps[2]) * (wxy * self.weights[2]);
    }
}

/// Mass only, for the one-time density estimate (step 2).
pub fn scatter_mass<const N: usize>(
    grid: &mut Grid,
    bins: &Bins,
    particles: &Particles,
    weights_at: fn(Vec3) -> StencilWeights<N>,
) {
    let (table, nodes) = grid.parts_mut();
    let layout = table.layout;
    scatter_by_colour(nodes, bins, |block, writer| {
        for &p in block {
            let p = p as usize;
            let weights = weights_at(layout.to_grid(particles.position[p]));
            let stencil = table.stencil(weights.base);
            for i in 0..N {
                for j in 0..N {
                    for k in 0..N {
                        let mass = particles.mass[p] * weights.weight(i, j, k);
                        writer.update(stencil.index(i, j, k), |node| node.velocity_mass.w += mass);
                    }
                }
            }
        }
    });
}

/// Step 2: ρ_p^0 = Σ_i m_i w_ip / h³ and V_p^0 = m_p / ρ_p^0, from a grid
/// holding the scattered mass.
pub fn estimate_volumes<const N: usize>(
    grid: &Grid,
    particles: &mut Particles,
    weights_at: fn(Vec3) -> StencilWeights<N>,
) {
    let table = grid.page_table();
    let layout = table.layout;
    let cell_volume = layout.cell_size.powi(3);
    let (positions, masses) = (&particles.position, &particles.mass);
    particles
        .volume0
        .par_iter_mut()
        .enumerate()
        .for_each(|(p, volume)| {
            let weights = weights_at(layout.to_grid(positions[p]));
            let stencil = table.stencil(weights.base);
            let mut density = 0.0;
            for i in 0..N {
                for j in 0..N {
                    for k in 0..N {
                        density +=
                            grid.nodes[stencil.index(i, j, k)].mass() * weights.weight(i, j, k);
                    }
                }
            }
            *volume = masses[p] * cell_volume / density;
        });
}

/// How the grid update treats the second node vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridForces {
    /// It holds the force f_i (PIC/FLIP).
    Separate,
    /// Forces are already in the momentum (APIC).
    InMomentum,
}

/// Steps 4 and 5: v_i = p_i / m_i, v_i* = v_i + Δt (f_i / m_i + g), then grid
/// collisions, on every node with mass.
pub fn update_grid(
    grid: &mut Grid,
    forces: GridForces,
    dt: f32,
    gravity: Vec3,
    colliders: &Colliders,
) {
    let layout = grid.layout;
    for_each_active_block(grid, |block, nodes| {
        for (local, node) in nodes.iter_mut().enumerate() {
            let mass = node.mass();
            if mass <= 0.0 {
                continue;
            }
            let inverse_mass = 1.0 / mass;
            let velocity = node.velocity() * inverse_mass;
            let acceleration = match forces {
                GridForces::Separate => node.velocity_new() * inverse_mass + gravity,
                GridForces::InMomentum => gravity,
            };
            let position = layout.node_position(GridLayout::node_in_block(block, local));
            node.velocity_mass = velocity.extend(mass);
            node.set_velocity_new(colliders.collide(position, velocity + acceleration * dt));
        }
    });
}

/// Zeroes every node with storage, which includes every node the last
/// scatter could have touched.
pub fn clear_grid(grid: &mut Grid) {
    for_each_active_block(grid, |_, nodes| nodes.fill(Node::default()));
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
        let layout = self.grid.layout;
        let inverse_h = 1.0 / layout.cell_size;
        let weights = cubic_weights(layout.to_grid(position));
        let window = local.window::<4, CUBIC_SPAN>(weights.base);
        let mut pic = Vec3::ZERO;
        let mut change = Vec3::ZERO;
        let mut gradient = Mat3::ZERO;
        for i in 0..4 {
            for j in 0..4 {
                for k in 0..4 {
                    let node = &window[at(i, j, k)];
                    let w = weights.weight(i, j, k);
                    let grad_w = weights.gradient(i, j, k) * inverse_h;
                    pic += node.velocity_new() * w;
                    change += (node.velocity_new() - node.velocity()) * w;
                    gradient += outer(node.velocity_new(), grad_w);
                }
            }
        }
        let flip = self.flip;
        (pic * (1.0 - flip) + (velocity + change) * flip, gradient)
    }
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
        simd: Simd,
        particles: [(Vec3, Vec3); 2],
    ) -> [(Vec3, Mat3); 2] {
        // Arrays spelled out, not `map`ped: `array::map` can be compiled as
        // a function of its own, outside the caller's instruction set.
        let weights_at =
            |(position, _): (Vec3, Vec3)| quadratic_values(self.grid.layout.to_grid(position));
        let weights = [weights_at(particles[0]), weights_at(particles[1])];
        let sums = match simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: AVX-512F CPUs have AVX2 too, and the gather only runs
            // an instruction set the CPU has.
            Simd::Avx2 | Simd::Avx512 => unsafe {
                StencilSums::of_pair(local, [&weights[0], &weights[1]])
            },
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
    #[target_feature(enable = "avx2")]
    #[inline]
    fn of_pair(local: &LocalNodes<Vec4>, weights: [&StencilValues<3>; 2]) -> [StencilSums; 2] {
        use std::arch::x86_64::*;
        let [a, b] = weights;
        let pair = |x: Vec4, y: Vec4| _mm256_set_m128(y.into(), x.into());
        // No `array::map` here: it can be compiled as a function of its own,
        // without AVX2.
        let windows = [
            local.window::<3, QUADRATIC_SPAN>(a.base),
            local.window::<3, QUADRATIC_SPAN>(b.base),
        ];
        let z_weight = |k: usize| pair(Vec4::splat(a.values[k].z), Vec4::splat(b.values[k].z));
        let z_weights = [z_weight(0), z_weight(1), z_weight(2)];
        let mut slabs = [_mm256_setzero_ps(); 3];
        let mut rows = [_mm256_setzero_ps(); 3];
        let mut columns = [_mm256_setzero_ps(); 3];
        for (i, slab) in slabs.iter_mut().enumerate() {
            for (j, row) in rows.iter_mut().enumerate() {
                let wxy = pair(
                    Vec4::splat(a.values[i].x * a.values[j].y),
                    Vec4::splat(b.values[i].x * b.values[j].y),
                );
                for (k, column) in columns.iter_mut().enumerate() {
                    let nodes = pair(windows[0][at(i, j, k)], windows[1][at(i, j, k)]);
                    let weighted = _mm256_mul_ps(nodes, _mm256_mul_ps(wxy, z_weights[k]));
                    *slab = _mm256_add_ps(*slab, weighted);
                    *row = _mm256_add_ps(*row, weighted);
                    *column = _mm256_add_ps(*column, weighted);
                }
            }
        }
        let lower = |v: __m256| Vec4::from(_mm256_castps256_ps128(v));
        let upper = |v: __m256| Vec4::from(_mm256_extractf128_ps::<1>(v));
        [
            StencilSums {
                slabs: [lower(slabs[0]), lower(slabs[1]), lower(slabs[2])],
                rows: [lower(rows[0]), lower(rows[1]), lower(rows[2])],
                columns: [lower(columns[0]), lower(columns[1]), lower(columns[2])],
            },
            StencilSums {
                slabs: [upper(slabs[0]), upper(slabs[1]), upper(slabs[2])],
                rows: [upper(rows[0]), upper(rows[1]), upper(rows[2])],
                columns: [upper(columns[0]), upper(columns[1]), upper(columns[2])],
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

/// The outer product a bᵀ.
#[inline(always)]
pub fn outer(a: Vec3, b: Vec3) -> Mat3 {
    Mat3::from_cols(a * b.x, a * b.y, a * b.z)
}
