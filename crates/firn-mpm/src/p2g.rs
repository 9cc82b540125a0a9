//! Particle to grid, the scatter (thesis §3.4 steps 1 to 3): mass and
//! momentum onto the grid, the elastic force f_i = −Σ_p V_p^0 τ_p ∇w_ip
//! (eq. 31-33), and once at the start the volumes V_p^0 (step 2), for both
//! transfer schemes:
//!
//! - PIC/FLIP with cubic B-splines (Stomakhin et al. 2013, the thesis):
//!   mass, momentum and force are summed apart ([`scatter_pic_flip`]).
//! - APIC with quadratic B-splines (Jiang et al. 2015, in the MLS-MPM form of
//!   Hu et al. 2018): the scatter sums w_ip (m_p v_p + (m_p C_p −
//!   Δt V_p^0 M_p⁻¹ τ_p)(x_i − x_p)) with M_p⁻¹ = 4/h², the force impulse
//!   inside the momentum, which conserves angular momentum ([`scatter_apic`]).
//!
//! Each block's particles are summed into a dense local copy of the nodes
//! around the block ([`LocalNodes`]), then added to the grid colour by
//! colour ([`add_block_sums`]), so every node sums its contributions in the
//! same order whatever the thread count; in a part of a split run, the
//! sums of blocks next to other parts are traded ([`SumTrade`]).
//! [`crate::reference::particles_to_grid`] is the plain form of this stage.

use glam::{IVec3, Mat3, Vec3, Vec4};
use rayon::prelude::*;

use firn_core::math::bspline::{QuadraticLanes, StencilWeights, cubic_weights};
use firn_core::math::isa::{Avx2, Isa, Kernel, PairLanes, PortablePairs};
use firn_core::math::lanes::{F32s, Mat3s, Simd, Vec3s, lanes_to_rows};

use crate::binning::{Bins, OccupiedBlock};
use crate::block_sums::{ForeignBlocks, SumTrade, Traded};
use crate::disjoint::{NodeWriter, scatter_by_colour};
use crate::grid::{Grid, GridLayout, Node};
use crate::local_nodes::{CUBIC_SPAN, LocalNodes, NodeSum, QUADRATIC_SPAN, at};
use crate::particles::Particles;

/// Steps 1 and 3 for PIC/FLIP: gives the grid storage for the particles'
/// blocks, then mass, momentum and elastic force on the grid, summed per
/// block in [`LocalNodes`] (in a part of a split run, `trade` swaps the
/// sums of the blocks next to other parts, [`add_block_sums`]). Each block
/// runs compiled for the instruction set ([`Isa::run`]); every instruction
/// set gives the same bits ([`PicFlipStencil`]). Returns the blocks
/// whose sums other parts sent (none in one process).
pub fn scatter_pic_flip(
    grid: &mut Grid,
    bins: &Bins,
    particles: &Particles,
    simd: Simd,
    trade: Option<&mut dyn SumTrade>,
) -> ForeignBlocks {
    let layout = grid.layout;
    let isa = Isa::of(simd);
    add_block_sums(grid, bins, trade, |block, sums| {
        isa.run(PicFlipBlock {
            layout,
            particles,
            block: bins.particles_of(block),
            local: sums,
        });
    })
}

/// One block's PIC/FLIP scatter, as a [`Kernel`] to compile per
/// instruction set.
struct PicFlipBlock<'a> {
    layout: GridLayout,
    particles: &'a Particles,
    block: &'a [u32],
    local: &'a mut LocalNodes<Node>,
}

impl Kernel for PicFlipBlock<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self, isa: Isa) {
        let particles = self.particles;
        let inverse_h = 1.0 / self.layout.cell_size;
        for &p in self.block {
            let p = p as usize;
            let weights = cubic_weights(self.layout.to_grid(particles.position[p]));
            let mass = particles.mass[p];
            let stencil = PicFlipStencil {
                momentum_mass: (particles.velocity[p] * mass).extend(mass),
                stress: particles.stress[p],
                inverse_h,
            };
            let window = self.local.window_mut::<4, CUBIC_SPAN>(weights.base);
            match isa.avx2() {
                #[cfg(target_arch = "x86_64")]
                Some(avx2) => stencil.add_to(avx2, &weights, window),
                _ => stencil.add_to(PortablePairs, &weights, window),
            }
        }
    }
}

/// What one particle adds to its 4x4x4 stencil: node (i, j, k) gets
/// w_ijk (m_p v_p, m_p) and the force −τ_p ∇w_ijk (eq. 31-33, 40), with
/// w_ijk = w_i^x w_j^y w_k^z and ∇w_ijk = (s_i^x w_j^y w_k^z,
/// w_i^x s_j^y w_k^z, w_i^x w_j^y s_k^z) / h (s the per-cell slopes).
///
/// Both node vectors are added at once, as a pair ([`Node::pair`]),
/// and the terms are built by the tensor product: per slab i the pairs
/// (w_i (m_p v_p, m_p), −s_i τ_0 / h), (0, −w_i τ_1 / h) and
/// (0, −w_i τ_2 / h) (τ_a the columns of τ_p); per row (i, j) from them
/// a_ij = (w_i w_j (m_p v_p, m_p), −(s_i w_j τ_0 + w_i s_j τ_1) / h) and
/// b_ij = (0, −w_i w_j τ_2 / h); node (i, j, k) gets a_ij w_k + b_ij s_k.
/// Every instruction set does these lane-wise operations in this order,
/// so the same bits.
struct PicFlipStencil {
    /// (m_p v_p, m_p).
    momentum_mass: Vec4,
    /// τ_p, V_p^0 included.
    stress: Mat3,
    /// 1 / h.
    inverse_h: f32,
}

impl PicFlipStencil {
    /// Adds the particle's terms to its stencil `window`.
    #[inline(always)]
    fn add_to<P: PairLanes>(
        &self,
        lanes: P,
        weights: &StencilWeights<4>,
        window: &mut [Node; CUBIC_SPAN],
    ) {
        let ((wx, sx), (wy, sy), (wz, sz)) = (weights.along(0), weights.along(1), weights.along(2));
        let splat = |value: f32| lanes.splat(value);
        let minus_inverse_h = -self.inverse_h;
        let stress = self.stress;
        let (t0, t1, t2) = (
            stress.x_axis.extend(0.0),
            stress.y_axis.extend(0.0),
            stress.z_axis.extend(0.0),
        );
        for i in 0..4 {
            // The slab's pairs, to be multiplied by w_j, s_j and w_j.
            let weighted = lanes.pair(self.momentum_mass * wx[i], t0 * (sx[i] * minus_inverse_h));
            let sloped = lanes.pair(Vec4::ZERO, t1 * (wx[i] * minus_inverse_h));
            let sloped_z = lanes.pair(Vec4::ZERO, t2 * (wx[i] * minus_inverse_h));
            for j in 0..4 {
                let a = weighted * splat(wy[j]) + sloped * splat(sy[j]);
                let b = sloped_z * splat(wy[j]);
                for k in 0..4 {
                    window[at(i, j, k)].add_pair(lanes, a * splat(wz[k]) + b * splat(sz[k]));
                }
            }
        }
    }
}

/// Steps 1 and 3 for APIC: gives the grid storage for the particles'
/// blocks, then mass and affine momentum including the force impulse,
/// summed per block in a [`LocalNodes`] of `Vec4`s (momentum, mass), with
/// `trade` as in [`scatter_pic_flip`].
/// With AVX2 (`simd` not portable, where the CPU has it) two of a stencil
/// row's three nodes are added in one 256-bit register; every lane does
/// the same IEEE operations either way, so the sums have the same bits.
/// Each block runs compiled for the instruction set ([`Isa::run`]).
/// Returns the blocks whose sums other parts sent (none in one process).
pub fn scatter_apic(
    grid: &mut Grid,
    bins: &Bins,
    particles: &Particles,
    dt: f32,
    simd: Simd,
    trade: Option<&mut dyn SumTrade>,
) -> ForeignBlocks {
    let scatter = ApicScatter {
        layout: grid.layout,
        dt,
        particles,
    };
    let isa = Isa::of(simd);
    add_block_sums(grid, bins, trade, |block, sums| {
        isa.run(ScatterBlock {
            scatter: &scatter,
            local: sums,
            particles: bins.particles_of(block),
        });
    })
}

/// One block's APIC scatter, as a [`Kernel`] to compile per instruction set.
struct ScatterBlock<'s, 'a> {
    scatter: &'s ApicScatter<'a>,
    local: &'s mut LocalNodes<Vec4>,
    particles: &'s [u32],
}

impl Kernel for ScatterBlock<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn run(self, isa: Isa) {
        self.scatter.block(isa.avx2(), self.local, self.particles);
    }
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
    /// rows added in AVX2 registers given `avx2`.
    #[inline(always)]
    fn block(&self, avx2: Option<Avx2>, local: &mut LocalNodes<Vec4>, block: &[u32]) {
        for group in block.chunks(TERM_LANES) {
            let terms = self.terms(avx2, group);
            for terms in &terms[..group.len()] {
                terms.add_to(avx2, local);
            }
        }
    }

    /// The terms of the (up to eight) particles `group`, in SIMD lanes with
    /// the operations glam does per particle (so the same bits), then turned
    /// into one [`ParticleTerms`] each; lanes past the group's end repeat its
    /// last particle.
    #[inline(always)]
    fn terms(&self, avx2: Option<Avx2>, group: &[u32]) -> [ParticleTerms; TERM_LANES] {
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
            if avx2.is_none() {
                gradient.set_lane(lane, particles.velocity_gradient[p]);
                stress.set_lane(lane, particles.stress[p]);
            }
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = avx2 {
            let (gradients, stresses) = (&particles.velocity_gradient, &particles.stress);
            avx2.load_eight(
                &mut gradient,
                0,
                std::array::from_fn(|l| &gradients[particle(l)]),
            );
            avx2.load_eight(
                &mut stress,
                0,
                std::array::from_fn(|l| &stresses[particle(l)]),
            );
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
            for (terms, row) in terms.iter_mut().zip(rows_of(avx2, values)) {
                terms.rows[part] = row;
            }
        }
        terms
    }
}

/// Particles whose scatter terms are computed together in SIMD lanes.
const TERM_LANES: usize = 8;

/// [`lanes_to_rows`], by AVX2 shuffles given `avx2`.
#[inline(always)]
fn rows_of(avx2: Option<Avx2>, values: &[F32s<TERM_LANES>; 8]) -> [[f32; 8]; TERM_LANES] {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = avx2 {
        return avx2.lanes_to_rows(values);
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
    /// affine part growing by one column per stencil step; given `avx2`
    /// two of a row's nodes are added in one 256-bit register.
    #[inline(always)]
    fn add_to(&self, avx2: Option<Avx2>, local: &mut LocalNodes<Vec4>) {
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
                match avx2 {
                    #[cfg(target_arch = "x86_64")]
                    Some(avx2) => row.add_by_pairs(avx2, sums, at_ij, wxy),
                    _ => row.add(sums, at_ij, wxy),
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
    #[inline(always)]
    fn add_by_pairs(&self, avx2: Avx2, sums: &mut [Vec4; 3], at_ij: Vec4, wxy: f32) {
        let first_two = |v: [Vec4; 3]| avx2.pair(v[0], v[1]);
        let weights = first_two(self.weights.map(Vec4::splat));
        let terms = (avx2.pair(at_ij, at_ij) + first_two(self.steps))
            * (avx2.pair(Vec4::splat(wxy), Vec4::splat(wxy)) * weights);
        [sums[0], sums[1]] = (avx2.pair(sums[0], sums[1]) + terms).halves();
        sums[2] += (at_ij + self.steps[2]) * (wxy * self.weights[2]);
    }
}

/// Gives the grid storage for the particles' blocks and adds every
/// occupied block's sums (`sums_of(block, sums)` adds its particles to
/// zeroed `sums`), colour by colour, so that each node sums its blocks in
/// the same order whatever the thread count. In a part of a split run
/// (`trade` given), the sums of the blocks other parts read are made first
/// and traded, and the other parts' sums are added in their colour's turn.
/// Returns the blocks whose sums the other parts sent.
fn add_block_sums<T: NodeSum>(
    grid: &mut Grid,
    bins: &Bins,
    trade: Option<&mut dyn SumTrade>,
    sums_of: impl Fn(&OccupiedBlock, &mut LocalNodes<T>) + Sync,
) -> ForeignBlocks {
    let traded = trade.map(|trade| Traded::trade(bins, grid.layout, trade, &sums_of));
    match &traded {
        Some(traded) => grid.allocate(&traded.blocks_with_storage(bins, grid.layout)),
        None => grid.allocate(bins.active_blocks()),
    }
    let (table, nodes) = grid.parts_mut();
    let writer = NodeWriter::new(nodes);
    for (colour, blocks) in bins.colours().iter().enumerate() {
        blocks.par_iter().for_each(|&block| {
            let made = traded.as_ref().and_then(|traded| traded.own_sums(block));
            match made {
                Some(sums) => sums.add_sums_to(&table, &writer),
                None => {
                    let block = &bins.occupied()[block as usize];
                    let mut sums = LocalNodes::around(block.coord);
                    sums_of(block, &mut sums);
                    sums.add_sums_to(&table, &writer);
                }
            }
        });
        if let Some(traded) = &traded {
            traded.received[colour]
                .par_iter()
                .for_each(|sums| sums.add_sums_to(&table, &writer));
        }
    }
    traded.map(|traded| traded.foreign).unwrap_or_default()
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
