//! `firn run` and `firn bench` under an MPI launcher (the `mpi` feature):
//! `mpirun -np N firn run SCENE` splits the snow or the flow between N
//! ranks (firn-mpi). Every rank loads the scene; rank 0 records the run as
//! one process would (the same caches, manifest and checkpoints, byte for
//! byte), the other ranks step their parts and follow rank 0's commands.

use std::sync::Arc;
use std::time::Instant;

use firn_core::Scene;
use firn_core::scene::{Backend, Transfer};
use firn_flow::{FlowSimulation, Simd};
use firn_gpu::{AdapterPolicy, GpuContext, GpuSnow};
use firn_mpi::driver::refusal;
use firn_mpi::exchange::{join_u64, split_u64};
use firn_mpi::mpi_exchange::{MpiExchange, MpiRun};
use firn_mpi::{Command, Exchange, Phase, RankFlow, RankSnow, RootStepper, follow};
use firn_mpm::Snapshot;
use firn_run::Placement;

use crate::Failure;
use crate::backend::gpu_failure;
use crate::bench::{BenchArgs, SimdChoice, failed, snowball_drop, transfer_name};
use crate::run::{RunArgs, record, scene_for};

/// Runs `args` as one rank of `mpi`'s run.
pub fn run(args: &RunArgs, mpi: &MpiRun) -> Result<(), Failure> {
    let exchange = mpi.exchange();
    let ranks = exchange.size();
    let scene = scene_for(args).and_then(|(scene, file)| match refusal(&scene, ranks) {
        Some(reason) => Err(Failure::BadInput(format!("error: {reason}"))),
        None => Ok((scene, file)),
    });
    let (scene, scene_file) = agree_on(&exchange, scene)?;
    let gpu = rank_gpu(&exchange, &scene);
    let gpu = agree_on(&exchange, gpu)?;
    if exchange.rank() != 0 {
        return follower(exchange, &scene, gpu);
    }
    let described = match &gpu {
        None => format!("the CPU, split between {ranks} MPI ranks"),
        Some(context) => format!(
            "GPUs, split between {ranks} MPI ranks (rank 0 on {})",
            context.adapter.name
        ),
    };
    let result = record(
        args,
        scene,
        scene_file,
        &Placement::Cpu,
        &described,
        |solver| {
            let stepper = RootStepper::start(exchange.clone(), solver, gpu)?;
            Ok(Some(Box::new(stepper)))
        },
    );
    let code = match &result {
        Ok(()) => 0,
        Err(Failure::BadInput(_)) => crate::EXIT_BAD_INPUT,
        Err(_) => crate::EXIT_FAILED,
    };
    // Said before the others hear stop: mpirun ends the whole job once a
    // rank exits with an error, and rank 0 could go before it had spoken.
    let result = result.map_err(said);
    Command::Stop {
        code: i32::from(code),
    }
    .send(&exchange);
    result
}

/// Prints `failure`'s message now and returns it emptied, so that main
/// prints it not again.
fn said(failure: Failure) -> Failure {
    match failure {
        Failure::BadInput(message) => {
            errln!("{message}");
            Failure::BadInput(String::new())
        }
        Failure::Failed(message) => {
            errln!("{message}");
            Failure::Failed(String::new())
        }
    }
}

/// Every rank's verdict on the scene: when one could not load it (or it
/// cannot run split), every rank stops with exit code 2, and the lowest
/// such rank says why.
fn agree_on<T>(exchange: &MpiExchange, verdict: Result<T, Failure>) -> Result<T, Failure> {
    let mine = match verdict {
        Ok(_) => u64::MAX,
        Err(_) => exchange.rank() as u64,
    };
    let first_failing = exchange.min_u64(&[mine])[0];
    let verdict = match (first_failing, verdict) {
        (u64::MAX, verdict) => return verdict,
        (rank, Err(failure)) if rank == exchange.rank() as u64 => Err(said(failure)),
        (_, _) => Err(Failure::BadInput(String::new())),
    };
    // No rank exits (and has mpirun end the job) before the message is out.
    exchange.barrier();
    verdict
}

/// This rank's GPU when the snow runs on GPUs: with `--backend gpu` (or
/// the scene's `[compute] backend = "gpu"`), or `auto` where the node has
/// a hardware GPU that runs the scene. The rank's index among its node's
/// ranks picks the adapter, round (ranks may share one). `None`: the CPU.
/// Every rank must call it.
fn rank_gpu(exchange: &MpiExchange, scene: &Scene) -> Result<Option<Arc<GpuContext>>, Failure> {
    let local = exchange.local_rank();
    let policy = match scene.compute.backend {
        Backend::Cpu => return Ok(None),
        _ if scene.kind.flow().is_some() => return Ok(None),
        Backend::Gpu => AdapterPolicy::AllowSoftware,
        Backend::Auto => {
            let hardware = firn_gpu::choose(AdapterPolicy::HardwareOnly);
            if firn_run::backend::auto_takes(scene, hardware.as_ref()).is_err()
                || GpuSnow::check_splittable(scene).is_err()
            {
                return Ok(None);
            }
            AdapterPolicy::HardwareOnly
        }
    };
    GpuSnow::check_splittable(scene).map_err(|error| gpu_failure(&error))?;
    GpuContext::new_nth(policy, local)
        .map(Some)
        .map_err(|error| gpu_failure(&error))
}

/// A rank other than 0: follows rank 0 to the end and exits with the
/// run's exit code, leaving the message to rank 0.
fn follower(
    exchange: MpiExchange,
    scene: &Scene,
    gpu: Option<Arc<GpuContext>>,
) -> Result<(), Failure> {
    match follow(exchange, scene, gpu) {
        0 => Ok(()),
        code if code == i32::from(crate::EXIT_BAD_INPUT) => Err(Failure::BadInput(String::new())),
        _ => Err(Failure::Failed(String::new())),
    }
}

/// `firn bench` under an MPI launcher: the snowball bench (or with
/// `--flow` the flow bench) split between the ranks; rank 0 prints the
/// speed and, per rank, its particles, the bytes it sent per substep and
/// its milliseconds per substep in exchanges, by phase.
pub fn bench(args: &BenchArgs, mpi: &MpiRun) -> Result<(), Failure> {
    let exchange = mpi.exchange();
    let refused = (args.scene.is_some() || args.render || args.sweep.sweep.is_some())
        .then(|| {
            Failure::BadInput(
                "error: under mpirun, firn bench measures the snowball bench and the flow (--flow) only\n  fix: leave out --scene, --render and --sweep, or run without mpirun".into(),
            )
        });
    agree_on(&exchange, refused.map_or(Ok(()), Err))?;
    if exchange.rank() == 0 {
        outln!("cpu (rank 0): {}", crate::machine::Cpu::detect().describe());
    }
    if args.flow {
        // As without mpirun: the widest path by default, else --simd's.
        let simd = match args.simd {
            SimdChoice::Auto => Ok(Simd::detect()),
            choice => choice.resolve(),
        };
        let simd = agree_on(&exchange, simd)?;
        for &particles in &args.particles {
            let measured = measure_flow_split(&exchange, particles, simd, args);
            let verdict = measured.map(|record| {
                if let Some(parts) = record {
                    print_flow_split(&parts, simd, args.steps);
                }
            });
            agree_on(&exchange, verdict.map_err(said))?;
        }
        return Ok(());
    }
    for &grid in &args.grid {
        for &particles in &args.particles {
            for &transfer in args.transfer.schemes() {
                let scene = snowball_drop(particles, grid, transfer);
                let measured = measure_split(&exchange, scene, args);
                let verdict = measured.map(|record| {
                    if let Some(parts) = record {
                        print_split(&parts, grid, transfer, args.steps);
                    }
                });
                agree_on(&exchange, verdict.map_err(said))?;
            }
        }
    }
    Ok(())
}

/// One rank's measurement: its particles, seconds, bytes sent and
/// exchange seconds by phase over the timed substeps.
struct RankMeasure {
    particles: u64,
    seconds: f64,
    bytes_sent: u64,
    exchange_seconds: [f64; 6],
}

/// Times `args.steps` substeps of `scene` split between the ranks after
/// `args.warmup`; every rank's measurement on rank 0.
fn measure_split(
    exchange: &MpiExchange,
    scene: Scene,
    args: &BenchArgs,
) -> Result<Option<Vec<RankMeasure>>, Failure> {
    let snapshot = match exchange.rank() {
        0 => Some(Snapshot::initial(&scene).map_err(|error| failed(error.into()))?),
        _ => None,
    };
    let mut part = RankSnow::scatter(exchange.clone(), scene, snapshot);
    for _ in 0..args.warmup {
        part.step(f64::MAX).map_err(failed)?;
    }
    let before = part.traffic();
    exchange.barrier();
    let started = Instant::now();
    for _ in 0..args.steps {
        part.step(f64::MAX).map_err(failed)?;
    }
    let seconds = started.elapsed().as_secs_f64();
    let after = part.traffic();
    let mut words = vec![part.owned() as u32];
    words.extend(split_u64(seconds.to_bits()));
    words.extend(split_u64(after.bytes_sent - before.bytes_sent));
    for phase in Phase::ALL {
        let spent =
            after.exchange_seconds[phase as usize] - before.exchange_seconds[phase as usize];
        words.extend(split_u64(spent.to_bits()));
    }
    let parts = exchange.gather(&words);
    Ok(parts.map(|parts| {
        parts
            .iter()
            .map(|w| RankMeasure {
                particles: u64::from(w[0]),
                seconds: f64::from_bits(join_u64(w[1], w[2])),
                bytes_sent: join_u64(w[3], w[4]),
                exchange_seconds: std::array::from_fn(|phase| {
                    f64::from_bits(join_u64(w[5 + 2 * phase], w[6 + 2 * phase]))
                }),
            })
            .collect()
    }))
}

/// One rank's measurement of a split flow: its particles, and over the
/// timed steps its seconds, the seconds it spent sending its part to rank
/// 0 (receiving every part, on rank 0) and the bytes it sent.
struct FlowRankMeasure {
    particles: u64,
    seconds: f64,
    gather_seconds: f64,
    bytes_sent: u64,
}

/// Times `args.steps` steps of the flow bench's scene with `particles`
/// particles split between the ranks after `args.warmup`, each step a
/// frame that ends with rank 0 collecting every part (as a run does); every
/// rank's measurement on rank 0.
fn measure_flow_split(
    exchange: &MpiExchange,
    particles: u32,
    simd: Simd,
    args: &BenchArgs,
) -> Result<Option<Vec<FlowRankMeasure>>, Failure> {
    let scene = crate::bench_flow::scene(particles, "analytic")?;
    let fps = scene.time.fps;
    let own = match exchange.rank() {
        0 => Some(FlowSimulation::new(scene.clone()).map_err(|error| failed(error.into()))?),
        _ => None,
    };
    let snapshot = own.as_ref().map(FlowSimulation::snapshot);
    let (mut part, copy) = RankFlow::start(exchange.clone(), &scene, snapshot.as_ref());
    let mut flow = own.or(copy).expect("every rank holds a copy of the flow");
    flow.set_simd(simd);
    // One frame: this rank's seconds in the gather and the bytes it sent.
    let mut frame = 0u32;
    let mut step = |flow: &mut FlowSimulation| {
        frame += 1;
        part.advance_to(flow, f64::from(frame) / fps);
        let started = Instant::now();
        let sent = part.gather(flow) as u64;
        (started.elapsed().as_secs_f64(), sent)
    };
    for _ in 0..args.warmup {
        step(&mut flow);
    }
    exchange.barrier();
    let started = Instant::now();
    let (mut gather_seconds, mut bytes_sent) = (0.0, 0);
    for _ in 0..args.steps {
        let (seconds, sent) = step(&mut flow);
        gather_seconds += seconds;
        bytes_sent += sent;
    }
    let seconds = started.elapsed().as_secs_f64();
    let own = part.own_particles(&flow) as u64;
    let mut words = Vec::new();
    for value in [own, seconds.to_bits(), gather_seconds.to_bits(), bytes_sent] {
        words.extend(split_u64(value));
    }
    let parts = exchange.gather(&words);
    Ok(parts.map(|parts| {
        parts
            .iter()
            .map(|w| {
                let word = |i: usize| join_u64(w[2 * i], w[2 * i + 1]);
                FlowRankMeasure {
                    particles: word(0),
                    seconds: f64::from_bits(word(1)),
                    gather_seconds: f64::from_bits(word(2)),
                    bytes_sent: word(3),
                }
            })
            .collect()
    }))
}

/// Rank 0's report of a split flow bench: the speed (the slowest rank's
/// time), then a line per rank.
fn print_flow_split(parts: &[FlowRankMeasure], simd: Simd, steps: u32) {
    let particles: u64 = parts.iter().map(|part| part.particles).sum();
    let seconds = parts.iter().map(|part| part.seconds).fold(0.0, f64::max);
    let steps_f = f64::from(steps.max(1));
    outln!(
        "firn mpi flow ranks={} threads={} simd={} particles={particles} steps={steps} seconds={seconds:.3} ns_per_particle_step={:.2} steps_per_s={:.2}",
        parts.len(),
        rayon::current_num_threads(),
        simd.name(),
        seconds * 1e9 / (steps_f * particles as f64),
        steps_f / seconds,
    );
    for (rank, part) in parts.iter().enumerate() {
        outln!(
            "  rank {rank}: particles={} bytes_sent_per_step={:.0} gathering_ms_per_step={:.3}",
            part.particles,
            part.bytes_sent as f64 / steps_f,
            part.gather_seconds * 1e3 / steps_f,
        );
    }
}

/// Rank 0's report of a split bench: the speed (the slowest rank's time),
/// then a line per rank.
fn print_split(parts: &[RankMeasure], grid: u32, transfer: Transfer, steps: u32) {
    let particles: u64 = parts.iter().map(|part| part.particles).sum();
    let seconds = parts.iter().map(|part| part.seconds).fold(0.0, f64::max);
    let substeps = f64::from(steps.max(1));
    outln!(
        "firn mpi ranks={} threads={} transfer={} particles={particles} grid={grid} steps={steps} seconds={seconds:.3} ns_per_particle_step={:.2} substeps_per_s={:.2}",
        parts.len(),
        rayon::current_num_threads(),
        transfer_name(transfer),
        seconds * 1e9 / (substeps * particles as f64),
        substeps / seconds,
    );
    for (rank, part) in parts.iter().enumerate() {
        let phases: Vec<String> = Phase::ALL
            .iter()
            .map(|phase| {
                let ms = part.exchange_seconds[*phase as usize] * 1e3 / substeps;
                format!("{}={ms:.3}", phase.name())
            })
            .collect();
        outln!(
            "  rank {rank}: particles={} bytes_sent_per_substep={:.0} exchange_ms_per_substep: {}",
            part.particles,
            part.bytes_sent as f64 / substeps,
            phases.join(" ")
        );
    }
}
