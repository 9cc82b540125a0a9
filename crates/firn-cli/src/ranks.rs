//! `firn run` under an MPI launcher (the `mpi` feature):
//! `mpirun -np N firn run SCENE` splits the snow between N ranks
//! (firn-mpi). Every rank loads the scene; rank 0 records the run as one
//! process would (the same caches, manifest and checkpoints, byte for
//! byte), the other ranks step their slabs and follow rank 0's commands.

use firn_core::Scene;
use firn_mpi::driver::refusal;
use firn_mpi::mpi_exchange::{MpiExchange, MpiRun};
use firn_mpi::{Command, Exchange, RootStepper, follow};
use firn_run::Placement;

use crate::Failure;
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
    if exchange.rank() != 0 {
        return follower(exchange, &scene);
    }
    let described = format!("the CPU, split between {ranks} MPI ranks");
    let result = record(
        args,
        scene,
        scene_file,
        &Placement::Cpu,
        &described,
        |recording| {
            let stepper = RootStepper::start(exchange.clone(), recording.solver())?;
            Ok(recording.with_stepper(Box::new(stepper)))
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
            eprintln!("{message}");
            Failure::BadInput(String::new())
        }
        Failure::Failed(message) => {
            eprintln!("{message}");
            Failure::Failed(String::new())
        }
    }
}

/// Every rank's verdict on the scene: when one could not load it (or it
/// cannot run split), every rank stops with exit code 2, and the lowest
/// such rank says why.
fn agree_on<T>(exchange: &MpiExchange, verdict: Result<T, Failure>) -> Result<T, Failure> {
    let failed = u32::from(verdict.is_err());
    let failures = exchange.all_gather(&[failed]);
    let first_failing = failures.iter().position(|flags| flags[0] == 1);
    let verdict = match (first_failing, verdict) {
        (None, verdict) => return verdict,
        (Some(rank), Err(failure)) if rank == exchange.rank() => Err(said(failure)),
        (Some(_), _) => Err(Failure::BadInput(String::new())),
    };
    // No rank exits (and has mpirun end the job) before the message is out.
    exchange.all_gather(&[]);
    verdict
}

/// A rank other than 0: follows rank 0 to the end and exits with the
/// run's exit code, leaving the message to rank 0.
fn follower(exchange: MpiExchange, scene: &Scene) -> Result<(), Failure> {
    match follow(exchange, scene) {
        0 => Ok(()),
        code if code == i32::from(crate::EXIT_BAD_INPUT) => Err(Failure::BadInput(String::new())),
        _ => Err(Failure::Failed(String::new())),
    }
}
