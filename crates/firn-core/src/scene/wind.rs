//! Wind on snow (`[wind]` in a snow scene): the curl-noise field of the flow
//! scenes blowing over the MPM grid as an aerodynamic drag.
//!
//! The air moves with the divergence-free field v_w(x, t) of [`FlowSettings`]
//! (seed 002, eq. 1 to 4; the same keys as `[flow]`). Each grid node with
//! snow feels a linear drag (the grid update, thesis §3.4 step 4):
//!
//! ```text
//! f_i = c_d A_i (v_w(x_i, t) − v_i)                                   (W1)
//! A_i = h² φ_i (1 − φ_up),   φ = min(1, m / (ρ_packed h³))            (W2)
//! ```
//!
//! - c_d (`drag`, kg m⁻² s⁻¹) is the force per exposed area per unit of
//!   relative speed. Quadratic air drag ½ ρ_air C_D |u| u linearised at a
//!   relative speed U is c_d = ½ ρ_air C_D U: about 6 for air (1.2 kg/m³),
//!   a rough body (C_D ≈ 1) and a 10 m/s wind.
//! - φ is a node's share of a packed cell: its mass over the mass of a cell
//!   of snow at `packed_density`. A node presents φ_i of a cell face h² to
//!   the air, less what the snow upwind of it hides: φ_up is the share of
//!   the nodes one cell against the relative wind u = v_w − v_i (one per
//!   axis, weighted by |u_a| / |u|₁).
//! - Along a line of nodes through a packed body the exposed areas
//!   telescope, Σ φ_i (1 − φ_{i−1}) ≈ 1: the body feels the drag on its
//!   frontal area, whatever the grid spacing, and its lee side and inside
//!   are sheltered. Loose powder lighter than `packed_density` lets the air
//!   through (φ_up < 1 everywhere), so every node of it feels the wind: it
//!   is carried, at a rate c_d (1 − φ_up) / (ρ_packed h) that grows as the
//!   grid gets finer (the grid's cell is the scale of the powder's clumps).
//!
//! Over a substep the drag is integrated exactly for a node's own velocity
//! (the other forces are explicit): with the rate k_i = c_d A_i / m_i,
//!
//! ```text
//! v_i ← v_w + (v_i − v_w) exp(−k_i Δt)                                 (W3)
//! ```
//!
//! which is stable for any Δt and relaxes a node at rest in a uniform wind
//! towards the wind speed at the analytic rate of the drag law.

use serde::{Deserialize, Serialize};

use super::flow::FlowSettings;

/// Air moving over the snow and the drag it exerts on the grid
/// (equations W1 to W3 of this module).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Wind {
    /// The air's velocity field: the field keys of a flow scene (noise
    /// share, strength, length scale, background flow, speed scale, seed,
    /// offsets, evolution rate, curl, obstacles). Its integrator, substeps
    /// and emitters do not apply.
    pub field: FlowSettings,
    /// c_d: drag force per exposed area per m/s of relative speed,
    /// kg m⁻² s⁻¹ (equation W1).
    pub drag: f32,
    /// ρ_packed: the density, kg/m³, of snow that the air does not pass
    /// through (equation W2): a node holding this much snow per cell shelters
    /// the nodes downwind of it.
    pub packed_density: f32,
}

impl Wind {
    /// The default drag coefficient c_d, kg m⁻² s⁻¹: air (1.2 kg/m³) on a
    /// rough body (C_D ≈ 1) at about 10 m/s relative speed.
    pub const DEFAULT_DRAG: f32 = 6.0;

    /// The default ρ_packed, kg/m³: snow this dense (wind-packed snow, a
    /// snowball) lets no air through.
    pub const DEFAULT_PACKED_DENSITY: f32 = 400.0;

    /// A wind with the field `field` and the default drag and packed density.
    pub fn new(field: FlowSettings) -> Wind {
        Wind {
            field,
            drag: Wind::DEFAULT_DRAG,
            packed_density: Wind::DEFAULT_PACKED_DENSITY,
        }
    }

    /// A steady, uniform wind of `speed` m/s along the unit vector
    /// `direction` (no turbulence), with the default drag and packed density.
    pub fn uniform(direction: glam::Vec3, speed: f32) -> Wind {
        let mut field = FlowSettings::for_extent(1.0);
        field.noise_share = 0.0;
        field.background_direction = direction;
        field.background_strength = speed;
        Wind::new(field)
    }
}
