//! The curl-noise flow of seed 002 (after Bridson et al. 2007) on the GPU:
//! the same model as `firn_flow::FlowSimulation`, which is its reference.
//!
//! The field (`shaders/flow/field.wgsl`) is v = s · curl ψ' with
//! ψ = turbulence + background (seed eq. 1), modulated near sphere
//! obstacles (eq. 2-3), its curl exact or by central differences (eq. 4),
//! on simplex noise with the CPU's hash and gradients
//! (`shaders/flow/noise.wgsl`). These library files, and `random.wgsl` and
//! `emitters.wgsl`, have the stems of the `firn_flow` files they mirror. A
//! substep is one submission of up to three dispatches
//! ([`shaders::FLOW_STEP`](crate::shaders::FLOW_STEP)), made and recorded
//! by `step.rs`, whose kernels are in `shaders/flow/step.wgsl`:
//!
//! 1. `advance`: RK2 or RK4 through the field, the fading birth velocity,
//!    aging, rebirth of particles that expired or left the domain (birth
//!    places and lifetimes drawn on the GPU from the same 64-bit hashes as on
//!    the CPU), and pushing particles out of spheres;
//! 2. `settle_newborns`: the particles `rate` emitters add in the substep,
//!    which the host computes (births are a schedule, independent of the
//!    particles) and uploads, pushed out of spheres with their velocity;
//! 3. `record_trails`, at a frame's end: every position into its trail ring.
//!
//! Particle data stays on the GPU between substeps; only
//! [`GpuFlow::snapshot`] reads it back. Buffers are sized once for the run's
//! largest particle count (every emitter's slots). The bind groups are
//! named once, in [`bindings`]; [`FlowProbe`] (`probe.rs` and
//! `shaders/flow/probe.wgsl`) runs the library functions for the parity tests.

pub mod bindings;
mod buffers;
pub(crate) mod layout;
mod probe;
mod step;

pub use probe::FlowProbe;

use std::sync::Arc;

use firn_core::Scene;
use firn_core::scene::{FlowEmission, FlowSettings};
use firn_flow::{FlowParticles, FlowSnapshot, emitters};

use self::bindings::{FieldBindings, ParticleBindings, TrailBindings};
use self::buffers::{FieldBuffers, ParticleBuffers, TrailBuffers, TrailState};
use self::layout::{NoiseDomains, SubstepParams};
use self::step::{StepGroups, StepKernels};
use crate::context::GpuContext;
use crate::draw::{ParticleArrays, StridedArray, TrailArrays};
use crate::error::GpuError;

/// A running curl-noise particle flow on the GPU (seed 002).
pub struct GpuFlow {
    context: Arc<GpuContext>,
    scene: Scene,
    settings: FlowSettings,
    domains: NoiseDomains,
    kernels: StepKernels,
    /// The layout of group 0, to rebuild the field for new settings.
    field_layout: wgpu::BindGroupLayout,
    field: FieldBuffers,
    particles: ParticleBuffers,
    trails: Option<TrailBuffers>,
    /// Particle slots of each emitter over the whole run.
    slots: Vec<u64>,
    /// Particles born so far by each emitter.
    births: Vec<u64>,
    substeps: u64,
    /// Particles born so far (all alive).
    count: u32,
}

impl GpuFlow {
    /// Makes the particles of time 0 exactly as the CPU does
    /// ([`FlowSnapshot::initial`], trails included), then moves them to the
    /// GPU.
    pub fn new(context: Arc<GpuContext>, scene: Scene) -> Result<GpuFlow, GpuError> {
        GpuFlow::check_supported(&scene)?;
        let initial = FlowSnapshot::initial(&scene)?;
        GpuFlow::from_snapshot(context, scene, &initial)
    }

    /// Continues a run from a snapshot of either backend, checked against
    /// the scene as the CPU checks it ([`FlowSnapshot::check`]).
    pub fn from_snapshot(
        context: Arc<GpuContext>,
        scene: Scene,
        snapshot: &FlowSnapshot,
    ) -> Result<GpuFlow, GpuError> {
        GpuFlow::check_supported(&scene)?;
        snapshot.check(&scene)?;
        let settings = flow_settings(&scene)?.clone();
        let slots = run_slots(&scene, &settings);
        let capacity = particle_capacity(&slots, snapshot.positions.len())?;
        let field_layout = FieldBindings::TABLE.layout(&context.device);
        let particle_layout = ParticleBindings::TABLE.layout(&context.device);
        let trail_layout = TrailBindings::TABLE.layout(&context.device);
        let kernels = StepKernels::new(&context, &field_layout, &particle_layout, &trail_layout);
        let field = FieldBuffers::new(&context, &scene, &settings, &field_layout);
        let count = snapshot.positions.len() as u32;
        let (births, substeps) = (snapshot.births.clone(), snapshot.substeps);
        let (particles, trails) = split_snapshot(snapshot);
        let particles = ParticleBuffers::new(&context, &particle_layout, capacity, &particles)?;
        let trails = trails
            .map(|state| TrailBuffers::new(&context, &trail_layout, capacity, &state))
            .transpose()?;
        Ok(GpuFlow {
            domains: NoiseDomains::new(&settings),
            kernels,
            field_layout,
            births,
            context,
            scene,
            settings,
            field,
            particles,
            trails,
            slots,
            substeps,
            count,
        })
    }

    /// Replaces the field's parameters between [`GpuFlow::advance_to`] calls
    /// (an interactive viewer's parameter panel), from the next substep on, as
    /// `firn_flow::FlowSimulation::set_settings` does, with the same checks
    /// ([`firn_flow::scene_with_settings`]: the emitters and substeps cannot
    /// change). The field's buffers are built anew; particles inside a new
    /// or grown sphere are pushed out and every velocity is taken from the
    /// new field.
    pub fn set_settings(&mut self, settings: FlowSettings) -> Result<(), GpuError> {
        let scene = firn_flow::scene_with_settings(&self.scene, settings)?;
        let settings = flow_settings(&scene)?.clone();
        self.field = FieldBuffers::new(&self.context, &scene, &settings, &self.field_layout);
        self.domains = NoiseDomains::new(&settings);
        self.settings = settings;
        self.scene = scene;
        self.settle_all();
        Ok(())
    }

    /// Every particle pushed out of the spheres, with its velocity in the
    /// field at the current time (the newborns' kernel over all particles).
    fn settle_all(&self) {
        let t = self.time();
        let mut params = SubstepParams::new(&self.domains, t, t, self.count);
        params.newborn_first = 0;
        self.field.write_substep(&self.context, &params);
        self.run_pass("flow settle", |pass| {
            let groups = self.groups(None);
            let count = self.count;
            self.kernels
                .record_settle(&self.context, pass, &groups, count);
        });
    }

    /// Records one compute pass with `record` and submits it.
    fn run_pass(&self, label: &str, record: impl FnOnce(&mut wgpu::ComputePass)) {
        let context = &self.context;
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
        record(
            &mut encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: None,
            }),
        );
        context.queue.submit([encoder.finish()]);
    }

    /// The particle arrays in the GPU buffers the substeps use, for a
    /// renderer on the same device (no copy): packed x, y, z per particle,
    /// and the trail rings when the flow keeps trails. They hold the state
    /// of the last [`GpuFlow::advance_to`] until the next one.
    pub fn particle_arrays(&self) -> ParticleArrays<'_> {
        let xyz = |buffer| StridedArray {
            buffer,
            stride: 3,
            offset: 0,
        };
        ParticleArrays {
            count: self.count,
            positions: xyz(&self.particles.positions),
            velocities: xyz(&self.particles.velocities),
            snow: None,
            trails: self.trails.as_ref().map(|trails| TrailArrays {
                points: &trails.points,
                lengths: &trails.lengths,
                capacity: trails.capacity,
                head: trails.head,
                count: trails.count,
            }),
        }
    }

    /// `Ok` when the GPU backend runs this scene: every flow scene whose
    /// particle ids fit in 32 bits (every field, obstacle, emitter,
    /// integrator and trail setting is ported).
    pub fn check_supported(scene: &Scene) -> Result<(), GpuError> {
        let settings = flow_settings(scene)?;
        particle_capacity(&run_slots(scene, settings), 0).map(|_| ())
    }

    /// Advances by whole substeps up to time `until` (the last substep that
    /// does not end after it, as `FlowSimulation::advance_to`); returns the
    /// substeps taken, once the GPU has finished them.
    pub fn advance_to(&mut self, until: f64) -> Result<u32, GpuError> {
        let mut taken = 0;
        let tolerance = 1e-6 / self.steps_per_second();
        while (self.substeps + 1) as f64 / self.steps_per_second() <= until + tolerance {
            self.step();
            taken += 1;
        }
        self.context.wait()?;
        Ok(taken)
    }

    /// Reads the state back: to write a frame from (through
    /// [`FlowSnapshot::view`]) or to continue from, on either backend. Every
    /// particle has a trail ring, as on the CPU
    /// ([`FlowSnapshot::cover_trails`]).
    pub fn snapshot(&self) -> Result<FlowSnapshot, GpuError> {
        let particles = self.particles.read(&self.context, self.count as usize)?;
        let trails = match &self.trails {
            Some(trails) => trails.read(&self.context)?,
            None => TrailState {
                capacity: 0,
                head: 0,
                points: Vec::new(),
                lengths: Vec::new(),
                generations: Vec::new(),
            },
        };
        let mut snapshot = FlowSnapshot {
            substeps: self.substeps,
            births: self.births.clone(),
            positions: particles.positions,
            velocities: particles.velocities,
            ages: particles.ages,
            lifetimes: particles.lifetimes,
            generations: particles.generations,
            emitters: particles.emitters,
            trail_capacity: trails.capacity,
            trail_head: trails.head,
            trail_points: trails.points,
            trail_lengths: trails.lengths,
            trail_generations: trails.generations,
        };
        snapshot.cover_trails();
        Ok(snapshot)
    }

    /// Simulated time in seconds.
    pub fn time(&self) -> f64 {
        self.substeps as f64 / self.steps_per_second()
    }

    /// Number of particles born so far (all alive).
    pub fn len(&self) -> usize {
        self.count as usize
    }

    /// Whether no particle is born yet.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The scene being simulated.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Bytes of GPU buffers held: field, particles and trails.
    pub fn memory_bytes(&self) -> u64 {
        self.field.bytes()
            + self.particles.bytes()
            + self.trails.as_ref().map_or(0, TrailBuffers::bytes)
    }

    /// The device this runs on.
    pub fn context(&self) -> &Arc<GpuContext> {
        &self.context
    }

    fn steps_per_second(&self) -> f64 {
        self.scene.time.fps * f64::from(self.settings.substeps)
    }

    /// One substep: its parameters and newborns uploaded, then one
    /// submission of its dispatches (no read back).
    fn step(&mut self) {
        let sps = self.steps_per_second();
        let t0 = self.substeps as f64 / sps;
        let t1 = (self.substeps + 1) as f64 / sps;
        let mut params = SubstepParams::new(&self.domains, t0, t1, self.count);
        let newborns = self.newborns(t1);
        params.newborn_end = self.count + newborns.len() as u32;
        let frame_end = (self.substeps + 1).is_multiple_of(u64::from(self.settings.substeps));
        let record = frame_end && self.trails.is_some();
        if let Some(trails) = self.trails.as_mut().filter(|_| record) {
            trails.head = (trails.head + 1) % trails.capacity;
            params.trail_head = trails.head;
            params.trail_capacity = trails.capacity;
            trails.count = trails.count.max(params.newborn_end);
        }
        self.field.write_substep(&self.context, &params);
        self.particles.write(&self.context, self.count, &newborns);
        self.submit(&params, record);
        self.count = params.newborn_end;
        self.substeps += 1;
    }

    /// Records and submits the dispatches of one substep.
    fn submit(&self, params: &SubstepParams, record: bool) {
        self.run_pass("flow substep", |pass| {
            let trails = self.trails.as_ref().filter(|_| record);
            let groups = self.groups(trails.map(|trails| &trails.group));
            self.kernels.record(&self.context, pass, &groups, params);
        });
    }

    /// The field's and the particles' bind groups, and `trails`.
    fn groups<'a>(&'a self, trails: Option<&'a wgpu::BindGroup>) -> StepGroups<'a> {
        StepGroups {
            field: &self.field.group,
            particles: &self.particles.group,
            trails,
        }
    }

    /// The particles `rate` emitters make by time `t` that are not born yet,
    /// in emitter order, at their birth point with the age they have by then
    /// (velocities are set on the GPU), as `FlowSimulation` makes them.
    fn newborns(&mut self, t: f64) -> FlowParticles {
        let mut newborns = FlowParticles::default();
        let seed = self.settings.seed;
        for (index, emitter) in self.settings.emitters.iter().enumerate() {
            if !matches!(emitter.emission, FlowEmission::Rate(_)) {
                continue;
            }
            let target = emitters::births_by(emitter, self.slots[index], t);
            for k in self.births[index]..target {
                let id = u64::from(self.count) + newborns.len() as u64;
                let age = (t - emitters::birth_time(emitter, k)).max(0.0) as f32;
                newborns.push_newborn(emitter, index, seed, id, age);
            }
            self.births[index] = self.births[index].max(target);
        }
        newborns
    }
}

/// The flow settings of a scene, or why the flow backend cannot run it.
fn flow_settings(scene: &Scene) -> Result<&FlowSettings, GpuError> {
    scene.kind.flow().ok_or_else(|| GpuError::Unsupported {
        what: "it is a snow scene, not a curl-noise flow".into(),
        fix: "run it with the snow backend, or give it kind = \"flow\" and a [flow] table".into(),
    })
}

/// Particle slots of each emitter over the run, as `FlowSimulation` counts them.
fn run_slots(scene: &Scene, settings: &FlowSettings) -> Vec<u64> {
    settings
        .emitters
        .iter()
        .map(|emitter| emitter.slots(scene.time.duration))
        .collect()
}

/// Particles the buffers must hold: every slot, and at least the snapshot's.
fn particle_capacity(slots: &[u64], snapshot: usize) -> Result<u32, GpuError> {
    let total = slots
        .iter()
        .fold(0u64, |sum, slots| sum.saturating_add(*slots))
        .max(snapshot as u64);
    u32::try_from(total).map_err(|_| GpuError::Unsupported {
        what: format!("{total} particles (particle ids are 32-bit on the GPU)"),
        fix: "give rate emitters a lifetime or lower their rates, or run with --backend cpu".into(),
    })
}

/// A copy of a snapshot's particles and, if it keeps trails, their raw
/// state.
fn split_snapshot(snapshot: &FlowSnapshot) -> (FlowParticles, Option<TrailState>) {
    let trails = (snapshot.trail_capacity > 0).then(|| TrailState {
        capacity: snapshot.trail_capacity,
        head: snapshot.trail_head,
        points: snapshot.trail_points.clone(),
        lengths: snapshot.trail_lengths.clone(),
        generations: snapshot.trail_generations.clone(),
    });
    let particles = FlowParticles {
        positions: snapshot.positions.clone(),
        velocities: snapshot.velocities.clone(),
        ages: snapshot.ages.clone(),
        lifetimes: snapshot.lifetimes.clone(),
        generations: snapshot.generations.clone(),
        emitters: snapshot.emitters.clone(),
    };
    (particles, trails)
}
