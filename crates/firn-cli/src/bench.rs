//! `firn bench`: solver speed on the thesis' performance scene, a snowball
//! dropped on the ground (§6.2), sized to match the peer benchmark
//! (`taichi_mpm3d.py --shape ball`): a ball of 0.3 m diameter at
//! (0.5, 0.6, 0.5) in the unit box, Stomakhin's snow, Δt = 0.0128 h.

use std::path::PathBuf;
use std::time::Instant;

use clap::{Args, ValueEnum};
use firn_core::Material;
use firn_core::scene::{
    Body, CacheFormat, Camera, Contact, ContactMode, Domain, OutputSettings, RenderSettings, Scene,
    Shape, SolverSettings, TimeSettings, TimeStep, Transfer,
};
use firn_mpm::Simulation;
use glam::Vec3;
use serde::Serialize;

use crate::Failure;

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
    center_of_mass_y: f64,
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
    let transfers: &[Transfer] = match args.transfer {
        TransferChoice::PicFlip => &[Transfer::PicFlip],
        TransferChoice::Apic => &[Transfer::Apic],
        TransferChoice::Both => &[Transfer::PicFlip, Transfer::Apic],
    };
    let mut records = Vec::new();
    for &grid in &args.grid {
        for &particles in &args.particles {
            for &transfer in transfers {
                let record = measure(snowball_drop(particles, grid, transfer), grid, &args)?;
                println!(
                    "firn transfer={} particles={} grid={} steps={} seconds={:.3} ns_per_particle_step={:.2} substeps_per_s={:.2} memory_mib={:.1} threads={}",
                    transfer_name(transfer),
                    record.particles,
                    grid,
                    record.steps,
                    record.seconds,
                    record.ns_per_particle_substep,
                    record.substeps_per_second,
                    record.memory_mib,
                    record.threads
                );
                records.push(record);
            }
        }
    }
    let json = serde_json::to_string_pretty(&records)
        .map_err(|error| Failure::Failed(error.to_string()))?;
    firn_io::write_atomically(&args.json, |out| out.write_all(json.as_bytes()))
        .map_err(|error| Failure::BadInput(format!("error: {error}")))?;
    println!("wrote {}", args.json.display());
    Ok(())
}

fn transfer_name(transfer: Transfer) -> &'static str {
    match transfer {
        Transfer::PicFlip => "pic-flip",
        Transfer::Apic => "apic",
    }
}

fn measure(scene: Scene, grid: u32, args: &BenchArgs) -> Result<BenchRecord, Failure> {
    let dt = match scene.time.step {
        TimeStep::Fixed { dt } => dt,
        TimeStep::Adaptive { max_dt, .. } => max_dt,
    };
    let transfer = scene.solver.transfer;
    let mut simulation =
        Simulation::new(scene).map_err(|error| Failure::Failed(format!("error: {error}")))?;
    let fail = |error: firn_mpm::SimulationError| Failure::Failed(format!("error: {error}"));
    for _ in 0..args.warmup {
        simulation.step(f64::INFINITY).map_err(fail)?;
    }
    let started = Instant::now();
    for _ in 0..args.steps {
        simulation.step(f64::INFINITY).map_err(fail)?;
    }
    let seconds = started.elapsed().as_secs_f64();
    let particles = simulation.particles().len();
    Ok(BenchRecord {
        transfer,
        particles,
        grid,
        steps: args.steps,
        dt,
        seconds,
        ns_per_particle_substep: seconds * 1e9 / (args.steps.max(1) as f64 * particles as f64),
        substeps_per_second: args.steps as f64 / seconds,
        memory_mib: simulation.memory_bytes() as f64 / (1024.0 * 1024.0),
        threads: rayon::current_num_threads(),
        center_of_mass_y: simulation.diagnostics().center_of_mass[1],
    })
}

/// The benchmark scene with about `particles` particles on a `grid`³ grid.
fn snowball_drop(particles: u32, grid: u32, transfer: Transfer) -> Scene {
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
        },
        solver: SolverSettings {
            transfer,
            flip_blend: 0.95,
            gravity: Vec3::new(0.0, -9.8, 0.0),
            seed: 1,
        },
        materials: vec![Material::preset("snow").expect("the snow preset exists")],
        bodies: vec![Body {
            shape: Shape::Sphere {
                center: Vec3::new(0.5, 0.6, 0.5),
                radius,
            },
            velocity: Vec3::ZERO,
            material: 0,
            particles_per_cell,
        }],
        colliders: Vec::new(),
        output: OutputSettings {
            directory: PathBuf::from("out/bench"),
            formats: vec![CacheFormat::Ply],
            attributes: Vec::new(),
            checkpoint_every: 0,
        },
        camera: Camera::default(),
        render: RenderSettings::default(),
    }
}
