//! `firn bench --flow`: speed of the curl-noise particle flow (seed 002) on
//! the demo's setting: a 100 m box, L = 20, one sphere obstacle of radius 15
//! in the middle, half turbulence and half background, particles filling the
//! box uniformly. Each configuration takes `--warmup` untimed steps, then
//! `--steps` timed ones (one RK2 step each: two velocity evaluations per
//! particle), with the analytic curl and, for comparison, central differences;
//! the analytic curl is also timed on every other SIMD path the CPU offers.
//! `--simd PATH` times only the analytic curl on that path.

use std::time::Instant;

use firn_core::Scene;
use firn_flow::Simd;
use firn_run::{Placement, Solver, SolverOptions};
use serde::Serialize;

use crate::Failure;
use crate::bench::{BenchArgs, SimdChoice, failed, write_json};

/// One measured configuration.
#[derive(Debug, Serialize)]
struct FlowRecord {
    mode: &'static str,
    curl: &'static str,
    integrator: &'static str,
    simd: &'static str,
    particles: usize,
    steps: u32,
    seconds: f64,
    ns_per_particle_step: f64,
    steps_per_second: f64,
    /// CPU time of all threads over the timed steps (Linux), which other
    /// programs on the machine do not inflate; `None` where unknown.
    cpu_seconds: Option<f64>,
    /// `cpu_seconds` per particle-step: the wall time per particle-step on
    /// `threads` otherwise idle cores is this divided by `threads`.
    cpu_ns_per_particle_step: Option<f64>,
    memory_mib: f64,
    threads: usize,
}

/// CPU seconds this process has used so far, all threads, from
/// `/proc/self/stat` (utime + stime, in the kernel's fixed 100 ticks per
/// second); `None` off Linux.
fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which may hold spaces) start at field 3.
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks = |field: usize| fields.get(field - 3)?.parse::<f64>().ok();
    Some((ticks(14)? + ticks(15)?) / 100.0)
}

/// The benchmark scene with `particles` particles and the given curl.
pub(crate) fn scene(particles: u32, curl: &str) -> Result<Scene, Failure> {
    let text = format!(
        r#"format = 1
name = "bench-curl-noise"
kind = "flow"

[domain]
max = [100.0, 100.0, 100.0]

[time]
duration = 100.0
fps = 60

[flow]
noise_share = 0.5
noise_strength = 40.0
length_scale = 20.0
background_strength = 12.0
evolution_rate = 0.04
curl = "{curl}"
integration = "rk2"
substeps = 1

[[flow.obstacles]]
center = [50.0, 50.0, 50.0]
radius = 15.0
influence = 10.0

[[flow.emitters]]
shape = "box"
center = [50.0, 50.0, 50.0]
size = [100.0, 100.0, 100.0]
count = {particles}
"#
    );
    Scene::from_toml_str(&text, "bench-curl-noise.toml")
        .map_err(|error| Failure::Failed(format!("{error}")))
}

/// Runs every configuration and writes the JSON record.
pub fn bench_flow(args: &BenchArgs) -> Result<(), Failure> {
    let chosen = match args.simd {
        SimdChoice::Auto => None,
        choice => Some(choice.resolve()?),
    };
    let detected = Simd::detect();
    let mut records = Vec::new();
    for &particles in &args.particles {
        let runs = match chosen {
            Some(simd) => vec![("analytic", simd)],
            None => {
                let mut runs = vec![("analytic", detected), ("finite-difference", detected)];
                for simd in [Simd::Avx512, Simd::Avx2, Simd::Portable] {
                    if simd != detected && simd.is_available() {
                        runs.push(("analytic", simd));
                    }
                }
                runs
            }
        };
        for (curl, simd) in runs {
            let record = measure(particles, curl, simd, args)?;
            outln!(
                "firn flow curl={} simd={} particles={} steps={} seconds={:.3} ns_per_particle_step={:.2} steps_per_s={:.2} cpu_ns_per_particle_step={} memory_mib={:.1} threads={}",
                record.curl,
                record.simd,
                record.particles,
                record.steps,
                record.seconds,
                record.ns_per_particle_step,
                record.steps_per_second,
                record
                    .cpu_ns_per_particle_step
                    .map_or("unknown".to_string(), |ns| format!("{ns:.2}")),
                record.memory_mib,
                record.threads
            );
            records.push(record);
        }
    }
    write_json(&args.json, &records)
}

/// Times `args.steps` steps of `particles` particles with `curl` on `simd`
/// after `args.warmup`, on the CPU.
fn measure(
    particles: u32,
    curl: &'static str,
    simd: Simd,
    args: &BenchArgs,
) -> Result<FlowRecord, Failure> {
    let options = SolverOptions {
        simd: Some(simd),
        gpu_scatter: None,
    };
    let mut flow = Solver::new(scene(particles, curl)?, &Placement::Cpu)
        .map_err(failed)?
        .with_options(options);
    flow.advance_substeps(args.warmup).map_err(failed)?;
    let cpu_before = process_cpu_seconds();
    let started = Instant::now();
    flow.advance_substeps(args.steps).map_err(failed)?;
    let seconds = started.elapsed().as_secs_f64();
    let cpu_seconds = cpu_before
        .zip(process_cpu_seconds())
        .map(|(before, after)| after - before);
    let count = flow.particle_count();
    let steps = args.steps.max(1);
    Ok(FlowRecord {
        mode: "flow",
        curl,
        integrator: "rk2",
        simd: flow.options().simd.unwrap_or(simd).name(),
        particles: count,
        steps,
        seconds,
        ns_per_particle_step: seconds * 1e9 / (f64::from(steps) * count as f64),
        steps_per_second: f64::from(steps) / seconds,
        cpu_seconds,
        cpu_ns_per_particle_step: cpu_seconds
            .map(|cpu| cpu * 1e9 / (f64::from(steps) * count as f64)),
        memory_mib: flow.memory_bytes() as f64 / (1024.0 * 1024.0),
        threads: rayon::current_num_threads(),
    })
}
