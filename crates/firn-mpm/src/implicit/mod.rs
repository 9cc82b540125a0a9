//! Step 6 of Stomakhin et al. 2013 (their eq. 9), which the thesis skipped
//! (§3.4, §7): the semi-implicit update of the grid velocities,
//!
//! ```text
//! (M + β Δt² H) v^{n+1} = M v*,
//! ```
//!
//! with M the lumped grid masses, v* the explicit velocities after grid forces,
//! gravity and collisions (steps 4 and 5), and H the Hessian of the elastic
//! energy Φ = Σ_p V_p^0 Ψ(F̂_Ep) (eq. 34) with respect to the grid node
//! positions x̂_i, where F̂_Ep = (I + Σ_i (x̂_i − x_i) (∇w_ip)ᵀ) F_Ep (eq. 32).
//! β = 0 is the explicit update, β = 1 linearised backward Euler.
//!
//! H is never assembled. Its product with a grid vector δv (eq. 33 differentiated)
//! is, per particle,
//!
//! ```text
//! δF_E = (Σ_i δv_i (∇w_ip)ᵀ) F_E,    A_p = V_p^0 δ(∂Ψ/∂F_E)(F_E; δF_E),
//! (H δv)_i = Σ_p A_p F_Eᵀ ∇w_ip,
//! ```
//!
//! with the hardened μ, λ of each particle (eq. 35) and the differential of the
//! polar rotation R_E from Stomakhin's technical report ([`StressDifferential`]).
//! The product scatters through the same block colouring as the transfers
//! ([`crate::binning`]), so it is deterministic for any thread count. What a
//! product needs per particle that does not change during a solve, its 1D
//! weights, stencil nodes, SVD and cof F_E, is computed once per substep
//! ([`ForceKernel::prepare`], [`StressDifferential::new`]; 176 bytes of
//! stencil per particle with the cubic kernel) and kept for every iteration;
//! the product does the same floating-point operations in the same order as
//! computing them afresh, so the results have the same bits.
//!
//! The system is symmetric but may be indefinite (the fixed-corotated energy is
//! not convex under compression), so it is solved, as in the paper, by
//! conjugate residuals, starting from v* and preconditioned by M⁻¹. (A Jacobi
//! preconditioner with the small-strain stiffness on the diagonal needed about
//! a quarter more iterations on the stiff snowball of
//! `scenes/bench/snowball-wall-stiff-implicit.toml`.) Grid nodes in contact
//! keep the velocity components their collider fixed: every residual and
//! search direction is projected onto the free components ([`Constraint`]),
//! so the solve works on P (M + β Δt² H) P. Velocities are f32 like the grid;
//! dot products sum in f64, block by block in a fixed order.

mod hessian;
mod node_vectors;
mod stress_differential;
#[cfg(test)]
mod tests;

use hessian::HessianOperator;
pub use hessian::{CubicGradient, ForceKernel, MlsGradient, PreparedStencil, PreparedStencils};
use node_vectors::NodeVectors;
pub use stress_differential::StressDifferential;

use firn_core::Scene;
use firn_core::scene::{ImplicitSettings, Integrator, TimeStep, Transfer};
use rayon::prelude::*;

use crate::binning::Bins;
use crate::contact::{PlacedCollider, collide_all};
use crate::grid::{Grid, GridLayout};
use crate::particles::Particles;
use crate::snow_model::MaterialConstants;
use node_vectors::blocks;

/// How one substep's solve ended.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveReport {
    /// Conjugate-residual iterations (products with H besides the first).
    pub iterations: u32,
    /// Final relative residual ‖r‖ / max(‖M v*‖, ‖r_0‖) in the M⁻¹ norm,
    /// r_0 the residual of v* (see [`ImplicitSolver::solve`]).
    pub residual: f32,
    /// Whether the residual reached the tolerance.
    pub converged: bool,
}

/// What the semi-implicit solves did so far (since the simulation started or
/// was restored from a snapshot).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolverStats {
    /// Substeps solved.
    pub steps: u64,
    /// Conjugate-residual iterations over all substeps.
    pub total_iterations: u64,
    /// Most iterations one substep took.
    pub max_iterations: u32,
    /// Iterations of the last substep.
    pub last_iterations: u32,
    /// Final relative residual of the last substep (see [`SolveReport::residual`]).
    pub last_residual: f32,
    /// Largest final relative residual of any substep.
    pub worst_residual: f32,
    /// Substeps that stopped at the iteration limit, or broke down, before
    /// reaching the tolerance; their velocities are the last iterate.
    pub unconverged_steps: u64,
    /// Σ over substeps of (iterations + 1) × the nodes with mass: how many
    /// node-rows of H v the solves computed (the first product is the
    /// initial residual's), for the cost per product and node.
    pub node_products: u64,
}

impl SolverStats {
    /// Mean iterations per solved substep (0 before the first).
    pub fn mean_iterations(&self) -> f64 {
        if self.steps == 0 {
            0.0
        } else {
            self.total_iterations as f64 / self.steps as f64
        }
    }

    /// The cost of the solves' products with H per node-row, from the
    /// seconds they took (e.g. the implicit phase of a profile).
    pub fn seconds_per_node_product(&self, seconds: f64) -> Option<f64> {
        (self.node_products > 0).then(|| seconds / self.node_products as f64)
    }

    /// Adds one substep's solve, on `active_nodes` nodes with mass (both
    /// backends keep their statistics with it).
    pub fn record(&mut self, report: SolveReport, active_nodes: u64) {
        self.node_products += (u64::from(report.iterations) + 1) * active_nodes;
        self.steps += 1;
        self.total_iterations += u64::from(report.iterations);
        self.max_iterations = self.max_iterations.max(report.iterations);
        self.last_iterations = report.iterations;
        self.last_residual = report.residual;
        self.worst_residual = self.worst_residual.max(report.residual);
        self.unconverged_steps += u64::from(!report.converged);
    }
}

/// What one semi-implicit solve needs besides the grid and the particles.
#[derive(Clone, Copy)]
pub struct ImplicitStep<'a> {
    /// Substep Δt.
    pub dt: f32,
    /// β, tolerance and iteration limit.
    pub settings: ImplicitSettings,
    /// The transfer scheme, which decides the weight gradients.
    pub transfer: Transfer,
    /// Materials by index (for the hardened μ and λ, eq. 35).
    pub materials: &'a [MaterialConstants],
    /// Colliders at the end of the step, walls included.
    pub colliders: &'a [PlacedCollider],
}

/// The semi-implicit velocity update (step 6); keeps its buffers between
/// substeps and accumulates [`SolverStats`].
#[derive(Clone, Debug, Default)]
pub struct ImplicitSolver {
    linearized: Vec<StressDifferential>,
    stencils: PreparedStencils,
    nodes: NodeVectors,
    stats: SolverStats,
}

impl ImplicitSolver {
    /// Solves (M + β Δt² H) v^{n+1} = M v* on the active nodes of `grid`,
    /// whose `velocity_new` holds v* before collisions (steps 4 and 5 without
    /// colliders); collisions are applied here, and again to the result so that
    /// no node ends up moving into a collider. Leaves v^{n+1} in `velocity_new`.
    pub fn solve(
        &mut self,
        grid: &mut Grid,
        bins: &Bins,
        particles: &Particles,
        step: &ImplicitStep,
    ) -> SolveReport {
        let active_nodes = grid.nodes.iter().filter(|node| node.mass() > 0.0).count();
        let report = match step.transfer {
            Transfer::PicFlip => self.solve_with(CubicGradient, grid, bins, particles, step),
            Transfer::Apic => self.solve_with(MlsGradient, grid, bins, particles, step),
        };
        self.stats.record(report, active_nodes as u64);
        report
    }

    /// Statistics of every solve so far.
    pub fn stats(&self) -> SolverStats {
        self.stats
    }

    fn solve_with<K: ForceKernel>(
        &mut self,
        kernel: K,
        grid: &mut Grid,
        bins: &Bins,
        particles: &Particles,
        step: &ImplicitStep,
    ) -> SolveReport {
        self.linearize(particles, step.materials);
        let table = grid.page_table();
        let stencils = K::buffer(&mut self.stencils);
        particles
            .position
            .par_iter()
            .with_min_len(512)
            .map(|&position| kernel.prepare(table, position))
            .collect_into_vec(stencils);
        self.nodes.reset(grid.nodes.len());
        let operator = HessianOperator {
            kernel,
            cell_size: table.layout.cell_size,
            bins,
            stencils,
            linearized: &self.linearized,
            scale: step.settings.beta * step.dt * step.dt,
        };
        let momentum = self.nodes.load(grid, step.colliders);
        let report = conjugate_residual(&operator, &mut self.nodes, momentum, &step.settings);
        self.store(grid, step.colliders);
        report
    }

    /// One [`StressDifferential`] per particle, with hardened μ and λ.
    fn linearize(&mut self, particles: &Particles, materials: &[MaterialConstants]) {
        (
            particles.elastic.par_iter(),
            particles.plastic_j.par_iter(),
            particles.volume0.par_iter(),
            particles.material.par_iter(),
        )
            .into_par_iter()
            .with_min_len(512)
            .map(|(&elastic, &plastic_j, &volume0, &material)| {
                let constants = &materials[material as usize];
                let factor = constants.hardening_factor(plastic_j);
                StressDifferential::new(
                    elastic,
                    constants.mu0 * factor,
                    constants.lambda0 * factor,
                    volume0,
                )
            })
            .collect_into_vec(&mut self.linearized);
    }

    /// Writes the solution into the grid's `velocity_new`, through the
    /// colliders once more.
    fn store(&self, grid: &mut Grid, colliders: &[PlacedCollider]) {
        let layout = grid.layout;
        grid.par_blocks_mut()
            .zip(blocks(&self.nodes.x))
            .for_each(|((coord, nodes), x)| {
                for (local, node) in nodes.iter_mut().enumerate() {
                    if node.mass() > 0.0 {
                        let position =
                            layout.node_position(GridLayout::node_in_block(coord, local));
                        node.set_velocity_new(collide_all(colliders, position, x[local].into()));
                    }
                }
            });
    }
}

/// Preconditioned conjugate residuals on P S P x = P M v* from x = v* (in
/// `nodes.x`), S = M + β Δt² H, preconditioned by M⁻¹. `momentum` is
/// ‖M v*‖²_{M⁻¹}.
///
/// Residuals are measured in the M⁻¹ norm: where S ≥ M, ‖r‖_{M⁻¹} bounds the
/// error of v^{n+1} in the kinetic-energy norm ‖e‖_M = (Σ m_i |e_i|²)^½. The
/// solve stops when ‖r‖_{M⁻¹} ≤ tolerance · max(‖M v*‖_{M⁻¹}, ‖r_0‖_{M⁻¹}),
/// r_0 = −β Δt² P H v* the correction the explicit step misses (larger than
/// the momentum in hard impacts); at the iteration limit; or if the
/// recurrence breaks down (z · S z = 0, possible as S may be indefinite).
fn conjugate_residual<K: ForceKernel>(
    operator: &HessianOperator<K>,
    nodes: &mut NodeVectors,
    momentum: f64,
    settings: &ImplicitSettings,
) -> SolveReport {
    operator.apply(&nodes.x, &mut nodes.product);
    let mut rz = nodes.initial_residual();
    let reference = rz.max(momentum);
    let relative = |rz: f64| {
        if reference > 0.0 {
            (rz / reference).sqrt() as f32
        } else {
            0.0
        }
    };
    let target = f64::from(settings.tolerance).powi(2) * reference;
    let mut report = SolveReport {
        iterations: 0,
        residual: relative(rz),
        converged: rz <= target,
    };
    if report.converged {
        return report;
    }
    operator.apply(&nodes.z, &mut nodes.product);
    let mut z_sz = nodes.finish_product();
    let mut denominator = nodes.next_direction(0.0);
    while report.iterations < settings.max_iterations {
        if !(z_sz.is_finite() && z_sz != 0.0 && denominator > 0.0 && denominator.is_finite()) {
            break;
        }
        rz = nodes.advance((z_sz / denominator) as f32);
        report.iterations += 1;
        report.residual = relative(rz);
        report.converged = rz <= target;
        if report.converged {
            break;
        }
        operator.apply(&nodes.z, &mut nodes.product);
        let next_z_sz = nodes.finish_product();
        denominator = nodes.next_direction((next_z_sz / z_sz) as f32);
        z_sz = next_z_sz;
    }
    report
}

/// What to change when a semi-implicit step of `scene` blew up, given the
/// run's solver statistics `stats`: the linear solve's limit if solves
/// stopped short, else the step (shared by the CPU and GPU backends).
pub fn blow_up_fix(scene: &Scene, stats: SolverStats) -> String {
    let step_fix = match scene.time.step {
        TimeStep::Fixed { dt } => {
            format!("in [time] set dt = {:.1e} (now {dt:.1e})", dt * 0.25)
        }
        TimeStep::Adaptive { cfl, max_dt } => format!(
            "in [time] set cfl = {:.2} (now {cfl}) or dt = {:.1e} (now {max_dt:.1e})",
            cfl * 0.5,
            max_dt * 0.5
        ),
    };
    match scene.solver.integrator {
        Integrator::SemiImplicit(settings) if stats.unconverged_steps > 0 => format!(
            "{} of {} linear solves stopped at solver_max_iterations = {} (last residual \
             {:.1e}, tolerance {:.0e}); in [solver] raise solver_max_iterations, or {step_fix}",
            stats.unconverged_steps,
            stats.steps,
            settings.max_iterations,
            stats.last_residual,
            settings.tolerance
        ),
        _ => step_fix,
    }
}
