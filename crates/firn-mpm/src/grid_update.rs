//! The grid update (thesis §3.4 steps 3 to 5): grid velocities from the
//! scattered momentum, v_i = p_i / m_i, the forces and gravity,
//! v_i* = v_i + Δt (f_i / m_i + g), the wind's drag where the scene has one
//! ([`crate::wind`], equation W3), and the grid-based collisions with the
//! colliders (Quellcode 12), then the rigid bodies, whose momentum exchange
//! with each node is summed ([`crate::coupling`]).
//! [`crate::reference::update_grid_velocities`] is the plain form of this
//! stage.

use glam::{DVec3, IVec3, Vec3};
use rayon::prelude::*;

use crate::contact::Colliders;
use crate::coupling::{BodyContacts, ImpulseSum};
use crate::grid::{BLOCK_NODES, BLOCK_WIDTH, Grid, GridLayout, Node};
use crate::wind::{AirDrag, relax};

/// Smallest number of blocks a worker thread takes at once.
const MIN_BLOCKS_PER_TASK: usize = 16;

/// Runs `visit` on the 64 nodes of every block with storage (the active
/// blocks of the last [`Grid::allocate`]), blocks in parallel.
pub(crate) fn for_each_active_block(grid: &mut Grid, visit: impl Fn(IVec3, &mut [Node]) + Sync) {
    grid.par_blocks_mut()
        .with_min_len(MIN_BLOCKS_PER_TASK)
        .for_each(|(block, nodes)| visit(block, nodes));
}

/// How the grid update treats the second node vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridForces {
    /// It holds the force f_i (PIC/FLIP).
    Separate,
    /// Forces are already in the momentum (APIC).
    InMomentum,
}

/// The wind of one substep: its drag and the time at which the air's
/// velocity is taken (the end of the substep, as for the colliders).
#[derive(Clone, Copy, Debug)]
pub struct WindStep<'a> {
    /// The drag law and the air's field.
    pub drag: &'a AirDrag,
    /// Simulated time of the air's velocity.
    pub time: f64,
}

/// What the grid update gave the snow besides its forces.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GridImpulses {
    /// The wind's impulse, Σ m_i Δv_i of its drag (zero without wind), N s.
    pub wind: DVec3,
    /// Each rigid body's exchange with the snow, in body order.
    pub bodies: Vec<ImpulseSum>,
}

/// Steps 4 and 5: v_i = p_i / m_i, v_i* = v_i + Δt (f_i / m_i + g), the
/// wind's drag, then grid collisions with the colliders and the rigid
/// `bodies`, on every node with mass. Returns the wind's impulse, summed
/// block by block in a fixed order, and the bodies' exchanges, summed in
/// fixed point, so that both are the same for any thread count.
pub fn update_grid(
    grid: &mut Grid,
    forces: GridForces,
    dt: f32,
    gravity: Vec3,
    colliders: &Colliders,
    wind: Option<WindStep>,
    bodies: &BodyContacts,
) -> GridImpulses {
    let step = NodeStep {
        layout: grid.layout,
        forces,
        dt,
        gravity,
        colliders,
        bodies,
    };
    if wind.is_none() && bodies.is_empty() {
        for_each_active_block(grid, |block, nodes| {
            step.update_block(block, nodes, None, &mut []);
        });
        return GridImpulses::default();
    }
    let air = wind.map(|wind| air_at_nodes(grid, &step, wind));
    let per_block: Vec<(DVec3, Vec<ImpulseSum>)> = grid
        .par_blocks_mut()
        .enumerate()
        .with_min_len(MIN_BLOCKS_PER_TASK)
        .map(|(index, (block, nodes))| {
            let air = air
                .as_ref()
                .map(|air| &air[index * BLOCK_NODES..(index + 1) * BLOCK_NODES]);
            let mut sums = vec![ImpulseSum::default(); bodies.len()];
            let wind = step.update_block(block, nodes, air, &mut sums);
            (wind, sums)
        })
        .collect();
    let mut impulses = GridImpulses {
        wind: DVec3::ZERO,
        bodies: vec![ImpulseSum::default(); bodies.len()],
    };
    for (wind, sums) in &per_block {
        impulses.wind += *wind;
        for (total, sum) in impulses.bodies.iter_mut().zip(sums) {
            total.merge(sum);
        }
    }
    impulses
}

/// The air at a node: its velocity and the rate of its drag on the node's
/// snow (equation W3).
#[derive(Clone, Copy, Debug, Default)]
struct NodeAir {
    wind: Vec3,
    rate: f32,
}

/// The air at every node with storage, in pool order: a read-only pass, as
/// the drag's exposure depends on the neighbours' masses.
fn air_at_nodes(grid: &Grid, step: &NodeStep, wind: WindStep) -> Vec<NodeAir> {
    let table = grid.page_table();
    let nodes = &grid.nodes;
    let mass_at = |node: IVec3| grid.node_mass(node);
    let mut air = vec![NodeAir::default(); nodes.len()];
    air.par_chunks_mut(BLOCK_NODES)
        .zip(nodes.par_chunks(BLOCK_NODES))
        .zip(grid.resident_blocks().par_iter())
        .with_min_len(MIN_BLOCKS_PER_TASK)
        .for_each(|((air, block_nodes), &block)| {
            let block = table.layout.block_coord(block as usize);
            let winds = wind.drag.block_wind(&table.layout, block, wind.time);
            for (local, node) in block_nodes.iter().enumerate() {
                let mass = node.mass();
                if mass <= 0.0 {
                    continue;
                }
                let (_, velocity) = step.velocities(node);
                let position = GridLayout::node_in_block(block, local);
                air[local] = NodeAir {
                    wind: winds[local],
                    rate: wind
                        .drag
                        .rate(position, mass, velocity, winds[local], mass_at),
                };
            }
        });
    air
}

/// What the grid update does to each node.
struct NodeStep<'a> {
    layout: GridLayout,
    forces: GridForces,
    dt: f32,
    gravity: Vec3,
    colliders: &'a Colliders<'a>,
    bodies: &'a BodyContacts,
}

impl NodeStep<'_> {
    /// v_i = p_i / m_i and v_i* = v_i + Δt (f_i / m_i + g) of a node with
    /// mass, before the wind and the collisions.
    fn velocities(&self, node: &Node) -> (Vec3, Vec3) {
        let inverse_mass = 1.0 / node.mass();
        let velocity = node.velocity() * inverse_mass;
        let acceleration = match self.forces {
            GridForces::Separate => node.velocity_new() * inverse_mass + self.gravity,
            GridForces::InMomentum => self.gravity,
        };
        (velocity, velocity + acceleration * self.dt)
    }

    /// Updates the nodes of one block, blown by `air` where there is wind;
    /// returns the wind's impulse on them and adds the rigid bodies'
    /// exchanges with them to `sums`.
    fn update_block(
        &self,
        block: IVec3,
        nodes: &mut [Node],
        air: Option<&[NodeAir]>,
        sums: &mut [ImpulseSum],
    ) -> DVec3 {
        let mut impulse = DVec3::ZERO;
        let near = match self.bodies.is_empty() {
            true => Vec::new(),
            false => {
                let first = GridLayout::node_in_block(block, 0);
                let last = first + IVec3::splat(BLOCK_WIDTH - 1);
                let (low, high) = (
                    self.layout.node_position(first),
                    self.layout.node_position(last),
                );
                self.bodies.near(low, high)
            }
        };
        for (local, node) in nodes.iter_mut().enumerate() {
            let mass = node.mass();
            if mass <= 0.0 {
                continue;
            }
            let (velocity, mut velocity_new) = self.velocities(node);
            if let Some(air) = air {
                let blown = relax(velocity_new, air[local].wind, air[local].rate, self.dt);
                impulse += f64::from(mass) * (blown - velocity_new).as_dvec3();
                velocity_new = blown;
            }
            let coord = GridLayout::node_in_block(block, local);
            let position = self.layout.node_position(coord);
            node.velocity_mass = velocity.extend(mass);
            let mut collided = self.colliders.collide(position, velocity_new);
            if !near.is_empty() {
                collided = self
                    .bodies
                    .collide(&near, (coord, position), mass, collided, sums);
            }
            node.set_velocity_new(collided);
        }
        impulse
    }
}

/// Zeroes every node with storage, which includes every node the last
/// scatter could have touched.
pub fn clear_grid(grid: &mut Grid) {
    for_each_active_block(grid, |_, nodes| nodes.fill(Node::default()));
}
