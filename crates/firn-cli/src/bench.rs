//! `firn bench`: solver speed on the thesis' performance scene, a snowball
//! dropped on the ground (§6.2), sized to match the peer benchmark
//! (`scripts/peer/taichi_snow.py --shape ball`): a ball of 0.3 m diameter at
//! (0.5, 0.6, 0.5) in the unit box, Stomakhin's snow, Δt = 0.0128 h.
//!
//! With `--scene FILE` it runs a scene file instead, for a stretch of simulated
//! time, and reports wall-clock seconds per simulated second: the measure that
//! compares integrators, whose substeps differ in length and cost.
//!
//! Both step a `firn_run::Solver` on the backend of `--backend`, as `firn
//! run` does (see `bench_gpu.rs` for the GPU's memory figures); so do
//! `--flow` and `--sweep`, on the CPU.

use std::path::PathBuf;
use std::time::Instant;

use clap::{Args, ValueEnum};
use firn_core::Material;
use firn_core::math::lanes::Simd;
use firn_core::scene::{
    Backend, Body, CacheFormat, Camera, Contact, ContactMode, Domain, ImplicitSettings, Integrator,
    OutputSettings, RenderSettings, Scene, SceneKind, SolverSettings, TimeSettings, TimeStep,
    Transfer,
};
use firn_mpm::PhaseTimes;
use firn_mpm::g2p::preferred_simd;
use firn_run::simulation::HostState;
use firn_run::{Placement, RunError, Solver, SolverOptions};
use glam::Vec3;
use serde::Serialize;

use crate::Failure;
use crate::backend::{backend_values, choose_backend, gpu_failure};
use crate::bench_gpu::GpuMemoryRecord;
use crate::bench_render::bench_render;
use crate::bench_sweep::SweepArgs;
use firn_gpu::snow::stage_times::STAGE_NAMES;

/// Arguments of `firn bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Approximate particle counts, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "262144")]
    pub particles: Vec<u32>,
    /// Grid cells per side of the unit box, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "128")]
    pub grid: Vec<u32>,
    /// Transfer scheme(s) to measure.
    #[arg(long, value_enum, default_value = "both")]
    pub transfer: TransferChoice,
    /// Timed substeps per configuration.
    #[arg(long, default_value_t = 100)]
    pub steps: u32,
    /// Untimed substeps first (they advance the simulation).
    #[arg(long, default_value_t = 10)]
    pub warmup: u32,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Where to write the JSON record.
    #[arg(long, default_value = "bench.json")]
    pub json: PathBuf,
    /// Run this scene file instead and report wall-clock seconds per
    /// simulated second (--particles, --grid, --transfer, --steps and
    /// --warmup do not apply).
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// With --scene: simulated seconds to run (default: the scene's duration).
    #[arg(long, requires = "scene")]
    pub duration: Option<f64>,
    /// With --scene: the time integrator (default: the scene's).
    #[arg(long, value_enum, requires = "scene")]
    pub integrator: Option<IntegratorChoice>,
    /// With --scene: a fixed substep Δt in seconds (default: the scene's step).
    #[arg(long, requires = "scene")]
    pub dt: Option<f32>,
    /// With --scene: hold every collider at its starting pose (a deforming
    /// mesh at its first file), to measure what the colliders' motion costs.
    #[arg(long, requires = "scene")]
    pub still_colliders: bool,
    /// Measure the narrow-band distance field of one mesh frame of a
    /// deforming collider instead: a 20,480-triangle sphere of radius
    /// 0.25 m sampled at 1 cm within 6 cm of its surface, --repeats times;
    /// see bench_mesh_field.rs.
    #[arg(long)]
    pub mesh_field: bool,
    /// Measure the renderer instead: `points` on the snowball of the first
    /// --particles count, `volume` on the bundled default scene.
    #[arg(long)]
    pub render: bool,
    /// With --render: picture size in pixels, WIDTH,HEIGHT.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1920,1080",
        requires = "render"
    )]
    pub size: Vec<u32>,
    /// With --render or --mesh-field: timed repetitions.
    #[arg(long, default_value_t = 3)]
    pub repeats: u32,
    /// Print where the time of each substep goes, phase by phase: on the
    /// CPU (binning, scatter, colliders, grid update, implicit solve,
    /// gather, clear, rigid bodies; its JSON record holds them either way),
    /// or on a GPU with timestamp queries, its stages over 20 more substeps
    /// (blocks, begin_step, clear, binning, scatter, grid_update, gather,
    /// spindrift).
    #[arg(long)]
    pub phases: bool,
    /// Measure the curl-noise particle flow instead (seed 002): --particles,
    /// --steps and --warmup apply; see bench_flow.rs (under mpirun, split
    /// between the ranks: ranks.rs).
    #[arg(long)]
    pub flow: bool,
    /// `--sweep particles|grid` and its options; see bench_sweep.rs.
    #[command(flatten)]
    pub sweep: SweepArgs,
    /// The instruction set of the snow model's batched particle update, for
    /// the snowball, --scene and --sweep runs (default: the solver's own
    /// choice, AVX2 where the CPU has it); with --flow, the one path the
    /// analytic curl is timed on (default: every path the CPU has, and
    /// central differences). All give the same bits; this compares their
    /// speed.
    #[arg(long, value_enum, default_value = "auto")]
    pub simd: SimdChoice,
    /// Compute backend of the snowball and --scene runs (default: auto, or
    /// the --scene file's [compute] backend). --render, --flow and --sweep
    /// run on the CPU.
    #[arg(long, value_parser = backend_values())]
    pub backend: Option<Backend>,
    /// GPU runs: the memory budget, GiB, of the estimate of how many
    /// particles fit (on the bench's grid and on 256^3).
    #[arg(long, default_value_t = 4.0)]
    pub memory_budget_gib: f64,
    /// GPU runs: how the scatter adds into the grid: binned (particles
    /// sorted by block, sums in workgroup memory first; the default where
    /// the adapter allows) or atomic (every particle adds into the grid).
    #[arg(long, value_enum, default_value_t = GpuScatterChoice::Binned)]
    pub gpu_scatter: GpuScatterChoice,
}

/// Scatters for `--gpu-scatter`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum GpuScatterChoice {
    /// Counting sort by block, sums in workgroup memory, one global add per node.
    Binned,
    /// Global 64-bit fixed-point atomics per particle and node.
    Atomic,
}

impl GpuScatterChoice {
    fn scatter(self) -> firn_gpu::snow::Scatter {
        match self {
            GpuScatterChoice::Binned => firn_gpu::snow::Scatter::Binned,
            GpuScatterChoice::Atomic => firn_gpu::snow::Scatter::Atomic,
        }
    }
}

/// Instruction sets for `--simd`.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum SimdChoice {
    /// The solver's choice ([`firn_mpm::g2p::preferred_simd`]).
    Auto,
    /// Portable code (SSE on x86-64).
    Portable,
    /// 256-bit AVX2 registers.
    Avx2,
    /// 512-bit AVX-512 registers.
    Avx512,
}

impl SimdChoice {
    /// The instruction set, or an error when the CPU lacks it.
    pub fn resolve(self) -> Result<Simd, Failure> {
        let simd = match self {
            SimdChoice::Auto => preferred_simd(),
            SimdChoice::Portable => Simd::Portable,
            SimdChoice::Avx2 => Simd::Avx2,
            SimdChoice::Avx512 => Simd::Avx512,
        };
        if simd.is_available() {
            Ok(simd)
        } else {
            Err(Failure::BadInput(format!(
                "error: --simd {}: this CPU does not have it\n  fix: pick one it has (the widest here: {}), or leave --simd out",
                simd.name(),
                Simd::detect().name()
            )))
        }
    }
}

/// Time integrators for `--scene`.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum IntegratorChoice {
    /// Forward Euler on the grid velocities.
    Explicit,
    /// Stomakhin's semi-implicit update (the scene's β and solver settings,
    /// else the defaults).
    SemiImplicit,
}

impl IntegratorChoice {
    /// The scene's integrator switched to this choice, keeping the scene's
    /// semi-implicit settings where it has them.
    pub fn applied_to(self, current: Integrator) -> Integrator {
        match (self, current) {
            (IntegratorChoice::Explicit, _) => Integrator::Explicit,
            (IntegratorChoice::SemiImplicit, Integrator::SemiImplicit(settings)) => {
                Integrator::SemiImplicit(settings)
            }
            (IntegratorChoice::SemiImplicit, Integrator::Explicit) => {
                Integrator::SemiImplicit(ImplicitSettings::DEFAULT)
            }
        }
    }
}

/// Which transfer schemes to benchmark.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum TransferChoice {
    /// PIC/FLIP with cubic B-splines.
    PicFlip,
    /// APIC with quadratic B-splines.
    Apic,
    /// Both, one after the other.
    Both,
}

impl TransferChoice {
    /// The schemes to measure, in order.
    pub fn schemes(self) -> &'static [Transfer] {
        match self {
            TransferChoice::PicFlip => &[Transfer::PicFlip],
            TransferChoice::Apic => &[Transfer::Apic],
            TransferChoice::Both => &[Transfer::PicFlip, Transfer::Apic],
        }
    }
}

/// One measured configuration.
#[derive(Debug, Serialize)]
struct BenchRecord {
    transfer: Transfer,
    particles: usize,
    grid: u32,
    steps: u32,
    dt: f32,
    seconds: f64,
    ns_per_particle_substep: f64,
    substeps_per_second: f64,
    memory_mib: f64,
    threads: usize,
    /// Instruction set of the batched particle update (CPU runs only).
    simd: Option<&'static str>,
    center_of_mass_y: f64,
    /// Nanoseconds per particle-substep in each phase of the step (CPU
    /// runs only; empty on the GPU).
    phases_ns_per_particle_substep: Vec<PhaseRecord>,
    /// Where it ran.
    #[serde(flatten)]
    backend: BackendRecord,
}

/// The backend a bench ran on, for its JSON record.
#[derive(Debug, Serialize)]
struct BackendRecord {
    /// "cpu" or "gpu".
    backend: &'static str,
    /// The GPU adapter's name (GPU runs only).
    #[serde(skip_serializing_if = "Option::is_none")]
    adapter: Option<String>,
    /// GPU memory needed and what fits the budget (GPU runs only).
    #[serde(skip_serializing_if = "Option::is_none")]
    gpu_memory: Option<GpuMemoryRecord>,
    /// The scatter the GPU ran, "binned" or "atomic" (GPU runs only).
    #[serde(skip_serializing_if = "Option::is_none")]
    gpu_scatter: Option<&'static str>,
}

impl BackendRecord {
    /// A CPU run.
    const CPU: BackendRecord = BackendRecord {
        backend: "cpu",
        adapter: None,
        gpu_memory: None,
        gpu_scatter: None,
    };

    /// Where `solver` runs, with its GPU memory against `--memory-budget-gib`.
    fn of(solver: &Solver, args: &BenchArgs) -> Self {
        let Placement::Gpu(context) = solver.placement() else {
            return BackendRecord::CPU;
        };
        BackendRecord {
            gpu_scatter: solver.options().gpu_scatter.map(|scatter| match scatter {
                firn_gpu::snow::Scatter::Binned => "binned",
                firn_gpu::snow::Scatter::Atomic => "atomic",
            }),
            backend: "gpu",
            adapter: Some(context.adapter.name.clone()),
            gpu_memory: Some(GpuMemoryRecord::of(
                solver.scene(),
                solver.particle_count() as u64,
                args.memory_budget_gib,
            )),
        }
    }

    /// ` backend=gpu adapter="NAME"` for the bench's output line.
    fn words(&self) -> String {
        match &self.adapter {
            Some(adapter) => format!(
                " backend={} adapter=\"{adapter}\" gpu_scatter={}",
                self.backend,
                self.gpu_scatter.unwrap_or("atomic")
            ),
            None => format!(" backend={}", self.backend),
        }
    }

    /// The GPU memory lines, if any, each on its own line.
    fn print_memory(&self) {
        if let Some(memory) = &self.gpu_memory {
            outln!("{}", memory.lines());
        }
    }
}

/// The time of one phase of the step, per particle and substep.
#[derive(Debug, Serialize)]
struct PhaseRecord {
    phase: &'static str,
    ns_per_particle_substep: f64,
    share: f64,
}

/// Where the GPU's substeps go, stage by stage, over up to
/// [`GPU_PHASE_SUBSTEPS`] more substeps timed with timestamp queries
/// (none where the adapter has none).
fn gpu_phase_records(solver: &mut Solver) -> Result<Vec<PhaseRecord>, Failure> {
    let particles = solver.particle_count();
    let Some(times) = solver.stage_times(GPU_PHASE_SUBSTEPS).map_err(failed)? else {
        return Ok(Vec::new());
    };
    let total = times.seconds.iter().sum::<f64>().max(f64::MIN_POSITIVE);
    let per_particle_substep = 1e9 / (times.substeps.max(1) as f64 * particles.max(1) as f64);
    Ok(STAGE_NAMES
        .iter()
        .zip(times.seconds)
        .map(|(&phase, seconds)| PhaseRecord {
            phase,
            ns_per_particle_substep: seconds * per_particle_substep,
            share: seconds / total,
        })
        .collect())
}

/// Substeps [`gpu_phase_records`] times, after the timed run.
const GPU_PHASE_SUBSTEPS: u32 = 20;

/// The phase profile of `substeps` timed substeps of `particles` particles.
fn phase_records(times: PhaseTimes, substeps: u32, particles: usize) -> Vec<PhaseRecord> {
    let total = times.total().max(f64::MIN_POSITIVE);
    let per_particle_substep = 1e9 / (substeps.max(1) as f64 * particles.max(1) as f64);
    times
        .entries()
        .into_iter()
        .map(|(phase, seconds)| PhaseRecord {
            phase,
            ns_per_particle_substep: seconds * per_particle_substep,
            share: seconds / total,
        })
        .collect()
}

/// ` simd=NAME` for the output line of a CPU run.
fn simd_words(simd: Option<&str>) -> String {
    simd.map(|name| format!(" simd={name}")).unwrap_or_default()
}

/// Prints `phases` as a small table, or why a run on `backend` has none.
fn print_phase_table(backend: &BackendRecord, phases: &[PhaseRecord]) {
    if backend.backend != "cpu" && phases.is_empty() {
        outln!(
            "  phases: not measured: the adapter has no timestamp queries, the integrator is semi-implicit or the scene has rigid bodies"
        );
    }
    for phase in phases {
        outln!(
            "  {:<15} {:>9.2} ns  {:>5.1} %",
            phase.phase,
            phase.ns_per_particle_substep,
            100.0 * phase.share
        );
    }
}

/// One `--scene` run.
#[derive(Debug, Serialize)]
struct SceneRecord {
    scene: String,
    integrator: &'static str,
    transfer: Transfer,
    time_step: TimeStep,
    particles: usize,
    simulated_seconds: f64,
    substeps: u64,
    wall_seconds: f64,
    wall_seconds_per_simulated_second: f64,
    ns_per_particle_substep: f64,
    mean_substep_dt: f64,
    mean_solver_iterations: Option<f64>,
    max_solver_iterations: Option<u32>,
    unconverged_solves: Option<u64>,
    worst_solver_residual: Option<f32>,
    /// The semi-implicit solve's time per node-row of a product with H
    /// (its phase time over the solves' (iterations + 1) × active nodes; CPU
    /// runs with the semi-implicit integrator only).
    implicit_ns_per_node_product: Option<f64>,
    threads: usize,
    /// Instruction set of the batched particle update (CPU runs only).
    simd: Option<&'static str>,
    /// Nanoseconds per particle-substep in each phase of the step (CPU
    /// runs only; empty on the GPU).
    phases_ns_per_particle_substep: Vec<PhaseRecord>,
    /// Where it ran.
    #[serde(flatten)]
    backend: BackendRecord,
}

/// Runs every configuration and writes the JSON record.
pub fn bench(args: BenchArgs) -> Result<(), Failure> {
    if let Some(count) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(count.max(1))
            .build_global()
            .map_err(|error| {
                Failure::Failed(format!("error: cannot start {count} threads: {error}"))
            })?;
    }
    #[cfg(feature = "mpi")]
    if let Some(mpi) = firn_mpi::mpi_exchange::MpiRun::launched() {
        return crate::ranks::bench(&args, &mpi);
    }
    outln!("cpu: {}", crate::machine::Cpu::detect().describe());
    if (args.render || args.flow || args.sweep.sweep.is_some())
        && args.backend == Some(Backend::Gpu)
    {
        return Err(Failure::BadInput(
            "error: --backend gpu applies to the snowball bench and --scene; --render, --flow and --sweep measure the CPU\n  fix: leave out --backend, or --render, --flow and --sweep".into(),
        ));
    }
    if args.render {
        let particles = args.particles.first().copied().unwrap_or(262_144);
        let size = <[u32; 2]>::try_from(args.size.as_slice()).map_err(|_| {
            Failure::BadInput(
                "error: --size takes two numbers\n  fix: pass WIDTH,HEIGHT, e.g. --size 1920,1080"
                    .into(),
            )
        })?;
        return bench_render(particles, size, args.repeats, &args.json);
    }
    if args.flow {
        return crate::bench_flow::bench_flow(&args);
    }
    if args.mesh_field {
        return crate::bench_mesh_field::bench_mesh_field(args.repeats, &args.json);
    }
    if let Some(kind) = args.sweep.sweep {
        return crate::bench_sweep::bench_sweep(kind, &args);
    }
    if let Some(path) = &args.scene {
        let record = measure_scene(path, &args)?;
        return write_json(&args.json, &[record]);
    }
    let transfers = args.transfer.schemes();
    let mut records = Vec::new();
    for &grid in &args.grid {
        for &particles in &args.particles {
            for &transfer in transfers {
                let record = measure(snowball_drop(particles, grid, transfer), grid, &args)?;
                outln!(
                    "firn{} transfer={} particles={} grid={} steps={} seconds={:.3} ns_per_particle_step={:.2} substeps_per_s={:.2} memory_mib={:.1} threads={}{}",
                    record.backend.words(),
                    transfer_name(transfer),
                    record.particles,
                    grid,
                    record.steps,
                    record.seconds,
                    record.ns_per_particle_substep,
                    record.substeps_per_second,
                    record.memory_mib,
                    record.threads,
                    simd_words(record.simd)
                );
                record.backend.print_memory();
                if args.phases {
                    print_phase_table(&record.backend, &record.phases_ns_per_particle_substep);
                }
                records.push(record);
            }
        }
    }
    write_json(&args.json, &records)
}

/// Writes the records as [`records_json`].
pub fn write_json(path: &std::path::Path, records: &[impl Serialize]) -> Result<(), Failure> {
    let json = records_json(records)?;
    firn_io::write_atomically(path, |out| out.write_all(json.as_bytes()))
        .map_err(|error| Failure::BadInput(format!("error: {error}")))?;
    outln!("wrote {}", path.display());
    Ok(())
}

/// The records as a pretty JSON array, each with the CPU it was measured on
/// added (`cpu`: [`crate::machine::Cpu`]).
pub fn records_json(records: &[impl Serialize]) -> Result<String, Failure> {
    let failed = |error: serde_json::Error| Failure::Failed(error.to_string());
    let cpu = serde_json::to_value(crate::machine::Cpu::detect()).map_err(failed)?;
    let mut values = Vec::with_capacity(records.len());
    for record in records {
        let mut value = serde_json::to_value(record).map_err(failed)?;
        if let Some(fields) = value.as_object_mut() {
            fields.insert("cpu".into(), cpu.clone());
        }
        values.push(value);
    }
    serde_json::to_string_pretty(&values).map_err(failed)
}

/// The scene file with the command line's overrides, validated.
fn bench_scene(path: &std::path::Path, args: &BenchArgs) -> Result<Scene, Failure> {
    let mut scene = Scene::load(path).map_err(|error| Failure::BadInput(error.to_string()))?;
    if let Some(duration) = args.duration {
        scene.time.duration = duration;
    }
    if let Some(dt) = args.dt {
        scene.time.step = TimeStep::Fixed { dt };
    }
    if let Some(choice) = args.integrator {
        scene.solver.integrator = choice.applied_to(scene.solver.integrator);
    }
    if args.still_colliders {
        for collider in &mut scene.colliders {
            collider.hold_still();
        }
    }
    scene.validate().map_err(|error| {
        Failure::BadInput(format!(
            "error: {} with the command line's overrides: {}\n  fix: {}",
            path.display(),
            error.message,
            error.hint
        ))
    })?;
    Ok(scene)
}

/// Where a bench scene runs: `--backend`, else the scene's own backend.
fn bench_placement(scene: &mut Scene, args: &BenchArgs) -> Result<Placement, Failure> {
    if let Some(backend) = args.backend {
        scene.compute.backend = backend;
    }
    let chosen = choose_backend(scene)?;
    if let Some(note) = chosen.note {
        outln!("{note}");
    }
    Ok(chosen.placement)
}

/// Runs `scene` to its end on `placement`; returns the solver at the end
/// and the wall-clock seconds it took.
fn run_scene(
    scene: Scene,
    placement: &Placement,
    args: &BenchArgs,
) -> Result<(Solver, f64), Failure> {
    let duration = scene.time.duration;
    let mut solver = bench_solver(scene, placement, args)?;
    solver.wait().map_err(failed)?;
    let started = Instant::now();
    solver.advance_to(duration).map_err(failed)?;
    solver.wait().map_err(failed)?;
    Ok((solver, started.elapsed().as_secs_f64()))
}

/// Runs a scene file for its duration and times it.
fn measure_scene(path: &std::path::Path, args: &BenchArgs) -> Result<SceneRecord, Failure> {
    let mut scene = bench_scene(path, args)?;
    let placement = bench_placement(&mut scene, args)?;
    let (duration, time_step) = (scene.time.duration, scene.time.step.clone());
    let (transfer, integrator) = (scene.solver.transfer, scene.solver.integrator);
    let (mut solver, wall_seconds) = run_scene(scene, &placement, args)?;
    let substeps = solver.steps();
    let particles = solver.particle_count();
    let stats = solver.solver_stats();
    let times = solver.phase_times();
    let simd = solver.options().simd.map(Simd::name);
    let backend = BackendRecord::of(&solver, args);
    let implicit_ns_per_node_product = match (times, stats) {
        (Some(times), Some(stats)) => stats
            .seconds_per_node_product(times.implicit_solve)
            .map(|seconds| seconds * 1e9),
        _ => None,
    };
    let phases = match times {
        Some(times) => phase_records(times, substeps as u32, particles),
        None if args.phases => gpu_phase_records(&mut solver)?,
        None => Vec::new(),
    };
    let record = SceneRecord {
        scene: path.display().to_string(),
        integrator: match integrator {
            Integrator::Explicit => "explicit",
            Integrator::SemiImplicit(_) => "semi-implicit",
        },
        transfer,
        time_step,
        particles,
        simulated_seconds: duration,
        substeps,
        wall_seconds,
        wall_seconds_per_simulated_second: wall_seconds / duration,
        ns_per_particle_substep: wall_seconds * 1e9 / (substeps.max(1) as f64 * particles as f64),
        mean_substep_dt: duration / substeps.max(1) as f64,
        mean_solver_iterations: stats.map(|stats| stats.mean_iterations()),
        max_solver_iterations: stats.map(|stats| stats.max_iterations),
        unconverged_solves: stats.map(|stats| stats.unconverged_steps),
        worst_solver_residual: stats.map(|stats| stats.worst_residual),
        implicit_ns_per_node_product,
        threads: rayon::current_num_threads(),
        simd,
        phases_ns_per_particle_substep: phases,
        backend,
    };
    let iterations = match (record.mean_solver_iterations, record.max_solver_iterations) {
        (Some(mean), Some(max)) => format!(
            " mean_iterations={mean:.1} max_iterations={max} unconverged={}",
            record.unconverged_solves.unwrap_or(0)
        ),
        _ => String::new(),
    };
    let per_node = record
        .implicit_ns_per_node_product
        .map(|ns| format!(" implicit_ns_per_node_product={ns:.1}"))
        .unwrap_or_default();
    outln!(
        "firn{} scene={} integrator={} transfer={} particles={} simulated_s={} substeps={} mean_dt={:.3e} wall_s={:.3} wall_s_per_simulated_s={:.2} ns_per_particle_step={:.1}{iterations}{per_node} threads={}{}",
        record.backend.words(),
        record.scene,
        record.integrator,
        transfer_name(transfer),
        particles,
        duration,
        substeps,
        record.mean_substep_dt,
        wall_seconds,
        record.wall_seconds_per_simulated_second,
        record.ns_per_particle_substep,
        record.threads,
        simd_words(record.simd)
    );
    record.backend.print_memory();
    if args.phases {
        print_phase_table(&record.backend, &record.phases_ns_per_particle_substep);
    }
    Ok(record)
}

/// The scheme's name on the command line.
pub fn transfer_name(transfer: Transfer) -> &'static str {
    match transfer {
        Transfer::PicFlip => "pic-flip",
        Transfer::Apic => "apic",
    }
}

/// Times `args.steps` substeps of the snowball `scene` after `args.warmup`,
/// on `--backend`'s choice.
fn measure(mut scene: Scene, grid: u32, args: &BenchArgs) -> Result<BenchRecord, Failure> {
    let placement = bench_placement(&mut scene, args)?;
    let (dt, transfer) = (bench_dt(&scene), scene.solver.transfer);
    let mut solver = bench_solver(scene, &placement, args)?;
    let (steps, seconds) = time_substeps(&mut solver, args.warmup, args.steps, None)?;
    let particles = solver.particle_count();
    let backend = BackendRecord::of(&solver, args);
    let (memory_bytes, simd) = (solver.memory_bytes(), solver.options().simd);
    let HostState::Snow(state) = solver.host().map_err(failed)? else {
        return Err(Failure::Failed(
            "error: the bench scene is not a snow scene".into(),
        ));
    };
    let center_of_mass_y = state.diagnostics().center_of_mass[1];
    let phases = match solver.phase_times() {
        Some(times) => phase_records(times, steps, particles),
        None if args.phases => gpu_phase_records(&mut solver)?,
        None => Vec::new(),
    };
    Ok(BenchRecord {
        transfer,
        particles,
        grid,
        steps,
        dt,
        seconds,
        ns_per_particle_substep: seconds * 1e9 / (steps.max(1) as f64 * particles as f64),
        substeps_per_second: steps as f64 / seconds,
        memory_mib: memory_bytes as f64 / (1024.0 * 1024.0),
        threads: rayon::current_num_threads(),
        simd: simd.map(Simd::name),
        center_of_mass_y,
        phases_ns_per_particle_substep: phases,
        backend,
    })
}

/// The fixed substep of a bench scene (or its adaptive bound).
fn bench_dt(scene: &Scene) -> f32 {
    match scene.time.step {
        TimeStep::Fixed { dt } => dt,
        TimeStep::Adaptive { max_dt, .. } => max_dt,
    }
}

/// The solver of `scene` on `placement`, with `--simd` and `--gpu-scatter`.
pub fn bench_solver(
    scene: Scene,
    placement: &Placement,
    args: &BenchArgs,
) -> Result<Solver, Failure> {
    let options = SolverOptions {
        simd: Some(args.simd.resolve()?),
        gpu_scatter: Some(args.gpu_scatter.scatter()),
    };
    let solver = Solver::new(scene, placement).map_err(|error| match error {
        RunError::Gpu(error) => gpu_failure(&error),
        other => failed(other),
    })?;
    Ok(solver.with_options(options))
}

/// A solver's error while it runs (exit code 1).
pub fn failed(error: RunError) -> Failure {
    Failure::Failed(format!("error: {error}"))
}

/// Runs `warmup` untimed substeps, then `steps` timed ones, or fewer once
/// `budget` has passed (but at least [`MIN_TIMED_SUBSTEPS`]); returns the
/// timed substeps and their wall-clock seconds. With a budget it steps one
/// substep at a time; the GPU may take a substep more than asked (see
/// [`Solver::advance_substeps`]).
pub fn time_substeps(
    solver: &mut Solver,
    warmup: u32,
    steps: u32,
    budget: Option<std::time::Duration>,
) -> Result<(u32, f64), Failure> {
    solver.advance_substeps(warmup).map_err(failed)?;
    solver.wait().map_err(failed)?;
    solver.reset_phase_times();
    let started = Instant::now();
    let timed = match budget {
        Some(budget) => {
            let mut timed = 0;
            while timed < steps {
                timed += solver.advance_substeps(1).map_err(failed)?;
                if timed >= MIN_TIMED_SUBSTEPS && started.elapsed() >= budget {
                    break;
                }
            }
            timed
        }
        None => solver.advance_substeps(steps).map_err(failed)?,
    };
    solver.wait().map_err(failed)?;
    Ok((timed, started.elapsed().as_secs_f64()))
}

/// Fewest timed substeps [`time_substeps`] runs before its time budget may
/// stop it.
pub const MIN_TIMED_SUBSTEPS: u32 = 3;

/// The benchmark scene with about `particles` particles on a `grid`³ grid.
pub fn snowball_drop(particles: u32, grid: u32, transfer: Transfer) -> Scene {
    let h = 1.0 / grid as f32;
    let radius = 0.15;
    let ball_cells = 4.0 / 3.0 * std::f32::consts::PI * radius * radius * radius / (h * h * h);
    let particles_per_cell = (particles as f32 / ball_cells).round().clamp(1.0, 64.0) as u32;
    Scene {
        name: "bench-snowball-drop".into(),
        domain: Domain {
            min: Vec3::ZERO,
            max: Vec3::ONE,
            cell_size: h,
            walls: Contact {
                mode: ContactMode::Separate,
                friction: 0.0,
            },
        },
        time: TimeSettings {
            duration: 1.0,
            fps: 30.0,
            step: TimeStep::Fixed { dt: 0.0128 * h },
            max_substeps_per_frame: TimeSettings::DEFAULT_MAX_SUBSTEPS_PER_FRAME,
        },
        solver: SolverSettings {
            transfer,
            flip_blend: 0.95,
            gravity: Vec3::new(0.0, -9.8, 0.0),
            seed: 1,
            integrator: Integrator::Explicit,
        },
        materials: vec![Material::preset("snow").expect("the snow preset exists")],
        bodies: vec![
            Body::sphere(Vec3::new(0.5, 0.6, 0.5), radius).particles_per_cell(particles_per_cell),
        ],
        colliders: Vec::new(),
        rigid_bodies: Vec::new(),
        output: OutputSettings {
            directory: PathBuf::from("out/bench"),
            formats: vec![CacheFormat::Ply],
            attributes: Vec::new(),
            checkpoint_every: 0,
            ..OutputSettings::default()
        },
        camera: Camera::default(),
        render: RenderSettings::default(),
        kind: SceneKind::Snow,
        compute: Default::default(),
        wind: None,
    }
}
