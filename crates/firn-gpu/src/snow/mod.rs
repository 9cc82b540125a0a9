//! The MPM substep on the GPU (thesis §3.4, with the explicit or the
//! semi-implicit integrator), the same step as `firn_mpm::Simulation`,
//! which is its reference.
//!
//! Each stage is a pair of files with one stem, a Rust file that makes its
//! pipelines and records its dispatches and a WGSL file under
//! `shaders/snow/` with its kernels, as `firn_mpm` has one file per stage.
//! Per substep, with no host round trip (`substep.rs` records them in
//! order):
//!
//! 0. `blocks`: the sparse grid's block table, every block a particle's
//!    stencil reaches given a slot in block-index order;
//! 1. `begin_step` (one invocation): Δt = CFL h / (max |v_p| + max c_p)
//!    from the maxima the last gather reduced, clipped to the frame's end;
//!    stops the frame when it is done or a particle was in trouble, and the
//!    batch when a deforming collider needs the bands of its next mesh
//!    frames (`sequences.rs`), which the host then uploads, or when the
//!    grid has no room for the blocks, which the host then grows;
//! 2. the grid's word planes are cleared;
//! 3. `binning`: the counting sort of the particles by block, for the
//!    binned scatter;
//! 4. `p2g`: particle to grid (thesis steps 1 and 3), atomic or binned,
//!    into 64-bit fixed-point sums ([`fixed_point`]);
//! 5. `grid_update`: v_i = p_i / m_i, forces, gravity, the wind's drag
//!    ([`wind`], `[wind]` scenes) and grid collisions (steps 4 and 5),
//!    then the rigid bodies' push (`[[rigid_bodies]]` scenes), summed per
//!    body in 64-bit fixed point (`coupling.rs`);
//! 6. `implicit` (semi-implicit integrator): the solve of step 6,
//!    (M + β Δt² H) v^{n+1} = M v* by conjugate residuals, which applies
//!    the grid collisions itself;
//! 7. `g2p`: grid to particle, the snow model (SVD, plastic clamp,
//!    hardened stress), particle collisions and advection (steps 7 to 10),
//!    with the maxima for the next Δt reduced per workgroup, then by atomics;
//! 8. `spindrift` (`[wind.spindrift]` scenes): loose surface snow lifts
//!    into the wind, the drift moves, lands and escapes; the particles keep
//!    one buffer, each with a phase (snow, drift, escaped) that the stages
//!    above read to skip all but the snow.
//!
//! The physics the stages share is WGSL in `shaders/common/` (B-spline
//! weights, SVD, snow model, colliders, stress differential); the bindings
//! are named once in
//! [`bindings`], the structs in `shaders/snow/layout.wgsl` and `layout.rs`.
//!
//! The host records batches of substeps, sized from the last Δt to just
//! reach the frame's end, and reads back one 52-byte state per batch (with
//! the semi-implicit integrator, also the solve's state every few
//! iterations: `implicit.rs`). With rigid bodies a batch is one substep:
//! the host places the bodies before it and reads their sums back with the
//! state after it, and rapier, on the CPU, steps them by its Δt
//! (`coupling.rs`). The
//! particles come back only when a frame is written ([`GpuSnow::snapshot`]).
//! One part of a run split between processes with a GPU each (MPI ranks)
//! steps one substep at a time and trades grid sums with the others
//! between its scatter and its grid update ([`parts`]).
//! The grid is sparse: its nodes are stored by 4³-node block, only for the
//! blocks the particles reach, so GPU memory follows the snow, not the
//! domain; the fixed-point sums make the results independent of where a
//! block is stored. [`MemoryEstimate`] says what a scene needs before
//! anything is allocated.

mod begin_step;
pub mod bindings;
mod binning;
mod blocks;
mod buffers;
mod coupling;
mod failures;
pub mod fixed_point;
mod g2p;
mod grid_update;
mod implicit;
mod layout;
mod memory;
mod p2g;
pub mod parts;
mod program;
mod sequences;
mod spindrift;
pub mod stage_times;
mod substep;
mod wind;

use std::sync::Arc;

use firn_core::Scene;
use firn_core::scene::{
    ColliderGeometry, Integrator, Material, SceneKind, TimeStep, Transfer, Wind,
};
use firn_mpm::coupling::RigidBodies;
use firn_mpm::grid::GridLayout;
use firn_mpm::implicit::SolverStats;
use firn_mpm::snow_model::{MaterialConstants, max_wave_speed_squared};
use firn_mpm::{Escaped, SimulationError, Snapshot};
use glam::{Mat3, Vec3};

use crate::buffers::{read_back, storage_buffer};
use crate::context::GpuContext;
use crate::draw::{ParticleArrays, SnowArrays, StridedArray};
use crate::error::GpuError;
use binning::BinningBuffers;
use blocks::{BlockBuffers, reached_blocks};
use buffers::{GridBuffers, ParticleBuffers, SnowBuffers, SolveBuffers, TradeBuffers};
use coupling::{BodyBuffers, Coupling, body_colliders};
use fixed_point::Scales;
use layout::{
    GpuMat3, GpuMaterial, GpuPlastic, NO_PARTICLE, Params, StepState, WAITING_FOR_GRID_BLOCKS,
};
use memory::body_blocks;
use spindrift::{PHASE_SNOW, ReadBack, SpindriftParams, joined, split_phases};
use substep::{Substep, traded_block_words};
use wind::{MAX_WIND_OBSTACLES, WindBuffers};

pub use buffers::ColliderBuffers;
pub use memory::MemoryEstimate;
pub use p2g::Scatter;

/// How far (in cells) a particle may stray outside the domain before the
/// run stops, as on the CPU.
const LEAVE_TOLERANCE_CELLS: f32 = 1.0;

/// Most substeps recorded in one submission.
const MAX_BATCH: u32 = 64;

/// A running snow simulation on the GPU.
pub struct GpuSnow {
    context: Arc<GpuContext>,
    scene: Scene,
    scales: Scales,
    params: Params,
    /// Materials (rewritten by [`GpuSnow::set_materials`]), colliders,
    /// particles, grid and the binning's buffers.
    buffers: SnowBuffers,
    substep: Substep,
    /// Particles in the buffers, snow, drift and escaped together.
    particle_count: usize,
    /// The drift that had escaped when the run came to the GPU.
    escaped_before: Escaped,
    time: f64,
    steps: u64,
    /// Where the frame being stepped ends, s.
    frame_end: f64,
    /// The last Δt and the maxima it came from, read back per batch.
    last: StepState,
    /// What the buffers were sized for, the grid's capacity included.
    memory: MemoryEstimate,
    /// The scene's rigid bodies, if it has any.
    coupling: Option<Coupling>,
}

impl GpuSnow {
    /// Fills the scene's bodies with particles and estimates their volumes
    /// exactly as the CPU solver does, then moves them to the GPU.
    pub fn new(context: Arc<GpuContext>, scene: Scene) -> Result<GpuSnow, GpuError> {
        GpuSnow::check_supported(&scene)?;
        let initial = Snapshot::initial(&scene)?;
        GpuSnow::from_snapshot(context, scene, &initial)
    }

    /// Continues a run from a snapshot (of the CPU or the GPU backend),
    /// checked against the scene as the CPU checks it ([`Snapshot::check`]).
    pub fn from_snapshot(
        context: Arc<GpuContext>,
        scene: Scene,
        snapshot: &Snapshot,
    ) -> Result<GpuSnow, GpuError> {
        GpuSnow::build(context, scene, snapshot, 0)
    }

    /// One part of a run split between processes, of the particles in
    /// `snapshot` ([`parts`]): it steps by [`GpuSnow::part_substep`].
    pub fn part_from_snapshot(
        context: Arc<GpuContext>,
        scene: Scene,
        snapshot: &Snapshot,
    ) -> Result<GpuSnow, GpuError> {
        GpuSnow::check_splittable(&scene)?;
        GpuSnow::build(context, scene, snapshot, parts::TRADE_CHUNK_BLOCKS)
    }

    /// A run of `snapshot` whose trade of sums between parts moves up to
    /// `trade_blocks` blocks at once (0 in one process).
    fn build(
        context: Arc<GpuContext>,
        scene: Scene,
        snapshot: &Snapshot,
        trade_blocks: u32,
    ) -> Result<GpuSnow, GpuError> {
        GpuSnow::check_supported(&scene)?;
        snapshot.check(&scene)?;
        let (particles, material_words) = joined(&snapshot.particles, &snapshot.drift);
        let domain = &scene.domain;
        let layout = GridLayout::new(domain.min, domain.max, domain.cell_size);
        let cubic = scene.solver.transfer == Transfer::PicFlip;
        let blocks =
            reached_blocks(&layout, &particles.position, cubic).max(body_blocks(&scene, &layout));
        let estimate =
            MemoryEstimate::for_blocks(&scene, capacity_of(particles.len(), trade_blocks), blocks);
        estimate.check_fits(&context)?;
        let constants = MaterialConstants::of_each(&scene.materials);
        let materials = storage_buffer(
            &context,
            "materials",
            &gpu_materials(&constants, &scene.materials),
        );
        let scales = Scales::of(&scene);
        let mut params = run_params(&scene, &layout, &scales, particles.len());
        params.flags[1] = context.limits.max_compute_workgroups_per_dimension;
        params.flags[3] = estimate.grid_blocks() as u32;
        let implicit = is_implicit(&scene);
        let all_colliders = firn_mpm::contact::ColliderSet::new(domain, &scene.colliders);
        let (colliders, body_shapes) = ColliderBuffers::with_bodies(
            &context,
            all_colliders.colliders(),
            &body_colliders(&scene),
        );
        let rigid = rigid_bodies(&scene, snapshot)?;
        let body_count = rigid.as_ref().map_or(0, |_| body_shapes.len());
        let buffers = SnowBuffers {
            materials,
            colliders,
            particles: ParticleBuffers::upload(
                &context,
                &particles,
                &material_words,
                estimate.particles as usize,
            ),
            blocks: BlockBuffers::new(&context, estimate.domain_blocks),
            grid: GridBuffers::new(&context, estimate.nodes, scene.solver.transfer, implicit),
            binning: BinningBuffers::new(&context, estimate.particles, estimate.grid_blocks()),
            wind: WindBuffers::upload(&context, &scene),
            spindrift: spindrift::params_buffer(&context, &scene),
            solve: SolveBuffers::new(&context, estimate.particles, estimate.nodes, implicit),
            trade: TradeBuffers::new(&context, trade_blocks, traded_block_words(&scene)),
            bodies: BodyBuffers::new(&context, body_count),
        };
        let state = StepState {
            max_speed_bits: snapshot.max_speed_squared.to_bits(),
            max_wave_bits: snapshot.max_wave_speed_squared.to_bits(),
            non_finite: NO_PARTICLE,
            left_domain: NO_PARTICLE,
            ..StepState::default()
        };
        let substep = Substep::new(
            &context,
            scene.solver.transfer,
            stages_of(&scene),
            implicit,
            &params,
            &state,
            &buffers,
        );
        Ok(GpuSnow {
            context,
            scales,
            params,
            buffers,
            substep,
            particle_count: particles.len(),
            escaped_before: snapshot.escaped,
            time: snapshot.time,
            steps: snapshot.steps,
            frame_end: snapshot.time,
            last: StepState {
                speed_squared: snapshot.max_speed_squared,
                wave_speed_squared: snapshot.max_wave_speed_squared,
                ..state
            },
            memory: estimate,
            coupling: rigid.map(|rigid| Coupling::new(rigid, body_shapes)),
            scene,
        })
    }

    /// `Ok` when the GPU backend runs this scene; otherwise what it lacks
    /// (`--backend auto` then stays on the CPU).
    pub fn check_supported(scene: &Scene) -> Result<(), GpuError> {
        if !matches!(scene.kind, SceneKind::Snow) {
            return Err(GpuError::Unsupported {
                what: "this is a flow scene, not a snow scene".into(),
                fix: "run it through firn_gpu::GpuFlow".into(),
            });
        }
        if let Some(wind) = &scene.wind
            && wind.field.obstacles.len() > MAX_WIND_OBSTACLES
        {
            return Err(GpuError::Unsupported {
                what: format!(
                    "the wind flows around {} spheres; the GPU backend takes at most \
                     {MAX_WIND_OBSTACLES}",
                    wind.field.obstacles.len()
                ),
                fix: "run with --backend cpu, or keep at most 8 [[wind.obstacles]]".into(),
            });
        }
        Ok(())
    }

    /// Advances to simulated time `until`; returns the substeps taken.
    pub fn advance_to(&mut self, until: f64) -> Result<u32, GpuError> {
        if until - self.time <= 1e-9 {
            return Ok(0);
        }
        self.begin_frame(until);
        let mut taken = 0;
        loop {
            let batch = match self.coupling.is_some() {
                true => self.place_bodies(),
                false => self.batch_size(until),
            };
            let (state, body_sums) = self
                .substep
                .run_batch(&self.context, batch, &self.buffers)?;
            let before = self.last;
            self.last = state;
            let batch_steps = state.steps - before.steps;
            taken += batch_steps;
            self.steps += u64::from(batch_steps);
            self.check_trouble(&state)?;
            self.time = f64::from(self.params.lower[3]) + f64::from(state.elapsed);
            if batch_steps > 0
                && let Some(coupling) = self.coupling.as_mut()
            {
                coupling.advance(&body_sums, state.dt, &self.scene.colliders, self.time);
            }
            self.check_step_length(&state)?;
            if self.serve_wait(&state)? {
                continue;
            }
            if state.running == 0 {
                self.time = until;
                return Ok(taken);
            }
        }
    }

    /// Before a substep of a scene with rigid bodies: writes the bodies
    /// where rapier has them and their fastest material speed, which
    /// bounds the substep's Δt; returns the size of the batch to record,
    /// one substep, since the next substep meets the bodies where this one
    /// leaves them.
    fn place_bodies(&mut self) -> u32 {
        if let Some(coupling) = &self.coupling {
            coupling.place(&self.context, &self.buffers.bodies);
            self.params.stepping[3] = coupling.max_speed();
            self.substep
                .write_body_speed(&self.context, self.params.stepping[3]);
        }
        1
    }

    /// The rigid bodies' fastest material speed, m/s (0 without bodies).
    fn body_speed(&self) -> f32 {
        self.coupling.as_ref().map_or(0.0, Coupling::max_speed)
    }

    /// The scene's rigid bodies, rapier's world on the CPU, if it has any.
    pub fn rigid_bodies(&self) -> Option<&RigidBodies> {
        self.coupling.as_ref().map(Coupling::rigid)
    }

    /// Starts a frame: the time window goes into the parameters, the step
    /// counter and the running flag into the state.
    fn begin_frame(&mut self, until: f64) {
        self.frame_end = until;
        self.params.lower[3] = self.time as f32;
        self.params.upper[3] = (until - self.time) as f32;
        self.last.elapsed = 0.0;
        self.last.steps = 0;
        self.last.running = 1;
        self.substep
            .write_frame(&self.context, &self.params, &self.last);
        let spindrift = SpindriftParams::of(&self.scene, self.steps);
        self.context
            .queue
            .write_buffer(&self.buffers.spindrift, 0, bytemuck::bytes_of(&spindrift));
    }

    /// When `begin_step` stopped the substeps to wait (`state.waiting`):
    /// grows the grid or uploads the mesh frames wanted, so that the frame
    /// runs on; returns whether it waited.
    fn serve_wait(&mut self, state: &StepState) -> Result<bool, GpuError> {
        match state.waiting {
            0 => return Ok(false),
            WAITING_FOR_GRID_BLOCKS => self.resize_grid(u64::from(state.grid_blocks))?,
            _ => self.resume_with_mesh_frames(state)?,
        }
        Ok(true)
    }

    /// After `begin_step` stopped a batch to wait for mesh frames: uploads
    /// the ones the deforming colliders' poses ask for and lets the frame
    /// run on from `state`.
    fn resume_with_mesh_frames(&mut self, state: &StepState) -> Result<(), GpuError> {
        if !self
            .buffers
            .colliders
            .load_wanted_mesh_frames(&self.context)?
        {
            return Err(GpuError::Device(
                "the substeps waited for mesh frames that were already uploaded".into(),
            ));
        }
        self.last.running = 1;
        self.last.waiting = 0;
        self.substep.resume(&self.context, state);
        Ok(())
    }

    /// Sizes the grid for `blocks` blocks and half as many again
    /// ([`MemoryEstimate::for_blocks`]), between substeps, and lets the frame run on:
    /// the substep that found too little room (`StepState::waiting`) had
    /// not begun, so it runs now on the new grid. A run grows its grid this
    /// way whenever the snow reaches more blocks than it has room for;
    /// sized below that, it grows again at the next substep. Fails, with
    /// nothing changed, when a buffer would pass the adapter's limits.
    pub fn resize_grid(&mut self, blocks: u64) -> Result<(), GpuError> {
        let particles = self.particle_count as u64;
        let estimate = MemoryEstimate::for_blocks(&self.scene, particles, blocks);
        estimate.check_fits(&self.context)?;
        let context = &self.context;
        let transfer = self.scene.solver.transfer;
        let implicit = is_implicit(&self.scene);
        let buffers = &mut self.buffers;
        buffers.grid = GridBuffers::new(context, estimate.nodes, transfer, implicit);
        buffers.binning = BinningBuffers::new(context, particles, estimate.grid_blocks());
        buffers.solve = SolveBuffers::new(context, particles, estimate.nodes, implicit);
        self.params.flags[3] = estimate.grid_blocks() as u32;
        self.memory = estimate;
        self.last.running = u32::from(self.last.waiting != 0 || self.last.running != 0);
        self.last.waiting = 0;
        let stages = (transfer, stages_of(&self.scene), implicit);
        self.substep
            .rebuild(context, stages, &self.params, &self.last, &self.buffers);
        Ok(())
    }

    /// What the run's GPU buffers were sized for: the particles and the
    /// grid's capacity, which grows with the snow ([`GpuSnow::resize_grid`]).
    pub fn memory(&self) -> MemoryEstimate {
        self.memory
    }

    /// Substeps to record next: enough to reach the frame's end, or the
    /// next mesh frame of a deforming collider (where the batch waits for
    /// its band), at the last Δt.
    fn batch_size(&self, until: f64) -> u32 {
        let dt = match self.scene.time.step {
            TimeStep::Fixed { dt } => dt,
            TimeStep::Adaptive { .. } if self.last.dt > 0.0 => self.last.dt,
            TimeStep::Adaptive { max_dt, .. } => max_dt,
        };
        let remaining = until.min(self.next_mesh_frame()) - self.time;
        ((remaining / f64::from(dt)).ceil() as u32 + 1).clamp(1, MAX_BATCH)
    }

    /// The time of the first mesh frame of a deforming collider after now
    /// (infinite when none comes).
    fn next_mesh_frame(&self) -> f64 {
        self.scene
            .colliders
            .iter()
            .filter_map(|collider| match &collider.geometry {
                ColliderGeometry::MeshSequence(sequence) => {
                    let passed = ((self.time - sequence.start) * sequence.frame_rate).floor();
                    let next = (passed + 1.0).max(0.0);
                    (next < f64::from(sequence.frame_count))
                        .then(|| sequence.time_of(next as usize))
                }
                _ => None,
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The semi-implicit solves' statistics since this run came to the GPU
    /// (with that integrator only), as `firn_mpm::Simulation::solver_stats`.
    pub fn solver_stats(&self) -> Option<SolverStats> {
        self.substep.solver_stats()
    }

    /// Reads the particles back, split by phase into the snow, the drift
    /// and the escaped tally: the state to write a frame from or to continue
    /// from, on either backend.
    pub fn snapshot(&self) -> Result<Snapshot, GpuError> {
        let n = self.particle_count;
        let b = &self.buffers.particles;
        let vectors = read_back::<[f32; 4]>(
            &self.context,
            &[(&b.position_mass, n), (&b.velocity_volume, n)],
        )?;
        let matrices = read_back::<GpuMat3>(
            &self.context,
            &[(&b.elastic, n), (&b.affine, n), (&b.stress, n)],
        )?;
        let plastic = read_back::<GpuPlastic>(&self.context, &[(&b.plastic, n)])?.remove(0);
        let xyz = |v: &[f32; 4]| Vec3::new(v[0], v[1], v[2]);
        let to_mat3 = |list: &Vec<GpuMat3>| list.iter().map(|&m| Mat3::from(m)).collect::<Vec<_>>();
        let all = ReadBack {
            position: vectors[0].iter().map(xyz).collect(),
            velocity: vectors[1].iter().map(xyz).collect(),
            mass: vectors[0].iter().map(|v| v[3]).collect(),
            volume: vectors[1].iter().map(|v| v[3]).collect(),
            elastic: to_mat3(&matrices[0]),
            affine: to_mat3(&matrices[1]),
            stress: to_mat3(&matrices[2]),
            plastic_j: plastic.iter().map(|p| p.plastic_j).collect(),
            material_word: plastic.iter().map(|p| p.material).collect(),
        };
        let (particles, drift, escaped) = split_phases(all, self.escaped_before);
        Ok(Snapshot {
            time: self.time,
            steps: self.steps,
            max_speed_squared: f32::from_bits(self.last.max_speed_bits),
            max_wave_speed_squared: f32::from_bits(self.last.max_wave_bits),
            particles,
            drift,
            escaped,
            rigid: self.rigid_bodies().map(RigidBodies::to_bytes),
        })
    }

    /// Replaces the scene's materials between [`GpuSnow::advance_to`] calls
    /// (an interactive viewer's parameter panel), from the next substep on:
    /// the snow model's constants and the elastic wave speed the next
    /// adaptive Δt starts from, as `firn_mpm::Simulation::set_materials`
    /// does, with the same checks ([`firn_mpm::live::scene_with_materials`];
    /// the density cannot change, so the fixed-point scales stay). The
    /// particles keep their state.
    pub fn set_materials(&mut self, materials: &[Material]) -> Result<(), GpuError> {
        let scene = firn_mpm::live::scene_with_materials(&self.scene, materials)?;
        let constants = MaterialConstants::of_each(&scene.materials);
        let wave_speed_squared = self.max_wave_speed_squared(&constants)?;
        let gpu = gpu_materials(&constants, &scene.materials);
        let queue = &self.context.queue;
        queue.write_buffer(&self.buffers.materials, 0, bytemuck::cast_slice(&gpu));
        self.substep
            .write_max_wave_speed(&self.context, wave_speed_squared);
        self.last.max_wave_bits = wave_speed_squared.to_bits();
        self.scene = scene;
        Ok(())
    }

    /// Replaces the scene's wind, from the next substep on; a scene without
    /// one gets it. Refused, with nothing changed, where the scene loader
    /// ([`firn_mpm::live::scene_with_wind`]) or the GPU backend
    /// ([`GpuSnow::check_supported`]) would refuse it.
    pub fn set_wind(&mut self, wind: &Wind) -> Result<(), GpuError> {
        let scene = firn_mpm::live::scene_with_wind(&self.scene, wind)?;
        GpuSnow::check_supported(&scene)?;
        self.buffers.wind.write(&self.context, &scene);
        self.substep.set_windy(stages_of(&scene));
        self.scene = scene;
        Ok(())
    }

    /// The largest squared wave speed of the snow particles as they are, for
    /// materials of `constants` (their J_P and materials read back).
    fn max_wave_speed_squared(&self, constants: &[MaterialConstants]) -> Result<f32, GpuError> {
        let buffers = [(&self.buffers.particles.plastic, self.particle_count)];
        let mut plastic = read_back::<GpuPlastic>(&self.context, &buffers)?.remove(0);
        plastic.retain(|p| p.material >> 16 == PHASE_SNOW);
        let material: Vec<u16> = plastic.iter().map(|p| p.material as u16).collect();
        let plastic_j: Vec<f32> = plastic.iter().map(|p| p.plastic_j).collect();
        Ok(max_wave_speed_squared(constants, &material, &plastic_j))
    }

    /// The particle arrays in the GPU buffers the substeps use, for a
    /// renderer on the same device (no copy): positions and masses share
    /// one `vec4` per particle, velocities and initial volumes another.
    /// They hold the state of the last [`GpuSnow::advance_to`] until the
    /// next one. With spindrift they hold the drift and the escaped drift
    /// too, in no particular place ([`GpuSnow::snapshot`] splits them).
    pub fn particle_arrays(&self) -> ParticleArrays<'_> {
        let array = |buffer, stride, offset| StridedArray {
            buffer,
            stride,
            offset,
        };
        let vec4 = words::<[f32; 4]>();
        let plastic_j = (std::mem::offset_of!(GpuPlastic, plastic_j) / 4) as u32;
        let particles = &self.buffers.particles;
        ParticleArrays {
            count: self.particle_count as u32,
            positions: array(&particles.position_mass, vec4, 0),
            velocities: array(&particles.velocity_volume, vec4, 0),
            snow: Some(SnowArrays {
                mass: array(&particles.position_mass, vec4, 3),
                volume0: array(&particles.velocity_volume, vec4, 3),
                elastic: array(&particles.elastic, words::<GpuMat3>(), 0),
                plastic_j: array(&particles.plastic, words::<GpuPlastic>(), plastic_j),
            }),
            trails: None,
        }
    }

    /// The scatter in use ([`Scatter::Binned`] by default where the
    /// adapter's workgroup memory allows it).
    pub fn scatter(&self) -> Scatter {
        self.substep.scatter_mode()
    }

    /// Chooses the scatter (for comparing them; both give the same sums,
    /// bit for bit); returns the one now in use.
    pub fn set_scatter(&mut self, scatter: Scatter) -> Scatter {
        self.substep.set_scatter_mode(scatter)
    }

    /// The scene being simulated.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Simulated time in seconds.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The device this runs on.
    pub fn context(&self) -> &Arc<GpuContext> {
        &self.context
    }
}

/// The materials' constants as the kernels read them, with their densities.
fn gpu_materials(constants: &[MaterialConstants], materials: &[Material]) -> Vec<GpuMaterial> {
    constants
        .iter()
        .zip(materials)
        .map(|(constants, material)| GpuMaterial {
            density: material.density,
            ..GpuMaterial::from(constants)
        })
        .collect()
}

/// The rigid bodies of `scene` as `snapshot` saved them, or at their start
/// when it saved none (as `firn_mpm::Simulation::from_snapshot`); `None`
/// without bodies.
fn rigid_bodies(scene: &Scene, snapshot: &Snapshot) -> Result<Option<RigidBodies>, GpuError> {
    let rigid = match &snapshot.rigid {
        Some(bytes) => Some(RigidBodies::from_bytes(scene, bytes).map_err(SimulationError::from)?),
        None => RigidBodies::new(scene).map_err(SimulationError::from)?,
    };
    Ok(rigid)
}

/// Whether `scene` runs the semi-implicit integrator.
fn is_implicit(scene: &Scene) -> bool {
    matches!(scene.solver.integrator, Integrator::SemiImplicit(_))
}

/// Which optional stages `scene` needs: the wind's drag, and spindrift.
fn stages_of(scene: &Scene) -> (bool, bool) {
    (scene.wind.is_some(), scene.spindrift().is_some())
}

/// 32-bit words in a `T`: the stride of an array of `T` in a renderer's terms.
fn words<T>() -> u32 {
    (size_of::<T>() / 4) as u32
}

/// Room for particles in a run of `particles`: as many in one process
/// (`trade_blocks` 0), a quarter more in a part of a split run, which
/// takes in particles at frames' ends ([`GpuSnow::replace_particles`]).
fn capacity_of(particles: usize, trade_blocks: u32) -> u64 {
    let particles = particles as u64;
    match trade_blocks {
        0 => particles,
        _ => particles + particles / 4 + 256,
    }
}

/// `Params` of a run: grid, stepping, scales; the frame window is set per frame.
fn run_params(scene: &Scene, layout: &GridLayout, scales: &Scales, particles: usize) -> Params {
    let dims = layout.node_dims();
    let tolerance = Vec3::splat(LEAVE_TOLERANCE_CELLS * layout.cell_size);
    let (cfl, max_dt, fixed_dt) = match scene.time.step {
        TimeStep::Fixed { dt } => (0.0, dt, dt),
        TimeStep::Adaptive { cfl, max_dt } => (cfl, max_dt, 0.0),
    };
    Params {
        origin: layout.origin.extend(layout.cell_size).into(),
        dims: [dims.x, dims.y, dims.z, particles as u32],
        gravity: scene.solver.gravity.extend(scene.solver.flip_blend).into(),
        lower: (scene.domain.min - tolerance).extend(0.0).into(),
        upper: (scene.domain.max + tolerance).extend(0.0).into(),
        stepping: [cfl, max_dt, fixed_dt, 0.0],
        scales: [scales.mass, scales.momentum, 0.0, 0.0],
        flags: [
            u32::from(scene.solver.transfer == Transfer::PicFlip),
            0,
            u32::from(is_implicit(scene)),
            0,
        ],
        implicit: match scene.solver.integrator {
            Integrator::SemiImplicit(settings) => [
                settings.beta,
                settings.tolerance,
                settings.max_iterations as f32,
                0.0,
            ],
            Integrator::Explicit => [0.0; 4],
        },
    }
}
