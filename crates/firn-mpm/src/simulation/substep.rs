//! One substep, as the list of the thesis' stages (§3.4, Figure 5), each a
//! named call into the file of the same name:
//!
//! 1. bin the particles by grid block (binning.rs), sorting them every
//!    [`REORDER_INTERVAL`] substeps;
//! 2. scatter mass, momentum and force to the grid, which first gets
//!    storage for the blocks the particles reach (p2g.rs);
//! 3. update the grid velocities: forces, gravity, wind, the grid
//!    collisions and the rigid bodies' push (grid_update.rs, contact.rs,
//!    wind.rs, coupling.rs);
//! 4. the semi-implicit solve, with that integrator (implicit.rs);
//! 5. gather velocities back to the particles, with plasticity and stress
//!    (snow_model.rs), particle collisions and advection (g2p.rs);
//! 6. spindrift, with a wind that lifts snow (spindrift.rs);
//! 7. clear the grid for the next substep (grid_update.rs);
//! 8. step the rigid bodies with what the snow gave them (coupling.rs).
//!
//! A part of a run split between processes (MPI ranks, firn-mpi) takes the
//! same stages, trading block sums in the scatter ([`SumTrade`]).

use firn_core::scene::{Integrator, TimeStep, Transfer};
use glam::Vec3;

use super::{LEAVE_TOLERANCE_CELLS, REORDER_INTERVAL, Simulation, SimulationError};
use crate::block_sums::{ForeignBlocks, NodeOwners, SumTrade};
use crate::contact::{Colliders, PlacedCollider};
use crate::coupling::BodyContacts;
use crate::coupling::ImpulseSum;
use crate::g2p::{self, GatherStats, UpdateContext};
use crate::grid_update::{self, GridForces, GridImpulses, WindStep};
use crate::implicit::ImplicitStep;
use crate::p2g;
use crate::particles::Particles;
use crate::profile::PhaseClock;
use crate::spindrift::{self, SpindriftStep};

impl Simulation {
    /// Advances one substep, never past time `until`; returns the Δt taken.
    /// Refuses, with nothing changed, when the Δt would be so short that a
    /// frame took more than `time.max_substeps_per_frame` substeps. Every
    /// [`REORDER_INTERVAL`] substeps it first sorts the particles by block.
    pub fn step(&mut self, until: f64) -> Result<f32, SimulationError> {
        let dt = self.clipped_dt(until)?;
        let mut clock = PhaseClock::start();
        self.bin_particles();
        clock.lap(&mut self.profile.binning);
        self.substep(dt, clock, None, None)
    }

    /// [`Simulation::step`] for one part of a run split between processes
    /// (MPI ranks), which holds the particles of its blocks in any order
    /// and never reorders them (see the MPI section of
    /// docs/architecture.md). `keys` gives each particle's place in the
    /// whole run's order: every block adds its particles in key order, and
    /// a failure names the particle with the lowest key. The block sums
    /// that other parts read, and those this part reads, go through `trade`
    /// ([`crate::block_sums`]). Every part must take the same Δt: the
    /// caller reduces [`Simulation::motion_bounds`] over the parts and
    /// hands the result back with [`Simulation::set_motion_bounds`].
    pub fn step_part(
        &mut self,
        until: f64,
        keys: &[u64],
        trade: &mut dyn SumTrade,
    ) -> Result<f32, SimulationError> {
        assert_eq!(keys.len(), self.particles.len(), "one key per particle");
        let dt = self.clipped_dt(until)?;
        let mut clock = PhaseClock::start();
        self.bins
            .rebuild(&self.grid.layout, &self.particles.position);
        self.bins.order_blocks_by(keys);
        clock.lap(&mut self.profile.binning);
        self.substep(dt, clock, Some(trade), Some(keys))
    }

    /// The stages of a substep of length `dt` after the binning, `clock`
    /// timing each; in a part of a split run `trade` swaps block sums and
    /// `keys` name a failed particle. On a failure nothing of the substep
    /// is kept but the particles' state, and the error explains it.
    fn substep(
        &mut self,
        dt: f32,
        mut clock: PhaseClock,
        mut trade: Option<&mut dyn SumTrade>,
        keys: Option<&[u64]>,
    ) -> Result<f32, SimulationError> {
        let foreign = self.scatter(dt, reborrow(&mut trade));
        clock.lap(&mut self.profile.scatter);
        let placed = self.colliders.placed_at(self.time + f64::from(dt));
        let colliders = Colliders::new(&placed);
        clock.lap(&mut self.profile.colliders);
        let part = trade.as_ref().map(|trade| trade.part());
        let bodies = self.body_contacts(part, &foreign);
        clock.lap(&mut self.profile.rigid_bodies);
        let mut impulses = self.update_grid(dt, &colliders, &bodies);
        if let (Some(trade), Some(_)) = (reborrow(&mut trade), &self.rigid) {
            add_up_between_parts(&mut impulses.bodies, trade);
        }
        clock.lap(&mut self.profile.grid_update);
        self.solve_implicit(dt, &placed);
        clock.lap(&mut self.profile.implicit_solve);
        let stats = self.gather(dt, &colliders, keys);
        clock.lap(&mut self.profile.gather);
        if stats.problem.is_none() {
            self.blow_spindrift(&placed, dt);
        }
        grid_update::clear_grid(&mut self.grid);
        clock.lap(&mut self.profile.clear);
        if let Some(problem) = stats.problem {
            return Err(self.instability(problem, dt));
        }
        self.time += f64::from(dt);
        self.steps += 1;
        self.stats = stats;
        self.wind_impulse += impulses.wind;
        if let Some(rigid) = self.rigid.as_mut() {
            rigid.advance(&impulses.bodies, dt, &self.scene.colliders, self.time);
            clock.lap(&mut self.profile.rigid_bodies);
        }
        Ok(dt)
    }

    /// Stage 1: the particles binned by block, sorted by block in memory
    /// every [`REORDER_INTERVAL`] substeps.
    fn bin_particles(&mut self) {
        let layout = self.grid.layout;
        if self.steps.is_multiple_of(REORDER_INTERVAL) {
            self.bins.rebuild(&layout, &self.particles.position);
            self.particles
                .permute(self.bins.order(), &mut self.permute_buffers);
        }
        self.bins.rebuild(&layout, &self.particles.position);
    }

    /// The rigid bodies where they are now, as the grid update meets them;
    /// in part `part` of a split run counting the nodes that part owns
    /// ([`NodeOwners`]) after a scatter that received the sums of
    /// `foreign` blocks.
    fn body_contacts(&self, part: Option<usize>, foreign: &ForeignBlocks) -> BodyContacts {
        let Some(rigid) = self.rigid.as_ref() else {
            return BodyContacts::default();
        };
        let contacts = rigid.contacts();
        match part {
            Some(part) => {
                contacts.counted_by(NodeOwners::new(part, self.grid.layout, &self.bins, foreign))
            }
            None => contacts,
        }
    }

    /// Stage 2 (steps 1 and 3): the grid's storage for this substep, then
    /// mass, momentum and force (PIC/FLIP) or affine momentum with the
    /// force impulse (APIC) on it. Returns the blocks whose sums other
    /// parts sent.
    fn scatter(&mut self, dt: f32, trade: Option<&mut dyn SumTrade>) -> ForeignBlocks {
        let (grid, bins, particles) = (&mut self.grid, &self.bins, &self.particles);
        match self.scene.solver.transfer {
            Transfer::PicFlip => p2g::scatter_pic_flip(grid, bins, particles, self.simd, trade),
            Transfer::Apic => p2g::scatter_apic(grid, bins, particles, dt, self.simd, trade),
        }
    }

    /// Stage 3 (steps 4 and 5): grid velocities with forces, gravity and
    /// the wind's drag, then the grid collisions against `colliders`
    /// (placed at the end of the substep) and the rigid `bodies`, except
    /// with the semi-implicit integrator, whose solve applies the colliders
    /// itself to learn which velocity components they fix (the scene format
    /// refuses rigid bodies with it). Returns the wind's impulse on the snow
    /// and the bodies' exchanges with it.
    fn update_grid(
        &mut self,
        dt: f32,
        colliders: &Colliders,
        bodies: &BodyContacts,
    ) -> GridImpulses {
        let forces = match self.scene.solver.transfer {
            Transfer::PicFlip => GridForces::Separate,
            Transfer::Apic => GridForces::InMomentum,
        };
        let no_colliders = Colliders::new(&[]);
        let grid_colliders = match self.implicit {
            Some(_) => &no_colliders,
            None => colliders,
        };
        let wind = self.wind.as_ref().map(|drag| WindStep {
            drag,
            time: self.time + f64::from(dt),
        });
        grid_update::update_grid(
            &mut self.grid,
            forces,
            dt,
            self.scene.solver.gravity,
            grid_colliders,
            wind,
            bodies,
        )
    }

    /// Stage 4 (step 6): the semi-implicit velocity update, with that
    /// integrator only.
    fn solve_implicit(&mut self, dt: f32, colliders: &[PlacedCollider]) {
        let (Integrator::SemiImplicit(settings), Some(solver)) =
            (self.scene.solver.integrator, self.implicit.as_mut())
        else {
            return;
        };
        let step = ImplicitStep {
            dt,
            settings,
            transfer: self.scene.solver.transfer,
            materials: &self.materials,
            colliders,
        };
        solver.solve(&mut self.grid, &self.bins, &self.particles, &step);
    }

    /// Stage 5 (steps 7 to 10): velocities and ∇v_p from the grid, the
    /// deformation update with plasticity and stress, the particle
    /// collisions and the advection; the statistics the next Δt and the
    /// checks read.
    fn gather(&mut self, dt: f32, colliders: &Colliders, keys: Option<&[u64]>) -> GatherStats {
        let tolerance = Vec3::splat(LEAVE_TOLERANCE_CELLS * self.grid.layout.cell_size);
        let context = UpdateContext {
            dt,
            materials: &self.materials,
            colliders,
            lower: self.scene.domain.min - tolerance,
            upper: self.scene.domain.max + tolerance,
            keys,
        };
        let (grid, bins, particles) = (&self.grid, &self.bins, &mut self.particles);
        match self.scene.solver.transfer {
            Transfer::PicFlip => {
                let flip = self.scene.solver.flip_blend;
                g2p::gather_pic_flip(grid, bins, particles, flip, &context, self.simd)
            }
            Transfer::Apic => g2p::gather_apic(grid, bins, particles, &context, self.simd),
        }
    }

    /// Stage 6: spindrift at the end of a substep of length `dt`, while the
    /// grid still holds its node masses ([`crate::spindrift`]): the drift
    /// moves and lands, then loose surface snow lifts. `placed` are the
    /// colliders at the end of the substep, the scene's first.
    fn blow_spindrift(&mut self, placed: &[PlacedCollider], dt: f32) {
        let (Some(drag), Some(wind)) = (self.wind.as_ref(), self.scene.wind.as_ref()) else {
            return;
        };
        let Some(settings) = wind.spindrift.as_ref() else {
            return;
        };
        let step = SpindriftStep {
            settings,
            drag,
            colliders: &placed[..self.scene.colliders.len()],
            domain: &self.scene.domain,
            gravity: self.scene.solver.gravity,
            interval: (self.time, self.time + f64::from(dt)),
            substep: self.steps,
            seed: wind.field.seed,
            integrator: wind.field.integrator,
            material_densities: &self.material_densities,
        };
        let mut landed = Particles::default();
        spindrift::carry(&step, &mut self.drift, &mut self.escaped, &mut landed);
        spindrift::detach(&step, &self.grid, &mut self.particles, &mut self.drift);
        self.particles.append(landed);
    }

    /// The Δt the next substep will take (before clipping to a frame end):
    /// fixed, or Δt = CFL · h / (max |v_p| + max c_p) capped at the maximum,
    /// with c_p the elastic wave speed including hardening. The semi-implicit
    /// update is stable beyond the elastic wave limit, so with it only the
    /// particle speed bounds Δt: Δt = CFL · h / max |v_p|.
    pub fn next_dt(&self) -> f32 {
        match self.scene.time.step {
            TimeStep::Fixed { dt } => dt,
            TimeStep::Adaptive { cfl, max_dt } => {
                let wave_speed = match self.scene.solver.integrator {
                    Integrator::Explicit => self.stats.max_wave_speed_squared.sqrt(),
                    Integrator::SemiImplicit(_) => 0.0,
                };
                let speed = self.fastest_motion() + wave_speed;
                if speed > 0.0 {
                    (cfl * self.scene.domain.cell_size / speed).min(max_dt)
                } else {
                    max_dt
                }
            }
        }
    }

    /// The fastest particle's speed, or a rigid body's material if that is
    /// faster, m/s.
    fn fastest_motion(&self) -> f32 {
        let particles = self.stats.max_speed_squared.sqrt();
        match &self.rigid {
            Some(rigid) => particles.max(rigid.max_speed()),
            None => particles,
        }
    }

    /// The Δt of the next substep, never past time `until`, or the error
    /// of [`Simulation::check_step_length`].
    fn clipped_dt(&self, until: f64) -> Result<f32, SimulationError> {
        let next = self.next_dt();
        self.check_step_length(next)?;
        Ok((next as f64).min(until - self.time).max(0.0) as f32)
    }

    /// Substeps until time `until` is reached; returns the number of substeps.
    pub fn advance_to(&mut self, until: f64) -> Result<u32, SimulationError> {
        let mut substeps = 0;
        while until - self.time > 1e-9 {
            self.step(until)?;
            substeps += 1;
        }
        Ok(substeps)
    }
}

/// Adds each body's exchange up over the parts of a split run, so that
/// every part steps its bodies with the whole run's sums.
fn add_up_between_parts(sums: &mut [ImpulseSum], trade: &mut dyn SumTrade) {
    let mut words: Vec<u64> = sums
        .iter()
        .flat_map(|sum| sum.linear.into_iter().chain(sum.angular))
        .map(|word| word as u64)
        .collect();
    trade.add_up(&mut words);
    for (sum, words) in sums.iter_mut().zip(words.chunks_exact(6)) {
        for axis in 0..3 {
            sum.linear[axis] = words[axis] as i64;
            sum.angular[axis] = words[3 + axis] as i64;
        }
    }
}

/// The trade of a split run's part, borrowed for one stage.
fn reborrow<'a>(trade: &'a mut Option<&mut dyn SumTrade>) -> Option<&'a mut dyn SumTrade> {
    match trade {
        Some(trade) => Some(&mut **trade),
        None => None,
    }
}
