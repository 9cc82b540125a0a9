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

use firn_core::math::bspline::{StencilWeights, cubic_weights, quadratic_values};
use firn_core::math::lanes::Simd;

use crate::binning::{Bins, OccupiedBlock};
use crate::contact::{PlacedCollider, collide_all};
use crate::grid::{BLOCK_NODES, BLOCK_WIDTH, Grid, GridLayout, Node, PageTable};
use crate::particles::Particles;
use crate::update::{GatherStats, UpdateContext, gather_with};

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

/// Nodes per axis that the particles of one block reach: from one before
/// the block to two past it (see [`crate::binning`]).
const REACH: i32 = BLOCK_WIDTH + 3;

/// The scatter's sums for the nodes around one block, in a dense local
/// array: particles add to it at fixed offsets from their stencil's corner,
/// with no page-table lookups, and the sums go to the grid once per block.
struct LocalNodes {
    /// Grid coordinate of `sums[0]`.
    first_node: IVec3,
    /// Sums over the block's particles, x-major.
    sums: [Node; (REACH * REACH * REACH) as usize],
}

impl LocalNodes {
    /// Empty sums around `block`.
    fn around(block: IVec3) -> LocalNodes {
        LocalNodes {
            first_node: block * BLOCK_WIDTH - IVec3::ONE,
            sums: [Node::default(); (REACH * REACH * REACH) as usize],
        }
    }

    /// A copy for [`LocalNodes::copy_from`] to fill.
    fn for_gather() -> LocalNodes {
        LocalNodes::around(IVec3::ZERO)
    }

    /// Index in `sums` of an `N`-wide stencil's first node `base`; its node
    /// (i, j, k) is `(i REACH + j) REACH + k` further. Binning puts the
    /// stencil of every particle of the block inside (panics otherwise).
    #[inline(always)]
    fn corner<const N: usize>(&self, base: IVec3) -> usize {
        let corner = base - self.first_node;
        assert!(
            corner.cmpge(IVec3::ZERO).all() && corner.cmple(IVec3::splat(REACH - N as i32)).all(),
            "a particle's stencil at {base} leaves the reach of its block"
        );
        ((corner.x * REACH + corner.y) * REACH + corner.z) as usize
    }

    /// Calls `run(to, from, len)` for each run of the nodes around a block
    /// (the first at `first_node`) that is contiguous along z both in
    /// `sums` and in the grid: `sums[to..to + len]` are the grid's nodes
    /// `from..from + len`, or lie outside the grid where `from` is `None`.
    /// Every block within one block of an occupied one has storage (see
    /// [`crate::binning`]), so one slot lookup per neighbouring block finds
    /// all.
    fn runs(
        first_node: IVec3,
        table: &PageTable,
        mut run: impl FnMut(usize, Option<usize>, usize),
    ) {
        /// Per axis, in three parts: the neighbouring block (−1, 0, +1),
        /// the first node taken from it, the first place here and the
        /// number of nodes.
        const PARTS: [(i32, usize, usize, usize); 3] = [(-1, 3, 0, 1), (0, 0, 1, 4), (1, 0, 5, 2)];
        const WIDTH: usize = BLOCK_WIDTH as usize;
        let block = (first_node + IVec3::ONE) / BLOCK_WIDTH;
        let blocks = table.layout.blocks.as_ivec3();
        for (dx, from_x, to_x, len_x) in PARTS {
            for (dy, from_y, to_y, len_y) in PARTS {
                for (dz, from_z, to_z, len_z) in PARTS {
                    let neighbour = block + IVec3::new(dx, dy, dz);
                    let inside =
                        neighbour.cmpge(IVec3::ZERO).all() && neighbour.cmplt(blocks).all();
                    let first = inside.then(|| {
                        let slot = table
                            .slot(table.layout.block_index(neighbour))
                            .expect("the blocks around an occupied block have storage");
                        slot * BLOCK_NODES
                    });
                    for x in 0..len_x {
                        for y in 0..len_y {
                            let to =
                                ((to_x + x) * REACH as usize + to_y + y) * REACH as usize + to_z;
                            let from = first.map(|first| {
                                first + ((from_x + x) * WIDTH + from_y + y) * WIDTH + from_z
                            });
                            run(to, from, len_z);
                        }
                    }
                }
            }
        }
    }

    /// Overwrites the copy with the grid's nodes around `block`, for the
    /// gather; nodes outside the grid (which no particle's stencil reaches)
    /// are zero. The copy is made run by run ([`LocalNodes::runs`]) and
    /// reused from block to block, so it is never cleared or moved whole.
    fn copy_from(&mut self, table: &PageTable, nodes: &[Node], block: IVec3) {
        self.first_node = block * BLOCK_WIDTH - IVec3::ONE;
        LocalNodes::runs(self.first_node, table, |to, from, len| {
            let run = &mut self.sums[to..to + len];
            match from {
                Some(from) => run.copy_from_slice(&nodes[from..from + len]),
                None => run.fill(Node::default()),
            }
        });
    }

    /// The node (i, j, k) of a stencil whose first node is at `corner`.
    #[inline(always)]
    fn at(&self, corner: usize, i: usize, j: usize, k: usize) -> &Node {
        &self.sums[corner + (i * REACH as usize + j) * REACH as usize + k]
    }

    /// Adds the sums into the grid's nodes (those a particle reached: every
    /// reached node has mass, and only they are sure to exist), run by run
    /// ([`LocalNodes::runs`]).
    fn add_to(&self, table: &PageTable, writer: &NodeWriter<Node>) {
        LocalNodes::runs(self.first_node, table, |to, from, len| {
            for (n, sum) in self.sums[to..to + len].iter().enumerate() {
                if sum.mass() == 0.0 {
                    continue;
                }
                let from = from.expect("a reached node lies inside the grid");
                writer.update(from + n, |node| {
                    node.velocity_mass += sum.velocity_mass;
                    node.velocity_new += sum.velocity_new;
                });
            }
        });
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
        let mut local = LocalNodes::around(block.coord);
        for &p in bins.particles_of(block) {
            let p = p as usize;
            let weights = cubic_weights(layout.to_grid(particles.position[p]));
            let mass = particles.mass[p];
            let momentum_mass = (particles.velocity[p] * mass).extend(mass);
            let stress = particles.stress[p];
            let corner = local.corner::<4>(weights.base);
            for i in 0..4 {
                for j in 0..4 {
                    let row = corner + (i * REACH as usize + j) * REACH as usize;
                    for (k, sum) in local.sums[row..row + 4].iter_mut().enumerate() {
                        let w = weights.weight(i, j, k);
                        let force = -(stress * (weights.gradient(i, j, k) * inverse_h));
                        sum.velocity_mass += momentum_mass * w;
                        sum.velocity_new += force.extend(0.0);
                    }
                }
            }
        }
        local.add_to(&table, writer);
    });
}

/// Steps 1 and 3 for APIC: mass and affine momentum including the force
/// impulse, summed per block in [`LocalNodes`].
pub fn scatter_apic(grid: &mut Grid, bins: &Bins, particles: &Particles, dt: f32) {
    let (table, nodes) = grid.parts_mut();
    let layout = table.layout;
    let h = layout.cell_size;
    let inverse_inertia = 4.0 / (h * h);
    scatter_blocks_by_colour(nodes, bins, |block, writer| {
        let mut local = LocalNodes::around(block.coord);
        for &p in bins.particles_of(block) {
            let p = p as usize;
            let weights = quadratic_values(layout.to_grid(particles.position[p]));
            let mass = particles.mass[p];
            // Maps a node offset in cells to momentum: (m C − Δt M⁻¹ V0 τ) h.
            let affine = (particles.velocity_gradient[p] * mass
                - particles.stress[p] * (dt * inverse_inertia))
                * h;
            // Node (i, j, k) gets w (m v + affine ((i, j, k) − offset), m):
            // the affine part grows by one column per stencil step.
            let at_base = (particles.velocity[p] * mass - affine * weights.offset).extend(mass);
            let step = |column: Vec3, n: usize| column.extend(0.0) * n as f32;
            let corner = local.corner::<3>(weights.base);
            for i in 0..3 {
                let at_i = at_base + step(affine.x_axis, i);
                for j in 0..3 {
                    let at_ij = at_i + step(affine.y_axis, j);
                    let wxy = weights.values[i].x * weights.values[j].y;
                    let row = corner + (i * REACH as usize + j) * REACH as usize;
                    for (k, sum) in local.sums[row..row + 3].iter_mut().enumerate() {
                        sum.velocity_mass +=
                            (at_ij + step(affine.z_axis, k)) * (wxy * weights.values[k].z);
                    }
                }
            }
        }
        local.add_to(&table, writer);
    });
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
    colliders: &[PlacedCollider],
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
            node.set_velocity_new(collide_all(
                colliders,
                position,
                velocity + acceleration * dt,
            ));
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
    let table = grid.page_table();
    let layout = table.layout;
    let inverse_h = 1.0 / layout.cell_size;
    let local_grid = |local: &mut LocalNodes, block| local.copy_from(&table, &grid.nodes, block);
    gather_with(
        particles,
        bins,
        context,
        simd,
        LocalNodes::for_gather,
        local_grid,
        |local, position, velocity| {
            let weights = cubic_weights(layout.to_grid(position));
            let corner = local.corner::<4>(weights.base);
            let mut pic = Vec3::ZERO;
            let mut change = Vec3::ZERO;
            let mut gradient = Mat3::ZERO;
            for i in 0..4 {
                for j in 0..4 {
                    for k in 0..4 {
                        let node = local.at(corner, i, j, k);
                        let w = weights.weight(i, j, k);
                        let grad_w = weights.gradient(i, j, k) * inverse_h;
                        pic += node.velocity_new() * w;
                        change += (node.velocity_new() - node.velocity()) * w;
                        gradient += outer(node.velocity_new(), grad_w);
                    }
                }
            }
            (pic * (1.0 - flip) + (velocity + change) * flip, gradient)
        },
    )
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
    let table = grid.page_table();
    let layout = table.layout;
    // (4/h²) times the offset in world units (cells · h).
    let affine_scale = 4.0 / layout.cell_size;
    let local_grid = |local: &mut LocalNodes, block| local.copy_from(&table, &grid.nodes, block);
    gather_with(
        particles,
        bins,
        context,
        simd,
        LocalNodes::for_gather,
        local_grid,
        |local, position, _| {
            let (velocity, affine) = interpolate_apic(local, layout.to_grid(position));
            (velocity, affine * affine_scale)
        },
    )
}

/// v_p = Σ w_ip v_i and Σ w_ip v_i (x_i − x_p)ᵀ in cells, for one particle
/// at grid coordinate `x`, from the nodes around its block.
#[inline(always)]
fn interpolate_apic(local: &LocalNodes, x: Vec3) -> (Vec3, Mat3) {
    let weights = quadratic_values(x);
    let corner = local.corner::<3>(weights.base);
    // Weighted velocities summed per x-slab, y-row and z-column of the
    // stencil: their totals give v_p, their first moments C_p.
    let (mut slabs, mut rows, mut columns) = ([Vec4::ZERO; 3], [Vec4::ZERO; 3], [Vec4::ZERO; 3]);
    for (i, slab) in slabs.iter_mut().enumerate() {
        for (j, row) in rows.iter_mut().enumerate() {
            let wxy = weights.values[i].x * weights.values[j].y;
            for (k, column) in columns.iter_mut().enumerate() {
                let weighted = local.at(corner, i, j, k).velocity_new * (wxy * weights.values[k].z);
                *slab += weighted;
                *row += weighted;
                *column += weighted;
            }
        }
    }
    let velocity = slabs[0] + slabs[1] + slabs[2];
    // Σ w v (n − offset) along one axis, from the sums at n = 0, 1, 2.
    let moment =
        |sums: [Vec4; 3], offset: f32| (sums[1] + sums[2] * 2.0 - velocity * offset).truncate();
    let offset = weights.offset;
    let affine = Mat3::from_cols(
        moment(slabs, offset.x),
        moment(rows, offset.y),
        moment(columns, offset.z),
    );
    (velocity.truncate(), affine)
}

/// The outer product a bᵀ.
#[inline(always)]
pub fn outer(a: Vec3, b: Vec3) -> Mat3 {
    Mat3::from_cols(a * b.x, a * b.y, a * b.z)
}
