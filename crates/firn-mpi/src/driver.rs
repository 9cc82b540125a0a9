//! A split run recorded by rank 0: rank 0 runs [`firn_run::Recording`] as
//! one process would, with a [`RootStepper`] that has every rank step its
//! slab to the end of each frame and gathers the whole state back for the
//! frame's caches and checkpoints (so they are the one process's, byte for
//! byte, and `--resume` works with any rank count). The other ranks
//! [`follow`] rank 0's [`Command`]s.

use firn_core::Scene;
use firn_run::recording::Stepper;
use firn_run::simulation::SolverState;
use firn_run::{Placement, RunError, Solver};

use crate::exchange::{Exchange, join_u64, split_u64};
use crate::rank::RankSnow;

/// What rank 0 tells the other ranks to do next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// Take a part of the run ([`RankSnow::scatter`]).
    Start,
    /// Step to simulated time `until`, then send the state to rank 0.
    Advance {
        /// The end of the frame.
        until: f64,
    },
    /// The run is over; exit with `code`.
    Stop {
        /// The run's exit code.
        code: i32,
    },
}

impl Command {
    fn to_words(self) -> Vec<u32> {
        match self {
            Command::Start => vec![0],
            Command::Advance { until } => {
                let [high, low] = split_u64(until.to_bits());
                vec![1, high, low]
            }
            Command::Stop { code } => vec![2, code as u32],
        }
    }

    fn from_words(words: &[u32]) -> Command {
        match words {
            [0] => Command::Start,
            [1, high, low] => Command::Advance {
                until: f64::from_bits(join_u64(*high, *low)),
            },
            [2, code] => Command::Stop { code: *code as i32 },
            other => panic!("rank 0 sent an unknown command {other:?}"),
        }
    }

    /// Rank 0 sends `self` to every rank.
    pub fn send<E: Exchange>(self, exchange: &E) {
        exchange.broadcast(self.to_words());
    }

    /// The command rank 0 sends next.
    pub fn receive<E: Exchange>(exchange: &E) -> Command {
        Command::from_words(&exchange.broadcast(Vec::new()))
    }
}

/// Why a scene cannot run split between `ranks` ranks, if it cannot.
pub fn refusal(scene: &Scene, ranks: usize) -> Option<String> {
    use firn_core::scene::{Integrator, SceneKind};
    if ranks == 1 {
        return None;
    }
    if !matches!(scene.kind, SceneKind::Snow) {
        return Some(format!(
            "scene `{}` is a flow scene; only snow runs split between MPI ranks\n  fix: run it without mpirun (its particles are independent: one process is fast)",
            scene.name
        ));
    }
    if matches!(scene.solver.integrator, Integrator::SemiImplicit(_)) {
        return Some(format!(
            "scene `{}` uses integrator = \"semi-implicit\", whose linear solve spans the whole grid and does not run split between MPI ranks yet\n  fix: in [solver] set integrator = \"explicit\" (or pass --integrator explicit), or run with one rank",
            scene.name
        ));
    }
    if scene
        .wind
        .as_ref()
        .is_some_and(|wind| wind.spindrift.is_some())
    {
        return Some(format!(
            "scene `{}` has [wind.spindrift], whose drift particles are not split between MPI ranks yet\n  fix: remove the [wind.spindrift] table (the wind still acts on the snow), or run with one rank",
            scene.name
        ));
    }
    None
}

/// Rank 0's [`Stepper`]: every rank steps its slab, rank 0 gathers the
/// state into the recording's solver.
pub struct RootStepper<E: Exchange> {
    rank: RankSnow<E>,
}

impl<E: Exchange> RootStepper<E> {
    /// Splits `solver`'s state between the ranks (which wait in
    /// [`follow`]). `solver` runs on the CPU.
    pub fn start(exchange: E, solver: &Solver) -> Result<RootStepper<E>, RunError> {
        let SolverState::Snow(snapshot) = solver.state()? else {
            return Err(RunError::Unsupported(
                "only snow runs split between MPI ranks",
            ));
        };
        Command::Start.send(&exchange);
        let rank = RankSnow::scatter(exchange, solver.scene().clone(), Some(snapshot));
        Ok(RootStepper { rank })
    }

    /// Rank 0's part.
    pub fn rank(&self) -> &RankSnow<E> {
        &self.rank
    }
}

impl<E: Exchange> Stepper for RootStepper<E> {
    fn advance_to(&mut self, solver: &mut Solver, until: f64) -> Result<u32, RunError> {
        Command::Advance { until }.send(self.rank.exchange());
        let substeps = self.rank.advance_to(until)?;
        let snapshot = self.rank.gather().expect("rank 0 gathers");
        let scene = solver.scene().clone();
        *solver = Solver::restore(scene, SolverState::Snow(snapshot), &Placement::Cpu)?;
        Ok(substeps)
    }
}

/// A rank other than 0: does what rank 0 says until it says stop; returns
/// the run's exit code.
pub fn follow<E: Exchange + Clone>(exchange: E, scene: &Scene) -> i32 {
    let mut part: Option<RankSnow<E>> = None;
    loop {
        match Command::receive(&exchange) {
            Command::Stop { code } => return code,
            Command::Start => {
                part = Some(RankSnow::scatter(exchange.clone(), scene.clone(), None));
            }
            Command::Advance { until } => {
                let rank = part
                    .as_mut()
                    .expect("rank 0 starts the ranks before stepping");
                // Every rank learns of a failure; rank 0 reports it.
                if rank.advance_to(until).is_ok() {
                    rank.gather();
                }
            }
        }
    }
}
