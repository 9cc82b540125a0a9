//! A split run recorded by rank 0: rank 0 runs [`firn_run::Recording`] as one
//! process would, with a [`RootStepper`] that has every rank step its part
//! ([`RankPart`]: a slab of the snow, or a part of a flow's particles) to the
//! end of each frame. A flow's state is then whole on rank 0, which writes
//! every file as one process would. In a snow run every rank writes its own
//! particles: a VTK piece per frame (rank 0 lists the pieces in the ParaView
//! collection) and a checkpoint piece with their keys (rank 0 writes the
//! manifest naming the pieces once all are written), so `--resume` works on any
//! rank count. Rank 0 also gathers the state of each frame for the caches that
//! are one file of the whole run (the PLY frames in the one-process order, byte
//! for byte; volumes, meshes, pictures). The other ranks [`follow`] rank 0's
//! [`Command`]s.

use std::sync::Arc;

use firn_core::Scene;
use firn_core::scene::CacheFormat;
use firn_gpu::GpuContext;
use firn_run::checkpoint::{self, PieceManifest};
use firn_run::recording::Stepper;
use firn_run::simulation::SolverState;
use firn_run::{Placement, RunDirectory, RunError, Solver};

use crate::exchange::{Exchange, join_u64, split_u64};
use crate::rank::RankSnow;
use crate::rank_flow::RankFlow;
use firn_flow::FlowSimulation;

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
    /// Write the own particles as a VTK piece of frame `frame`.
    Pieces {
        /// The frame.
        frame: u32,
    },
    /// Write the own piece of the checkpoint after frame `frame`.
    Checkpoint {
        /// The frame.
        frame: u32,
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
            Command::Pieces { frame } => vec![3, frame],
            Command::Checkpoint { frame } => vec![4, frame],
        }
    }

    fn from_words(words: &[u32]) -> Command {
        match words {
            [0] => Command::Start,
            [1, high, low] => Command::Advance {
                until: f64::from_bits(join_u64(*high, *low)),
            },
            [2, code] => Command::Stop { code: *code as i32 },
            [3, frame] => Command::Pieces { frame: *frame },
            [4, frame] => Command::Checkpoint { frame: *frame },
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

/// Why a scene cannot run split between `ranks` ranks (under MPI, even
/// one), if it cannot.
pub fn refusal(scene: &Scene, ranks: usize) -> Option<String> {
    use firn_core::scene::Integrator;
    if ranks == 1 || scene.kind.flow().is_some() {
        return None;
    }
    if matches!(scene.solver.integrator, Integrator::SemiImplicit(_)) {
        return Some(format!(
            "scene `{}` uses integrator = \"semi-implicit\", whose linear solve spans the whole grid and does not run split between MPI ranks yet\n  fix: in [solver] set integrator = \"explicit\" (or pass --integrator explicit), or run with one rank",
            scene.name
        ));
    }
    if scene.spindrift().is_some() {
        return Some(format!(
            "scene `{}` has [wind.spindrift], whose drift particles are not split between MPI ranks yet\n  fix: remove the [wind.spindrift] table (the wind still acts on the snow), or run with one rank",
            scene.name
        ));
    }
    None
}

/// One rank's part of a split run: snow by slabs, a flow by particles.
pub enum RankPart<E: Exchange> {
    /// A snow simulation's slab.
    Snow(Box<RankSnow<E>>),
    /// A flow's part of the particles, and the rank's copy of the flow
    /// (`None` on rank 0, which steps the recording's own flow).
    Flow(RankFlow<E>, Option<Box<FlowSimulation>>),
}

impl<E: Exchange> RankPart<E> {
    /// How this rank talks to the others.
    fn exchange(&self) -> &E {
        match self {
            RankPart::Snow(rank) => rank.exchange(),
            RankPart::Flow(rank, _) => rank.exchange(),
        }
    }
}

/// Rank 0's [`Stepper`]: every rank steps its part; rank 0 gathers the
/// state into the recording's solver (a flow's parts straight into its
/// flow).
pub struct RootStepper<E: Exchange> {
    part: RankPart<E>,
    /// Rank 0's GPU, when every rank steps its slab of the snow on one.
    gpu: Option<Arc<GpuContext>>,
}

impl<E: Exchange> RootStepper<E> {
    /// Splits `solver`'s state between the ranks (which wait in
    /// [`follow`]), a snow run's slabs onto each rank's GPU when `gpu`
    /// (this rank's) is given. `solver` runs on the CPU: it holds the state
    /// rank 0 gathers.
    pub fn start(
        exchange: E,
        solver: &Solver,
        gpu: Option<Arc<GpuContext>>,
    ) -> Result<RootStepper<E>, RunError> {
        let scene = solver.scene().clone();
        let state = solver.state()?;
        Command::Start.send(&exchange);
        let part = match (state, &gpu) {
            (SolverState::Flow(snapshot), _) => {
                let (rank, _) = RankFlow::start(exchange, &scene, Some(&snapshot));
                RankPart::Flow(rank, None)
            }
            (SolverState::Snow(snapshot), None) => {
                RankPart::Snow(Box::new(RankSnow::scatter(exchange, scene, Some(snapshot))))
            }
            (SolverState::Snow(snapshot), Some(context)) => RankPart::Snow(Box::new(
                RankSnow::scatter_gpu(exchange, context.clone(), scene, Some(snapshot))?,
            )),
        };
        Ok(RootStepper { part, gpu })
    }
}

impl<E: Exchange> Stepper for RootStepper<E> {
    fn placement(&self) -> Option<Placement> {
        self.gpu.clone().map(Placement::Gpu)
    }

    fn advance_to(&mut self, solver: &mut Solver, until: f64) -> Result<u32, RunError> {
        Command::Advance { until }.send(self.part.exchange());
        match &mut self.part {
            RankPart::Snow(rank) => {
                let substeps = rank.advance_to(until)?;
                let snapshot = rank.gather().expect("rank 0 gathers");
                let scene = solver.scene().clone();
                *solver = Solver::restore(scene, SolverState::Snow(snapshot), &Placement::Cpu)?;
                Ok(substeps)
            }
            RankPart::Flow(rank, _) => {
                let flow = solver
                    .cpu_flow_mut()
                    .expect("a split flow runs on the CPU backend");
                let substeps = rank.advance_to(flow, until);
                rank.gather(flow);
                Ok(substeps)
            }
        }
    }

    fn write_vtk_pieces(
        &mut self,
        index: u32,
        _time: f64,
        run: &RunDirectory,
    ) -> Option<Result<Vec<(u32, String)>, RunError>> {
        // A flow's frames are whole on rank 0, which writes them as one
        // process does.
        let RankPart::Snow(rank) = &mut self.part else {
            return None;
        };
        let scene = rank.scene();
        if !scene.output.formats.contains(&CacheFormat::Vtk) {
            return None;
        }
        Command::Pieces { frame: index }.send(rank.exchange());
        let ranks = rank.exchange().size();
        Some(rank.write_vtk_piece(index, run).map(|_| {
            (0..ranks)
                .map(|rank| (rank as u32, RunDirectory::vtk_piece_name(index, rank)))
                .collect()
        }))
    }

    fn write_checkpoint(
        &mut self,
        frame: u32,
        scene_json: &serde_json::Value,
        run: &RunDirectory,
    ) -> Option<Result<(), RunError>> {
        // A flow's checkpoint is whole on rank 0, as one process's.
        let RankPart::Snow(rank) = &mut self.part else {
            return None;
        };
        Command::Checkpoint { frame }.send(rank.exchange());
        let ranks = rank.exchange().size();
        let written = rank
            .write_checkpoint_piece(frame, scene_json, run)
            .and_then(|(_, particles)| {
                let manifest = PieceManifest {
                    frame,
                    particles,
                    pieces: (0..ranks)
                        .map(|rank| RunDirectory::checkpoint_piece_name(frame, rank))
                        .collect(),
                };
                checkpoint::write_piece_manifest(&manifest, &run.piece_manifest_path())?;
                remove_stale_pieces(run, &manifest);
                Ok(())
            });
        Some(written)
    }
}

/// Removes the checkpoint pieces that `manifest` (written) no longer names
/// (best effort: a stale piece left behind is never read).
fn remove_stale_pieces(run: &RunDirectory, manifest: &PieceManifest) {
    let folder = run.path().join(RunDirectory::checkpoint_piece_name(0, 0));
    let Some(Ok(entries)) = folder.parent().map(std::fs::read_dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let named = path
            .strip_prefix(run.path())
            .ok()
            .and_then(|relative| relative.to_str())
            .is_some_and(|relative| manifest.pieces.iter().any(|piece| piece == relative));
        if !named {
            // Best effort, as said.
            let _ = std::fs::remove_file(path);
        }
    }
}

/// A rank other than 0: does what rank 0 says until it says stop; returns
/// the run's exit code. Its pieces go into the scene's run directory. With
/// `gpu` (this rank's) it steps its slab of a snow run there.
pub fn follow<E: Exchange + Clone>(
    exchange: E,
    scene: &Scene,
    gpu: Option<Arc<GpuContext>>,
) -> i32 {
    let run = RunDirectory::new(scene.output.directory.clone());
    let scene_json = checkpoint::scene_json(scene);
    let mut part: Option<RankPart<E>> = None;
    loop {
        match Command::receive(&exchange) {
            Command::Stop { code } => return code,
            Command::Start => {
                part = if scene.kind.flow().is_some() {
                    let (rank, copy) = RankFlow::start(exchange.clone(), scene, None);
                    Some(RankPart::Flow(rank, copy.map(Box::new)))
                } else if let Some(context) = &gpu {
                    // Every rank learns of a failure to start; rank 0 reports it.
                    RankSnow::scatter_gpu(exchange.clone(), context.clone(), scene.clone(), None)
                        .ok()
                        .map(|rank| RankPart::Snow(Box::new(rank)))
                } else {
                    let rank = RankSnow::scatter(exchange.clone(), scene.clone(), None);
                    Some(RankPart::Snow(Box::new(rank)))
                };
            }
            Command::Advance { until } => match started(&mut part) {
                RankPart::Snow(rank) => {
                    // Every rank learns of a failure; rank 0 reports it.
                    if rank.advance_to(until).is_ok() {
                        rank.gather();
                    }
                }
                RankPart::Flow(rank, flow) => {
                    let flow = flow
                        .as_mut()
                        .expect("a follower holds its copy of the flow");
                    rank.advance_to(flow, until);
                    rank.gather(flow);
                }
            },
            // Every rank learns of a failure; rank 0 reports it.
            Command::Pieces { frame } => {
                let _ = started_snow(&mut part).write_vtk_piece(frame, &run);
            }
            Command::Checkpoint { frame } => {
                let _ = started_snow(&mut part).write_checkpoint_piece(frame, &scene_json, &run);
            }
        }
    }
}

/// A follower's part, which rank 0 starts before any other command.
fn started<E: Exchange>(part: &mut Option<RankPart<E>>) -> &mut RankPart<E> {
    part.as_mut()
        .expect("rank 0 starts the ranks before any other command")
}

/// A follower's snow part: rank 0 sends the commands for pieces only in a
/// snow run.
fn started_snow<E: Exchange>(part: &mut Option<RankPart<E>>) -> &mut RankSnow<E> {
    match started(part) {
        RankPart::Snow(rank) => rank,
        RankPart::Flow(..) => unreachable!("rank 0 sends piece commands in snow runs only"),
    }
}
