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

use glam::{IVec3, Mat3, Vec3};
use rayon::prelude::*;

use firn_core::math::bspline::{StencilWeights, cubic_weights, quadratic_weights};

use crate::binning::Bins;
use crate::constitutive::{MaterialConstants, PlasticProjection, scaled_stress};
use crate::contact::{PlacedCollider, collide_all};
use crate::grid::{Grid, GridLayout, Node};
use crate::particles::Particles;

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
    let writer = NodeWriter::new(nodes);
    for colour in &bins.colours {
        colour
            .par_iter()
            .for_each(|&block| scatter(bins.particles_of(&bins.occupied[block as usize]), &writer));
    }
}

/// Runs `visit` on the 64 nodes of every block with storage (the active
/// blocks of the last [`Grid::allocate`]), blocks in parallel.
pub(crate) fn for_each_active_block(grid: &mut Grid, visit: impl Fn(IVec3, &mut [Node]) + Sync) {
    grid.par_blocks_mut()
        .with_min_len(16)
        .for_each(|(block, nodes)| visit(block, nodes));
}

/// Steps 1 and 3 for PIC/FLIP: mass, momentum and elastic force on the grid.
pub fn scatter_pic_flip(grid: &mut Grid, bins: &Bins, particles: &Particles) {
    let (table, nodes) = grid.parts_mut();
    let layout = table.layout;
    let inverse_h = 1.0 / layout.cell_size;
    scatter_by_colour(nodes, bins, |block, writer| {
        for &p in block {
            let p = p as usize;
            let weights = cubic_weights(layout.to_grid(particles.position[p]));
            let mass = particles.mass[p];
            let momentum = particles.velocity[p] * mass;
            let stress = particles.stress[p];
            let stencil = table.stencil(weights.base);
            for i in 0..4 {
                for j in 0..4 {
                    for k in 0..4 {
                        let w = weights.weight(i, j, k);
                        let force = -(stress * (weights.gradient(i, j, k) * inverse_h));
                        writer.update(stencil.index(i, j, k), |node| {
                            node.mass += mass * w;
                            node.velocity += momentum * w;
                            node.velocity_new += force;
                        });
                    }
                }
            }
        }
    });
}

/// Steps 1 and 3 for APIC: mass and affine momentum including the force impulse.
pub fn scatter_apic(grid: &mut Grid, bins: &Bins, particles: &Particles, dt: f32) {
    let (table, nodes) = grid.parts_mut();
    let layout = table.layout;
    let h = layout.cell_size;
    let inverse_inertia = 4.0 / (h * h);
    scatter_by_colour(nodes, bins, |block, writer| {
        for &p in block {
            let p = p as usize;
            let weights = quadratic_weights(layout.to_grid(particles.position[p]));
            let mass = particles.mass[p];
            let momentum = particles.velocity[p] * mass;
            // Maps a node offset in cells to momentum: (m C − Δt M⁻¹ V0 τ) h.
            let affine = (particles.velocity_gradient[p] * mass
                - particles.stress[p] * (dt * inverse_inertia))
                * h;
            let stencil = table.stencil(weights.base);
            for i in 0..3 {
                for j in 0..3 {
                    for k in 0..3 {
                        let w = weights.weight(i, j, k);
                        let node_momentum = (momentum + affine * weights.node_offset(i, j, k)) * w;
                        writer.update(stencil.index(i, j, k), |node| {
                            node.mass += mass * w;
                            node.velocity += node_momentum;
                        });
                    }
                }
            }
        }
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
                        writer.update(stencil.index(i, j, k), |node| node.mass += mass);
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
                            grid.nodes[stencil.index(i, j, k)].mass * weights.weight(i, j, k);
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
            if node.mass <= 0.0 {
                continue;
            }
            let inverse_mass = 1.0 / node.mass;
            node.velocity *= inverse_mass;
            let acceleration = match forces {
                GridForces::Separate => node.velocity_new * inverse_mass + gravity,
                GridForces::InMomentum => gravity,
            };
            let position = layout.node_position(GridLayout::node_in_block(block, local));
            node.velocity_new = collide_all(colliders, position, node.velocity + acceleration * dt);
        }
    });
}

/// Zeroes every node with storage, which includes every node the last
/// scatter could have touched.
pub fn clear_grid(grid: &mut Grid) {
    for_each_active_block(grid, |_, nodes| nodes.fill(Node::default()));
}

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

/// One particle's mutable state during the gather.
struct ParticleUpdate<'a> {
    position: &'a mut Vec3,
    velocity: &'a mut Vec3,
    elastic: &'a mut Mat3,
    plastic_j: &'a mut f32,
    stress: &'a mut Mat3,
    velocity_gradient: &'a mut Mat3,
    volume0: f32,
    material: u16,
}

impl ParticleUpdate<'_> {
    /// Steps 7, 9 and 10 for a particle whose new grid velocity and velocity
    /// gradient are known: plasticity (eq. 41-43), the stress for the next
    /// scatter, particle collisions at the predicted position, advection.
    #[inline(always)]
    fn finish(
        self,
        index: usize,
        velocity_gradient: Mat3,
        velocity: Vec3,
        context: &UpdateContext,
    ) -> GatherStats {
        let constants = &context.materials[self.material as usize];
        let trial = (Mat3::IDENTITY + velocity_gradient * context.dt) * *self.elastic;
        let projection = PlasticProjection::new(trial, constants);
        let elastic = projection.elastic();
        let plastic_j = *self.plastic_j * projection.plastic_j_ratio();
        *self.stress = scaled_stress(&projection, elastic, plastic_j, self.volume0, constants);
        *self.elastic = elastic;
        *self.plastic_j = plastic_j;
        *self.velocity_gradient = velocity_gradient;

        let predicted = *self.position + velocity * context.dt;
        let velocity = collide_all(context.colliders, predicted, velocity);
        *self.velocity = velocity;
        *self.position += velocity * context.dt;

        let position = *self.position;
        let wave_speed_squared =
            constants.wave_speed_squared * constants.hardening_factor(plastic_j);
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
}

/// Steps 7-10 for every particle in parallel: `interpolate` reads the grid at a
/// particle (position, old velocity) and returns its new velocity and ∇v_p.
fn gather_with(
    particles: &mut Particles,
    context: &UpdateContext,
    interpolate: impl Fn(Vec3, Vec3) -> (Vec3, Mat3) + Sync,
) -> GatherStats {
    (
        particles.position.par_iter_mut(),
        particles.velocity.par_iter_mut(),
        particles.elastic.par_iter_mut(),
        particles.plastic_j.par_iter_mut(),
        particles.stress.par_iter_mut(),
        particles.velocity_gradient.par_iter_mut(),
        particles.volume0.par_iter(),
        particles.material.par_iter(),
    )
        .into_par_iter()
        .enumerate()
        .with_min_len(512)
        .map(
            |(
                p,
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
                let (new_velocity, gradient) = interpolate(*position, *velocity);
                let update = ParticleUpdate {
                    position,
                    velocity,
                    elastic,
                    plastic_j,
                    stress,
                    velocity_gradient,
                    volume0: *volume0,
                    material: *material,
                };
                update.finish(p, gradient, new_velocity, context)
            },
        )
        .reduce(GatherStats::default, GatherStats::merge)
}

/// Steps 7-10 for PIC/FLIP with FLIP share `flip`:
/// v_p = (1 − α) Σ w_ip v_i^{n+1} + α (v_p + Σ w_ip (v_i^{n+1} − v_i)) and
/// ∇v_p = Σ v_i^{n+1} (∇w_ip)ᵀ.
pub fn gather_pic_flip(
    grid: &Grid,
    particles: &mut Particles,
    flip: f32,
    context: &UpdateContext,
) -> GatherStats {
    let table = grid.page_table();
    let layout = table.layout;
    let inverse_h = 1.0 / layout.cell_size;
    let nodes = &grid.nodes;
    gather_with(particles, context, |position, velocity| {
        let weights = cubic_weights(layout.to_grid(position));
        let stencil = table.stencil(weights.base);
        let mut pic = Vec3::ZERO;
        let mut change = Vec3::ZERO;
        let mut gradient = Mat3::ZERO;
        for i in 0..4 {
            for j in 0..4 {
                for k in 0..4 {
                    let node = &nodes[stencil.index(i, j, k)];
                    let w = weights.weight(i, j, k);
                    let grad_w = weights.gradient(i, j, k) * inverse_h;
                    pic += node.velocity_new * w;
                    change += (node.velocity_new - node.velocity) * w;
                    gradient += outer(node.velocity_new, grad_w);
                }
            }
        }
        (pic * (1.0 - flip) + (velocity + change) * flip, gradient)
    })
}

/// Steps 7-10 for APIC: v_p = Σ w_ip v_i, C_p = (4/h²) Σ w_ip v_i (x_i − x_p)ᵀ,
/// and ∇v_p = C_p.
pub fn gather_apic(grid: &Grid, particles: &mut Particles, context: &UpdateContext) -> GatherStats {
    let table = grid.page_table();
    let layout = table.layout;
    // (4/h²) times the offset in world units (cells · h).
    let affine_scale = 4.0 / layout.cell_size;
    let nodes = &grid.nodes;
    gather_with(particles, context, |position, _| {
        let weights = quadratic_weights(layout.to_grid(position));
        let stencil = table.stencil(weights.base);
        let mut velocity = Vec3::ZERO;
        let mut affine = Mat3::ZERO;
        for i in 0..3 {
            for j in 0..3 {
                for k in 0..3 {
                    let node_velocity =
                        nodes[stencil.index(i, j, k)].velocity_new * weights.weight(i, j, k);
                    velocity += node_velocity;
                    affine += outer(node_velocity, weights.node_offset(i, j, k));
                }
            }
        }
        (velocity, affine * affine_scale)
    })
}

/// The outer product a bᵀ.
#[inline(always)]
pub fn outer(a: Vec3, b: Vec3) -> Mat3 {
    Mat3::from_cols(a * b.x, a * b.y, a * b.z)
}
