//! Wind on the grid (scene `[wind]`): the aerodynamic drag of a curl-noise
//! air flow on each node's snow, part of the grid update (thesis §3.4
//! step 4). The model and its equations W1 to W3 are in
//! [`firn_core::scene::wind`]; the air's velocity is the flow scenes' field
//! ([`firn_flow::FlowField`], seed 002 eq. 1 to 4), evaluated at the nodes in
//! SIMD batches that give the same bits on every instruction set.

use firn_core::math::exp::exp;
use firn_core::math::lanes::Simd;
use firn_core::scene::Wind;
use firn_flow::FlowField;
use glam::{IVec3, Vec3};

use crate::grid::{BLOCK_NODES, GridLayout};

/// The drag of a scene's wind on a grid of spacing h.
#[derive(Clone, Debug)]
pub struct AirDrag {
    field: FlowField,
    /// c_d h²: the drag of a node exposed over a whole cell face per m/s,
    /// kg/s (W1, W2).
    node_drag: f32,
    /// ρ_packed h³: the mass of a sheltered node (W2).
    packed_mass: f32,
    /// The instruction set of the field's batches (all give the same bits).
    simd: Simd,
}

impl AirDrag {
    /// The drag of `wind` on a grid of spacing `cell_size`.
    pub fn new(wind: &Wind, cell_size: f32) -> AirDrag {
        AirDrag {
            field: FlowField::new(&wind.field),
            node_drag: wind.drag * cell_size * cell_size,
            packed_mass: wind.packed_density * cell_size * cell_size * cell_size,
            simd: Simd::detect(),
        }
    }

    /// The same drag with the field evaluated in the lanes of `simd` (the
    /// same bits; for the tests and `firn bench --simd`).
    pub fn with_simd(mut self, simd: Simd) -> AirDrag {
        self.simd = simd;
        self
    }

    /// The air's velocity v_w(x, t) at one point (what [`AirDrag::block_wind`]
    /// gives at a node, bit for bit).
    pub fn wind_at(&self, position: Vec3, time: f64) -> Vec3 {
        self.field.velocity(position, time)
    }

    /// The air's velocity at the 64 nodes of `block` at time `time`, in the
    /// block's node order.
    pub fn block_wind(&self, layout: &GridLayout, block: IVec3, time: f64) -> [Vec3; BLOCK_NODES] {
        let positions: [Vec3; BLOCK_NODES] = std::array::from_fn(|local| {
            layout.node_position(GridLayout::node_in_block(block, local))
        });
        let mut wind = [Vec3::ZERO; BLOCK_NODES];
        self.field
            .velocities(self.simd, time, &positions, &mut wind);
        wind
    }

    /// The rate k_i = c_d A_i / m_i of equation W3 at node `node` of mass
    /// `mass` moving at `velocity` in air moving at `wind`, with
    /// A_i = h² φ_i (1 − φ_up) (W2): φ = min(1, m / (ρ_packed h³)) is the
    /// node's share of a packed cell, and φ_up the same share of the nodes
    /// upwind, one node against each axis component of the relative wind
    /// u = v_w − v, weighted by |u_a| / |u|₁. `mass_at` gives the mass of any
    /// node (0 where the grid holds none).
    pub fn rate(
        &self,
        node: IVec3,
        mass: f32,
        velocity: Vec3,
        wind: Vec3,
        mass_at: impl Fn(IVec3) -> f32,
    ) -> f32 {
        let relative = wind - velocity;
        let weights = relative.abs();
        let total = weights.x + weights.y + weights.z;
        if self.node_drag == 0.0 || total <= 0.0 {
            return 0.0;
        }
        let mut upwind = 0.0;
        for axis in 0..3 {
            if weights[axis] > 0.0 {
                let mut step = IVec3::ZERO;
                step[axis] = if relative[axis] > 0.0 { -1 } else { 1 };
                upwind += weights[axis] * self.share_of_packed(mass_at(node + step));
            }
        }
        let exposure = 1.0 - upwind / total;
        self.node_drag * exposure.max(0.0) / mass.max(self.packed_mass)
    }

    /// φ = min(1, m / (ρ_packed h³)): a node's share of a packed cell.
    fn share_of_packed(&self, mass: f32) -> f32 {
        (mass / self.packed_mass).min(1.0)
    }
}

/// Equation W3: a node moving at `velocity` after Δt of drag at `rate`
/// towards the air's velocity `wind`, v_w + (v − v_w) exp(−k Δt).
pub fn relax(velocity: Vec3, wind: Vec3, rate: f32, dt: f32) -> Vec3 {
    if rate == 0.0 {
        return velocity;
    }
    wind + (velocity - wind) * exp(-rate * dt)
}
