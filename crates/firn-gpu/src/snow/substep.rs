//! The substep recorder: the stages of one MPM substep in the order they
//! run, each from its own file, each kernel binding the buffers it uses of
//! [`StepBindings`](super::bindings::StepBindings) (`program.rs`):
//!
//! 1. `blocks.rs`: the sparse grid's block table, from the particles;
//! 2. `begin_step.rs`: Δt and the stop conditions;
//! 3. the grid's word planes cleared;
//! 4. `binning.rs` (binned scatter only): the counting sort;
//! 5. `p2g.rs`: the scatter, thesis steps 1 and 3;
//! 6. `grid_update.rs`: steps 4 and 5;
//! 7. `implicit.rs` (semi-implicit integrator only): step 6, the solve;
//! 8. `g2p.rs`: the gather, steps 7 to 10;
//! 9. `spindrift.rs` (`[wind.spindrift]` only): snow lifts, drift moves.
//!
//! [`Substep::run_batch`] records a batch of substeps in one submission and
//! reads back the step state, with the rigid bodies' sums in scenes with
//! bodies (whose batches are one substep: `super::coupling`). With the
//! semi-implicit integrator each
//! substep is submitted in parts instead: up to its solve, then a few
//! iterations at a time until the solve's state, read back in between,
//! says it has stopped, then the rest.

use bytemuck::Zeroable;
use firn_core::scene::Transfer;
use firn_mpm::implicit::{SolveReport, SolverStats};

use super::begin_step::BeginStep;
use super::binning::Binning;
use super::blocks::Blocks;
use super::buffers::SnowBuffers;
use super::coupling::SUM_WORDS;
use super::g2p::G2p;
use super::grid_update::GridUpdate;
use super::implicit::{ITERATIONS_PER_READ, ImplicitSolve, SolveGroups, read_header};
use super::layout::{Params, StepState};
use super::p2g::{BinnedP2g, P2g, Scatter, binned_fits};
use super::parts::PartKernels;
use super::program::{StepProgram, compute_pass};
use super::spindrift::SpindriftStage;
use super::stage_times::{STAGES, Stage, StageClock, mark};
use crate::buffers::{read_back, storage_buffer};
use crate::context::GpuContext;
use crate::dispatch::workgroups;
use crate::error::GpuError;

/// The binned scatter and the sort it runs on, built where the adapter's
/// workgroup memory allows.
struct Binned {
    binning: Binning,
    scatter: BinnedP2g,
}

/// The stages of a run's substep, its parameters, state and bind group.
pub struct Substep {
    params: wgpu::Buffer,
    state: wgpu::Buffer,
    blocks: Blocks,
    begin_step: BeginStep,
    binned: Option<Binned>,
    p2g: P2g,
    grid_update: GridUpdate,
    g2p: G2p,
    spindrift: SpindriftStage,
    /// The semi-implicit solve, with that integrator only.
    implicit: Option<ImplicitSolve>,
    /// The trade of sums between the parts of a split run.
    parts: PartKernels,
    /// Words of one block's traded sums (`parts.wgsl`).
    traded_block_words: u32,
    /// What the semi-implicit solves did so far.
    solver_stats: SolverStats,
    mode: Scatter,
    particle_groups: (u32, u32, u32),
    /// Whether the scene has rigid bodies, whose sums each substep clears.
    coupled: bool,
}

impl Substep {
    /// Builds the stages of `transfer`, with the wind's drag when `windy`,
    /// spindrift when `drifting` and the semi-implicit solve when
    /// `implicit`, and binds every buffer.
    pub fn new(
        context: &GpuContext,
        transfer: Transfer,
        (windy, drifting): (bool, bool),
        implicit: bool,
        params: &Params,
        state: &StepState,
        buffers: &SnowBuffers,
    ) -> Substep {
        let device = &context.device;
        let params_buffer = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("snow params"),
                contents: bytemuck::bytes_of(params),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            },
        );
        let state_buffer = storage_buffer(context, "snow step state", std::slice::from_ref(state));
        let program = StepProgram::new(
            device,
            buffers.bindings(&params_buffer, &state_buffer),
            !buffers.colliders.sequences.is_empty(),
        );
        let binned = binned_fits(&context.limits).then(|| Binned {
            binning: Binning::new(&program),
            scatter: BinnedP2g::new(&program, transfer),
        });
        let limit = context.limits.max_compute_workgroups_per_dimension;
        let coupled = buffers.bodies.count > 0;
        Substep {
            blocks: Blocks::new(&program, &buffers.blocks, limit),
            begin_step: BeginStep::new(&program),
            p2g: P2g::new(&program, transfer),
            mode: if binned.is_some() {
                Scatter::Binned
            } else {
                Scatter::Atomic
            },
            binned,
            grid_update: GridUpdate::new(&program, windy, implicit, coupled),
            g2p: G2p::new(&program, transfer),
            spindrift: SpindriftStage::new(&program, drifting),
            implicit: implicit.then(|| ImplicitSolve::new(&program)),
            parts: PartKernels::new(&program),
            traded_block_words: block_words_of(transfer),
            solver_stats: SolverStats::default(),
            particle_groups: workgroups(params.dims[3], limit),
            params: params_buffer,
            state: state_buffer,
            coupled,
        }
    }

    /// The scatter in use: binned where the adapter's workgroup memory
    /// allows, else atomic.
    pub fn scatter_mode(&self) -> Scatter {
        self.mode
    }

    /// Chooses the scatter; binned falls back to atomic where the adapter
    /// lacks the workgroup memory. Returns the scatter now in use.
    pub fn set_scatter_mode(&mut self, mode: Scatter) -> Scatter {
        self.mode = if self.binned.is_some() {
            mode
        } else {
            Scatter::Atomic
        };
        self.mode
    }

    /// Writes a frame's parameters and starting state.
    pub fn write_frame(&self, context: &GpuContext, params: &Params, state: &StepState) {
        context
            .queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(params));
        // Only the first four words: the maxima and trouble flags stay as
        // the last gather left them.
        let head = [
            state.dt.to_bits(),
            state.elapsed.to_bits(),
            state.running,
            state.steps,
        ];
        context
            .queue
            .write_buffer(&self.state, 0, bytemuck::cast_slice(&head));
    }

    /// The stages built again over `buffers` (after the grid grew), from
    /// `state` as it was read back, keeping the scatter in use and the
    /// solves' statistics; arguments as for [`Substep::new`].
    pub fn rebuild(
        &mut self,
        context: &GpuContext,
        (transfer, stages, implicit): (Transfer, (bool, bool), bool),
        params: &Params,
        state: &StepState,
        buffers: &SnowBuffers,
    ) {
        let mut rebuilt = Substep::new(context, transfer, stages, implicit, params, state, buffers);
        rebuilt.mode = self.mode;
        rebuilt.solver_stats = self.solver_stats;
        *self = rebuilt;
    }

    /// Lets a frame that waited for mesh frames (`StepState::waiting`) run
    /// on from `state`, as it was read back.
    pub fn resume(&self, context: &GpuContext, state: &StepState) {
        let head = [state.dt.to_bits(), state.elapsed.to_bits(), 1, state.steps];
        let queue = &context.queue;
        queue.write_buffer(&self.state, 0, bytemuck::cast_slice(&head));
        let waiting = std::mem::offset_of!(StepState, waiting) as u64;
        queue.write_buffer(&self.state, waiting, bytemuck::bytes_of(&0u32));
    }

    /// Sets the largest squared wave speed the next substep's Δt starts from
    /// (after the materials changed); the rest of the state stays.
    pub fn write_max_wave_speed(&self, context: &GpuContext, wave_speed_squared: f32) {
        let offset = std::mem::offset_of!(StepState, max_wave_bits) as u64;
        let bits = wave_speed_squared.to_bits();
        context
            .queue
            .write_buffer(&self.state, offset, bytemuck::bytes_of(&bits));
    }

    /// Sets the largest |v_p|² and squared wave speed the next substep's
    /// Δt starts from (a part of a split run: the maxima over all parts).
    pub fn write_motion_bounds(
        &self,
        context: &GpuContext,
        speed_squared: f32,
        wave_speed_squared: f32,
    ) {
        let offset = std::mem::offset_of!(StepState, max_speed_bits) as u64;
        let bits = [speed_squared.to_bits(), wave_speed_squared.to_bits()];
        context
            .queue
            .write_buffer(&self.state, offset, bytemuck::cast_slice(&bits));
    }

    /// Dispatches the particle kernels over `count` particles from now on.
    pub fn set_particle_count(&mut self, context: &GpuContext, count: u32) {
        let limit = context.limits.max_compute_workgroups_per_dimension;
        self.particle_groups = workgroups(count, limit);
    }

    /// Words of one block's sums in a trade between parts.
    pub fn traded_block_words(&self) -> u32 {
        self.traded_block_words
    }

    /// Runs the first half of a part's substep, up to and including the
    /// scatter, and reads the state back.
    pub fn run_part_scatter(
        &self,
        context: &GpuContext,
        buffers: &SnowBuffers,
    ) -> Result<StepState, GpuError> {
        let mut encoder = command_encoder(context);
        self.record_scatter(&mut encoder, buffers, None);
        context.queue.submit([encoder.finish()]);
        self.read_state(context)
    }

    /// Runs the second half of a part's substep, from the grid update on
    /// (the other parts' sums added), and reads the state back.
    pub fn finish_part_substep(
        &self,
        context: &GpuContext,
        buffers: &SnowBuffers,
    ) -> Result<StepState, GpuError> {
        let mut encoder = command_encoder(context);
        self.grid_update.record(
            &mut compute_pass(&mut encoder, "snow substep"),
            &buffers.blocks.indirect,
        );
        self.record_after_grid(&mut compute_pass(&mut encoder, "snow substep"));
        context.queue.submit([encoder.finish()]);
        self.read_state(context)
    }

    /// Packs the sums of the blocks in grid `slots` into the traded words
    /// (`words` `None`), or adds `words` (another part's sums of them)
    /// into the grid; at most the trade buffers' capacity of blocks.
    pub fn run_traded(
        &self,
        context: &GpuContext,
        buffers: &SnowBuffers,
        slots: &[u32],
        words: Option<&[u32]>,
    ) -> Result<(), GpuError> {
        assert!(
            slots.len() <= buffers.trade.capacity as usize,
            "a chunk within the trade buffers"
        );
        let mut list = Vec::with_capacity(slots.len() + 1);
        list.push(slots.len() as u32);
        list.extend_from_slice(slots);
        let queue = &context.queue;
        queue.write_buffer(&buffers.trade.slots, 0, bytemuck::cast_slice(&list));
        if let Some(words) = words {
            queue.write_buffer(&buffers.trade.words, 0, bytemuck::cast_slice(words));
        }
        let mut encoder = command_encoder(context);
        self.parts
            .record(context, &mut encoder, slots.len() as u32, words.is_some());
        queue.submit([encoder.finish()]);
        Ok(())
    }

    /// The step state as the GPU has it now.
    fn read_state(&self, context: &GpuContext) -> Result<StepState, GpuError> {
        let state = read_back::<StepState>(context, &[(&self.state, 1)])?;
        Ok(state[0].first().copied().unwrap_or_else(StepState::zeroed))
    }

    /// Writes the rigid bodies' fastest material speed, which bounds the
    /// next substep's Δt (`Params::stepping[3]`).
    pub fn write_body_speed(&self, context: &GpuContext, speed: f32) {
        let offset = (std::mem::offset_of!(Params, stepping) + 12) as u64;
        context
            .queue
            .write_buffer(&self.params, offset, bytemuck::bytes_of(&speed));
    }

    /// Records and runs `substeps` substeps over `buffers` (those after the
    /// frame's end do nothing), then reads the state back, with the rigid
    /// bodies' sums (`body_sums`' words, none without bodies: a batch with
    /// bodies is one substep).
    pub fn run_batch(
        &mut self,
        context: &GpuContext,
        substeps: u32,
        buffers: &SnowBuffers,
    ) -> Result<(StepState, Vec<u32>), GpuError> {
        match &self.implicit {
            Some(solve) => {
                for _ in 0..substeps {
                    let Some((report, active_nodes)) =
                        self.run_implicit_substep(context, solve, buffers)?
                    else {
                        break;
                    };
                    self.solver_stats.record(report, active_nodes);
                }
            }
            None => {
                let mut encoder = command_encoder(context);
                for _ in 0..substeps {
                    self.record(&mut encoder, buffers, None);
                }
                context.queue.submit([encoder.finish()]);
            }
        }
        let state_words = size_of::<StepState>() / 4;
        let bodies = &buffers.bodies;
        let mut wanted = vec![(&self.state, state_words)];
        if self.coupled {
            wanted.push((&bodies.sums, bodies.count * SUM_WORDS));
        }
        let mut words = read_back::<u32>(context, &wanted)?.into_iter();
        let state = words
            .next()
            .filter(|state| state.len() == state_words)
            .map(|state| bytemuck::pod_read_unaligned(bytemuck::cast_slice(&state)))
            .unwrap_or_else(StepState::zeroed);
        Ok((state, words.next().unwrap_or_default()))
    }

    /// What the semi-implicit solves did so far (with that integrator).
    pub fn solver_stats(&self) -> Option<SolverStats> {
        self.implicit.as_ref().map(|_| self.solver_stats)
    }

    /// Runs one substep with the semi-implicit solve, submitted in parts;
    /// returns how the solve went and the nodes with mass, or `None` when
    /// the frame had already ended (nothing ran).
    fn run_implicit_substep(
        &self,
        context: &GpuContext,
        solve: &ImplicitSolve,
        buffers: &SnowBuffers,
    ) -> Result<Option<(SolveReport, u64)>, GpuError> {
        let groups = SolveGroups {
            particles: self.particle_groups,
            nodes: &buffers.blocks.indirect,
        };
        let state = &buffers.solve.state;
        let mut encoder = command_encoder(context);
        self.record_until_solve(&mut encoder, buffers, None);
        solve.record_start(&mut encoder, state, groups);
        loop {
            {
                let mut pass = compute_pass(&mut encoder, "semi-implicit solve");
                solve.record_iterations(&mut pass, ITERATIONS_PER_READ, groups);
            }
            context.queue.submit([encoder.finish()]);
            let header = read_header(context, state)?;
            encoder = command_encoder(context);
            if header.solved == 0 {
                return Ok(None);
            }
            if header.running == 0 {
                let mut pass = compute_pass(&mut encoder, "snow substep");
                solve.record_store(&mut pass, &buffers.blocks.indirect);
                self.record_after_grid(&mut pass);
                drop(pass);
                context.queue.submit([encoder.finish()]);
                let report = SolveReport {
                    iterations: header.iterations,
                    residual: header.residual,
                    converged: header.converged != 0,
                };
                return Ok(Some((report, u64::from(header.active_nodes))));
            }
        }
    }

    /// Records the wind's drag in the grid update from now on when `windy`,
    /// and spindrift when `drifting`.
    pub fn set_windy(&mut self, (windy, drifting): (bool, bool)) {
        self.grid_update.set_windy(windy);
        self.spindrift.set_enabled(drifting);
    }

    /// Records one substep of the explicit integrator, stage by stage,
    /// each stage's end marked on `clock` when given.
    fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        buffers: &SnowBuffers,
        clock: Option<&StageClock>,
    ) {
        self.record_until_solve(encoder, buffers, clock);
        self.g2p
            .record(&mut compute_pass(encoder, "gather"), self.particle_groups);
        mark(clock, encoder, Stage::Gather);
        self.spindrift.record(
            &mut compute_pass(encoder, "spindrift"),
            self.particle_groups,
        );
        mark(clock, encoder, Stage::Spindrift);
    }

    /// Records a substep up to and including the grid update.
    fn record_until_solve(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        buffers: &SnowBuffers,
        clock: Option<&StageClock>,
    ) {
        self.record_scatter(encoder, buffers, clock);
        self.grid_update.record(
            &mut compute_pass(encoder, "snow substep"),
            &buffers.blocks.indirect,
        );
        mark(clock, encoder, Stage::GridUpdate);
    }

    /// Records a substep up to and including the scatter.
    fn record_scatter(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        buffers: &SnowBuffers,
        clock: Option<&StageClock>,
    ) {
        mark(clock, encoder, Stage::Start);
        if self.coupled {
            buffers.bodies.clear(encoder);
        }
        self.blocks
            .record(encoder, &buffers.blocks, self.particle_groups);
        mark(clock, encoder, Stage::Blocks);
        self.begin_step
            .record(&mut compute_pass(encoder, "snow substep"));
        mark(clock, encoder, Stage::BeginStep);
        buffers.grid.clear(encoder);
        mark(clock, encoder, Stage::Clear);
        match (&self.binned, self.mode) {
            (Some(binned), Scatter::Binned) => {
                let groups = self.particle_groups;
                let binning = &buffers.binning;
                binned.binning.record(encoder, binning, groups);
                mark(clock, encoder, Stage::Binning);
                let mut pass = compute_pass(encoder, "binned scatter");
                binned.scatter.record(&mut pass, &binning.indirect);
            }
            _ => {
                mark(clock, encoder, Stage::Binning);
                self.p2g.record(
                    &mut compute_pass(encoder, "snow substep"),
                    self.particle_groups,
                );
            }
        }
        mark(clock, encoder, Stage::Scatter);
    }

    /// Runs one substep of the explicit integrator with each stage's end
    /// marked on `clock`; returns the state and the stages' seconds.
    pub fn run_timed(
        &self,
        context: &GpuContext,
        buffers: &SnowBuffers,
        clock: &StageClock,
    ) -> Result<(StepState, [f64; STAGES]), GpuError> {
        let mut encoder = command_encoder(context);
        self.record(&mut encoder, buffers, Some(clock));
        clock.resolve(&mut encoder);
        context.queue.submit([encoder.finish()]);
        let seconds = clock.read(context)?;
        Ok((self.read_state(context)?, seconds))
    }

    /// Records the gather and spindrift, after the grid's new velocities.
    fn record_after_grid(&self, pass: &mut wgpu::ComputePass) {
        self.g2p.record(pass, self.particle_groups);
        self.spindrift.record(pass, self.particle_groups);
    }
}

fn command_encoder(context: &GpuContext) -> wgpu::CommandEncoder {
    context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("snow substeps"),
        })
}

/// Words of one block's sums in a trade between parts (`parts.wgsl`): a
/// low and a high word per node of each quantity the scatter sums, mass
/// and momentum, and for PIC/FLIP the force impulse.
fn block_words_of(transfer: Transfer) -> u32 {
    let quantities = match transfer {
        Transfer::Apic => 4,
        Transfer::PicFlip => 7,
    };
    quantities * 2 * 64
}

/// [`block_words_of`] the scene's transfer.
pub fn traded_block_words(scene: &firn_core::Scene) -> u32 {
    block_words_of(scene.solver.transfer)
}
