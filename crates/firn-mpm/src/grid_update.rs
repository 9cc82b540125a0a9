//! The grid update (thesis §3.4 steps 3 to 5): grid velocities from the
//! scattered momentum, v_i = p_i / m_i, the forces and gravity,
//! v_i* = v_i + Δt (f_i / m_i + g), and the grid-based collisions with the
//! colliders (Quellcode 12). [`crate::reference::update_grid_velocities`]
//! is the plain form of this stage.

use glam::{IVec3, Vec3};
use rayon::prelude::*;

use crate::contact::Colliders;
use crate::grid::{Grid, GridLayout, Node};

/// Runs `visit` on the 64 nodes of every block with storage (the active
/// blocks of the last [`Grid::allocate`]), blocks in parallel.
pub(crate) fn for_each_active_block(grid: &mut Grid, visit: impl Fn(IVec3, &mut [Node]) + Sync) {
    grid.par_blocks_mut()
        .with_min_len(16)
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
