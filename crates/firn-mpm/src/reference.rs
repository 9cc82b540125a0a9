//! The plain reference solver: the explicit MPM step of Stomakhin et al. 2013
//! (thesis §3.4, Figure 5) as a researcher reads it, one particle and one
//! node at a time, on a dense grid, in straight-line scalar code, for both
//! transfer schemes. It is the yardstick of the fast solver: the tests in
//! `tests/reference.rs` run every fast stage ([`crate::p2g`],
//! [`crate::grid_update`], [`crate::g2p`]) and whole substeps against it on
//! random states.
//!
//! It shares only the physics that has one definition in firn: the B-spline
//! weights ([`firn_core::math::bspline`]), the scalar SVD
//! ([`firn_core::math::svd::svd3`]), the material constants and the contact
//! law ([`crate::contact::collide_all`]). Everything else (sparse blocks,
//! colouring, SIMD batches, the yield-surface fast path) is left out, so its
//! results differ from the fast solver's by round-off only: sums are taken
//! in another order, the exponential is `f32::exp`, and every particle goes
//! through the SVD.

use firn_core::math::bspline::{cubic_weights, quadratic_weights};
use firn_core::math::svd::svd3;
use firn_core::scene::Transfer;
use glam::{IVec3, Mat3, UVec3, Vec3};

use crate::contact::{PlacedCollider, collide_all};
use crate::grid::GridLayout;
use crate::grid_update::WindStep;
use crate::particles::Particles;
use crate::snow_model::MaterialConstants;
use crate::wind::relax;

/// What one explicit substep needs besides the particles and the grid.
#[derive(Clone, Copy, Debug)]
pub struct ReferenceStep<'a> {
    /// Substep Δt.
    pub dt: f32,
    /// Transfer scheme: PIC/FLIP with cubic B-splines or APIC with quadratic ones.
    pub transfer: Transfer,
    /// FLIP share α of the PIC/FLIP blend (step 8).
    pub flip: f32,
    /// Gravity g.
    pub gravity: Vec3,
    /// Constants of each material, indexed by a particle's material.
    pub materials: &'a [MaterialConstants],
    /// The colliders at the end of the substep, the domain walls included.
    pub colliders: &'a [PlacedCollider],
    /// The wind's drag and the time of the air's velocity, if any.
    pub wind: Option<WindStep<'a>>,
}

/// A dense grid over the same nodes as the fast solver's sparse one.
#[derive(Clone, Debug)]
pub struct ReferenceGrid {
    /// Where node (0, 0, 0) lies and the spacing h.
    pub layout: GridLayout,
    /// Nodes along each axis.
    pub dims: UVec3,
    /// m_i.
    pub mass: Vec<f32>,
    /// Σ_p m_p v_p w_ip (plus the APIC affine term) after step 1; v_i after step 4.
    pub velocity: Vec<Vec3>,
    /// f_i after step 3 (PIC/FLIP; zero for APIC); v_i^{n+1} after step 5.
    pub velocity_new: Vec<Vec3>,
}

impl ReferenceGrid {
    /// An empty grid with the nodes of `layout`.
    pub fn new(layout: GridLayout) -> ReferenceGrid {
        let dims = layout.node_dims();
        let count = (dims.x * dims.y * dims.z) as usize;
        ReferenceGrid {
            layout,
            dims,
            mass: vec![0.0; count],
            velocity: vec![Vec3::ZERO; count],
            velocity_new: vec![Vec3::ZERO; count],
        }
    }

    /// The array index of node `node`, x fastest.
    pub fn index(&self, node: IVec3) -> usize {
        let n = node.as_uvec3();
        assert!(n.cmplt(self.dims).all(), "node {node} outside the grid");
        (n.x + self.dims.x * (n.y + self.dims.y * n.z)) as usize
    }

    /// m_i of node `node`, 0 outside the grid.
    pub fn mass_at(&self, node: IVec3) -> f32 {
        let inside = node.cmpge(IVec3::ZERO).all() && node.as_uvec3().cmplt(self.dims).all();
        if inside {
            self.mass[self.index(node)]
        } else {
            0.0
        }
    }

    /// The grid coordinate of node `index`.
    pub fn node(&self, index: usize) -> IVec3 {
        let i = index as u32;
        let (dx, dy) = (self.dims.x, self.dims.y);
        IVec3::new(
            (i % dx) as i32,
            (i / dx % dy) as i32,
            (i / (dx * dy)) as i32,
        )
    }
}

/// One explicit substep: steps 1, 3-5 and 7-10 (step 2, the volumes, is
/// done once before the first substep by the caller; step 6 is the
/// semi-implicit solve, not part of the explicit step).
pub fn reference_step(particles: &mut Particles, grid: &mut ReferenceGrid, step: &ReferenceStep) {
    *grid = ReferenceGrid::new(grid.layout);
    particles_to_grid(particles, grid, step);
    update_grid_velocities(grid, step);
    grid_to_particles(particles, grid, step);
}

/// Steps 1 and 3: m_i = Σ_p m_p w_ip and the momentum Σ_p m_p v_p w_ip;
/// PIC/FLIP adds the force f_i = −Σ_p V_p^0 τ_p ∇w_ip (eq. 31-33) apart,
/// APIC the affine momentum and the force impulse into the momentum:
/// Σ_p w_ip (m_p C_p − Δt (4/h²) V_p^0 τ_p)(x_i − x_p).
/// `particles.stress` holds V_p^0 τ_p from the previous substep.
pub fn particles_to_grid(particles: &Particles, grid: &mut ReferenceGrid, step: &ReferenceStep) {
    let h = grid.layout.cell_size;
    for p in 0..particles.len() {
        let x = grid.layout.to_grid(particles.position[p]);
        let (m, v, stress) = (
            particles.mass[p],
            particles.velocity[p],
            particles.stress[p],
        );
        match step.transfer {
            Transfer::PicFlip => {
                let weights = cubic_weights(x);
                for (i, j, k) in stencil(4) {
                    let node = grid.index(weights.base + IVec3::new(i as i32, j as i32, k as i32));
                    let w = weights.weight(i, j, k);
                    let grad_w = weights.gradient(i, j, k) / h;
                    grid.mass[node] += m * w;
                    grid.velocity[node] += m * v * w;
                    grid.velocity_new[node] -= stress * grad_w;
                }
            }
            Transfer::Apic => {
                let weights = quadratic_weights(x);
                let affine =
                    m * particles.velocity_gradient[p] - step.dt * (4.0 / (h * h)) * stress;
                for (i, j, k) in stencil(3) {
                    let node = grid.index(weights.base + IVec3::new(i as i32, j as i32, k as i32));
                    let w = weights.weight(i, j, k);
                    let to_node = weights.node_offset(i, j, k) * h;
                    grid.mass[node] += m * w;
                    grid.velocity[node] += w * (m * v + affine * to_node);
                }
            }
        }
    }
}

/// Steps 4 and 5: v_i = p_i / m_i, v_i* = v_i + Δt (f_i / m_i + g) (for
/// APIC the force is already in the momentum), the wind's drag (equation W3
/// of [`firn_core::scene::wind`]), then the grid collisions.
pub fn update_grid_velocities(grid: &mut ReferenceGrid, step: &ReferenceStep) {
    for node in 0..grid.mass.len() {
        let m = grid.mass[node];
        if m <= 0.0 {
            continue;
        }
        let v = grid.velocity[node] / m;
        let acceleration = match step.transfer {
            Transfer::PicFlip => grid.velocity_new[node] / m + step.gravity,
            Transfer::Apic => step.gravity,
        };
        let position = grid.layout.node_position(grid.node(node));
        let mut v_star = v + step.dt * acceleration;
        if let Some(wind) = step.wind {
            let air = wind.drag.wind_at(position, wind.time);
            let rate = wind
                .drag
                .rate(grid.node(node), m, v_star, air, |n| grid.mass_at(n));
            v_star = relax(v_star, air, rate, step.dt);
        }
        grid.velocity[node] = v;
        grid.velocity_new[node] = collide_all(step.colliders, position, v_star);
    }
}

/// Steps 7-10 for every particle: the new velocity and ∇v_p from the grid,
/// the snow model, the particle collisions at the predicted position, and
/// x_p += Δt v_p.
pub fn grid_to_particles(particles: &mut Particles, grid: &ReferenceGrid, step: &ReferenceStep) {
    for p in 0..particles.len() {
        let (velocity, gradient) = interpolate(particles, p, grid, step);
        particles.velocity_gradient[p] = gradient;
        let material = &step.materials[particles.material[p] as usize];
        let trial = (Mat3::IDENTITY + step.dt * gradient) * particles.elastic[p];
        let (elastic, plastic_j, tau) = snow_model(trial, particles.plastic_j[p], material);
        particles.elastic[p] = elastic;
        particles.plastic_j[p] = plastic_j;
        particles.stress[p] = particles.volume0[p] * tau;
        let predicted = particles.position[p] + step.dt * velocity;
        let velocity = collide_all(step.colliders, predicted, velocity);
        particles.velocity[p] = velocity;
        particles.position[p] += step.dt * velocity;
    }
}

/// Steps 7 and 8 for particle `p`: PIC/FLIP gives
/// v_p = (1 − α) Σ w_ip v_i^{n+1} + α (v_p + Σ w_ip (v_i^{n+1} − v_i)) and
/// ∇v_p = Σ v_i^{n+1} (∇w_ip)ᵀ; APIC gives v_p = Σ w_ip v_i^{n+1} and
/// ∇v_p = C_p = (4/h²) Σ w_ip v_i^{n+1} (x_i − x_p)ᵀ.
fn interpolate(
    particles: &Particles,
    p: usize,
    grid: &ReferenceGrid,
    step: &ReferenceStep,
) -> (Vec3, Mat3) {
    let h = grid.layout.cell_size;
    let x = grid.layout.to_grid(particles.position[p]);
    let mut velocity = Vec3::ZERO;
    let mut gradient = Mat3::ZERO;
    match step.transfer {
        Transfer::PicFlip => {
            let weights = cubic_weights(x);
            let mut change = Vec3::ZERO;
            for (i, j, k) in stencil(4) {
                let node = grid.index(weights.base + IVec3::new(i as i32, j as i32, k as i32));
                let w = weights.weight(i, j, k);
                let grad_w = weights.gradient(i, j, k) / h;
                let (v_old, v_new) = (grid.velocity[node], grid.velocity_new[node]);
                velocity += w * v_new;
                change += w * (v_new - v_old);
                gradient += outer(v_new, grad_w);
            }
            let flip = step.flip;
            velocity = (1.0 - flip) * velocity + flip * (particles.velocity[p] + change);
        }
        Transfer::Apic => {
            let weights = quadratic_weights(x);
            for (i, j, k) in stencil(3) {
                let node = grid.index(weights.base + IVec3::new(i as i32, j as i32, k as i32));
                let w = weights.weight(i, j, k);
                let v_new = grid.velocity_new[node];
                velocity += w * v_new;
                gradient += outer(w * v_new, weights.node_offset(i, j, k) * h);
            }
            gradient *= 4.0 / (h * h);
        }
    }
    (velocity, gradient)
}

/// The snow model for one particle (eq. 34-43): the trial F̂_E = U Σ Vᵀ has
/// its singular values clamped to [1 − θc, 1 + θs], the clamped part moves
/// into J_P, and the Kirchhoff stress of the fixed-corotated energy with
/// hardened Lamé parameters is τ = 2μ (F_E − R_E) F_Eᵀ + λ (J_E − 1) J_E I.
/// Returns the new F_E, J_P and τ.
pub fn snow_model(trial: Mat3, plastic_j: f32, material: &MaterialConstants) -> (Mat3, f32, Mat3) {
    let svd = svd3(trial);
    let clamped = svd.sigma.clamp(
        Vec3::splat(material.min_stretch),
        Vec3::splat(material.max_stretch),
    );
    let elastic = svd.u * Mat3::from_diagonal(clamped) * svd.v.transpose();
    let plastic_j = plastic_j * svd.sigma.element_product() / clamped.element_product();
    let rotation = svd.u * svd.v.transpose();
    let elastic_j = clamped.element_product();
    let hardening = (material.hardening * (1.0 - plastic_j)).exp();
    let (mu, lambda) = (material.mu0 * hardening, material.lambda0 * hardening);
    let tau = 2.0 * mu * (elastic - rotation) * elastic.transpose()
        + Mat3::from_diagonal(Vec3::splat(lambda * (elastic_j - 1.0) * elastic_j));
    (elastic, plastic_j, tau)
}

/// The nodes (i, j, k) of an `n`-wide stencil.
fn stencil(n: usize) -> impl Iterator<Item = (usize, usize, usize)> {
    (0..n).flat_map(move |i| (0..n).flat_map(move |j| (0..n).map(move |k| (i, j, k))))
}

/// a bᵀ.
fn outer(a: Vec3, b: Vec3) -> Mat3 {
    Mat3::from_cols(a * b.x, a * b.y, a * b.z)
}
