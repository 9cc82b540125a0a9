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
    /// node's share of a packed cell, and 1 − φ_up the exposure of
    /// [`AirDrag::exposure`] against ρ_packed h³. `mass_at` gives the mass of
    /// any node (0 where the grid holds none).
    pub fn rate(
        &self,
        node: IVec3,
        mass: f32,
        velocity: Vec3,
        wind: Vec3,
        mass_at: impl Fn(IVec3) -> f32,
    ) -> f32 {
        if self.node_drag == 0.0 {
            return 0.0;
        }
        match self.exposure(node, wind - velocity, self.packed_mass, mass_at) {
            Some(exposure) => self.node_drag * exposure / mass.max(self.packed_mass),
            None => 0.0,
        }
    }

    /// The exposure 1 − φ_up of node `node` to the relative wind `relative`
    /// (equation W2), in [0, 1]: φ_up is the share min(1, m / `full_mass`)
    /// of the nodes upwind, one node against each axis component u_a of the
    /// relative wind, weighted by |u_a| / |u|₁. The drag measures shares
    /// against a packed cell, ρ_packed h³; spindrift against the node's own
    /// mass. `None` in still air (u = 0). `mass_at` gives the mass of any
    /// node.
    pub fn exposure(
        &self,
        node: IVec3,
        relative: Vec3,
        full_mass: f32,
        mass_at: impl Fn(IVec3) -> f32,
    ) -> Option<f32> {
        let weights = relative.abs();
        let total = weights.x + weights.y + weights.z;
        if total <= 0.0 {
            return None;
        }
        let mut upwind = 0.0;
        for axis in 0..3 {
            if weights[axis] > 0.0 {
                let mut step = IVec3::ZERO;
                step[axis] = if relative[axis] > 0.0 { -1 } else { 1 };
                upwind += weights[axis] * (mass_at(node + step) / full_mass).min(1.0);
            }
        }
        Some((1.0 - upwind / total).max(0.0))
    }

    /// ρ_packed h³: the mass of a packed cell (W2).
    pub fn packed_mass(&self) -> f32 {
        self.packed_mass
    }

    /// The air's field.
    pub fn field(&self) -> &FlowField {
        &self.field
    }

    /// The instruction set of the field's batches.
    pub fn simd(&self) -> Simd {
        self.simd
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
