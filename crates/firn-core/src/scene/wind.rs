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
//!
//! ## Spindrift (`[wind.spindrift]`)
//!
//! Where the wind over the snow surface is strong enough, loose snow leaves
//! the snow body and is carried by the air as drift particles
//! ([`Spindrift`]; the solver is `firn_mpm::spindrift`). At the end of each
//! substep a snow particle p with relative wind u_p = v_w(x_p, t) − v_p
//! detaches when
//!
//! ```text
//! ρ_p = ρ₀ / J_p < ρ_loose,   |u_p| > u_t,   e_p > 0                   (S1)
//! ξ_p < 1 − exp(−r e_p Δt)                                             (S2)
//! ```
//!
//! with ρ₀ the material's density and J_p = det F_E J_P the particle's
//! volume ratio (so ρ_p is m_p / (V_p⁰ J_p) with the material's V_p⁰ =
//! m_p / ρ₀, not step 2's grid estimate, which halves at a surface and
//! would make every surface look loose), and e_p the exposure of the grid
//! node i nearest x_p: the larger of its
//! exposures 1 − φ_up of equation W2 against the relative wind u_p and from
//! above (against gravity), with the shares φ of the upwind nodes measured
//! against half the node's own mass, ½ m_i, instead of a packed cell (the
//! node masses inside snow differ by the sampling's noise). So e_p is 0
//! inside snow of any density and in the lee of it, and 1 on a face the
//! wind meets and on open snow under the sky: only the surface lifts. r is
//! the detachment rate of a fully exposed loose particle per second, and
//! ξ_p ∈ [0, 1) a hash of the particle's own state (the bits of its
//! position) and the substep index: the same particle in the same state
//! draws the same number whatever the thread count or the particles'
//! order.
//!
//! A drift particle keeps its mass and moves with the air plus the fall
//! speed w_s of snow grains along gravity ĝ:
//!
//! ```text
//! dx/dt = v_w(x, t) + w_s ĝ                                            (S3)
//! ```
//!
//! integrated with the flow's Runge-Kutta step for v_w (the same field and
//! integrator as a flow scene's particles) and a forward step for w_s ĝ.
//! A step that would take it into a collider or through a floor (a domain
//! wall that gravity points into) lands it at its last point above: with
//! `settle`, it becomes snow again there (at rest, undeformed, its density
//! that at detachment); without, it rests there as drift. A step through
//! any other wall carries it out of the domain: its mass is counted as
//! escaped. Snow mass + drift mass + escaped mass is the scene's mass,
//! exactly (each particle's m_p moves unchanged between the three).

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
    /// Loose snow blown off the surface as drift particles (equations S1
    /// to S3); `None`: the snow stays snow.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spindrift: Option<Spindrift>,
}

/// Spindrift: where loose snow at the surface detaches into the wind and
/// how the drift moves and lands (equations S1 to S3 of this module).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Spindrift {
    /// u_t: the relative wind speed |v_w − v_p|, m/s, above which surface
    /// snow can lift (S1).
    pub threshold_speed: f32,
    /// ρ_loose: only snow lighter than this, kg/m³, lifts (S1).
    pub loose_density: f32,
    /// r: detachments per second of a fully exposed loose particle in a wind
    /// above the threshold (S2); it bounds the work per substep.
    pub rate: f32,
    /// w_s: the speed, m/s, at which drift falls through the air along
    /// gravity (S3).
    pub fall_speed: f32,
    /// Whether drift that lands becomes snow again (else it rests as drift).
    pub settle: bool,
}

impl Spindrift {
    /// The default threshold u_t, m/s: fresh snow starts to drift in winds
    /// of about 5 m/s.
    pub const DEFAULT_THRESHOLD_SPEED: f32 = 5.0;
    /// The default ρ_loose, kg/m³: fresh and settled powder lifts,
    /// wind-packed snow does not.
    pub const DEFAULT_LOOSE_DENSITY: f32 = 250.0;
    /// The default rate r, per second.
    pub const DEFAULT_RATE: f32 = 2.0;
    /// The default fall speed w_s, m/s, of snow grains in still air.
    pub const DEFAULT_FALL_SPEED: f32 = 0.5;
}

impl Default for Spindrift {
    /// The defaults of the scene format: lifts above 5 m/s below
    /// 250 kg/m³ at 2 per second, falls at 0.5 m/s and settles.
    fn default() -> Spindrift {
        Spindrift {
            threshold_speed: Spindrift::DEFAULT_THRESHOLD_SPEED,
            loose_density: Spindrift::DEFAULT_LOOSE_DENSITY,
            rate: Spindrift::DEFAULT_RATE,
            fall_speed: Spindrift::DEFAULT_FALL_SPEED,
            settle: true,
        }
    }
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
            spindrift: None,
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
