//! A rank with a GPU (`--backend gpu` under mpirun): its particles live in
//! a [`GpuSnow`] part ([`firn_gpu::snow::parts`]) that trades grid sums with
//! the other ranks every substep. The GPU's sums are integers and its
//! other stages work per particle or per node, so which rank holds a
//! particle changes no bit: the particles stay on their rank through a
//! frame (no per-substep round trip of particles), and at each frame's end,
//! when the particles come back from the GPU anyway, those that left the
//! slab go to its owner and the slabs move when the counts grew uneven, as
//! on the CPU ranks. One GPU process never reorders its particles, so a
//! particle's key stays its place in the snapshot the run started from.

use std::sync::Arc;

use firn_core::Scene;
use firn_gpu::snow::parts::{PartSubstep, PartTrade};
use firn_gpu::{GpuContext, GpuError, GpuSnow};
use firn_mpm::{SimulationError, Snapshot};
use firn_run::RunError;

use super::{Phase, RankSnow, RankTraffic, Start};
use crate::exchange::Exchange;
use crate::packing::KeyedParticles;
use crate::part::{GpuPart, Slab};

impl<E: Exchange> RankSnow<E> {
    /// [`RankSnow::scatter`] onto this rank's GPU (`context`). Every rank
    /// learns whether every rank's part could start (the lowest failing
    /// rank's error is everyone's). Every rank must call it.
    pub fn scatter_gpu(
        exchange: E,
        context: Arc<GpuContext>,
        scene: Scene,
        snapshot: Option<Snapshot>,
    ) -> Result<RankSnow<E>, RunError> {
        let start = Start::receive(&exchange, &scene, snapshot);
        let own = Snapshot {
            time: start.time,
            steps: start.steps,
            max_speed_squared: start.bounds[0],
            max_wave_speed_squared: start.bounds[1],
            particles: start.own.particles,
            drift: Default::default(),
            escaped: Default::default(),
            rigid: start.rigid,
        };
        let gpu = GpuSnow::part_from_snapshot(context, scene.clone(), &own);
        let empty = GpuPart {
            gpu: None,
            keys: start.own.keys,
            scene,
        };
        let mut rank = RankSnow::of(exchange, Slab::Gpu(Box::new(empty)), start.slabs);
        let gpu = rank.agree_started(gpu)?;
        rank.gpu_part().gpu = Some(gpu);
        Ok(rank)
    }

    /// Substeps of the whole run on the GPUs until time `until`, then the
    /// migration of the frame's end; returns the number of substeps. Every
    /// rank must call it.
    pub(super) fn advance_gpu_to(&mut self, until: f64) -> Result<u32, RunError> {
        self.gpu().begin_part_frame(until);
        let mut substeps = 0;
        loop {
            let Slab::Gpu(part) = &mut self.part else {
                unreachable!("a rank on the GPU backend")
            };
            let mut trade = GpuTrade {
                exchange: &self.exchange,
                traffic: &mut self.traffic,
            };
            let gpu = part.gpu.as_mut().expect("a started part");
            let result = gpu.part_substep(&mut trade);
            if let PartSubstep::FrameDone = self.agree_gpu(result)? {
                break;
            }
            let (speed, waves) = self.gpu().motion_bounds();
            let bounds = self.timed(Phase::Agreement, |exchange| {
                exchange.max_f32(&[speed, waves])
            });
            self.gpu().set_motion_bounds(bounds[0], bounds[1]);
            self.traffic.substeps += 1;
            substeps += 1;
        }
        self.migrate_gpu()?;
        Ok(substeps)
    }

    /// The rank's part on its GPU.
    fn gpu_part(&mut self) -> &mut GpuPart {
        match &mut self.part {
            Slab::Gpu(part) => part,
            Slab::Cpu(_) => panic!("a rank on the GPU backend"),
        }
    }

    /// The rank's GPU run.
    fn gpu(&mut self) -> &mut GpuSnow {
        self.gpu_part().gpu.as_mut().expect("a started part")
    }

    /// At a frame's end: the particles that left the slab go to its owner
    /// (the slabs first move when the counts grew uneven), and a rank whose
    /// particles changed hands them to its GPU part. Every rank learns
    /// whether every rank's part took them.
    fn migrate_gpu(&mut self) -> Result<(), RunError> {
        let now = self.own_snapshot();
        let keys = std::mem::take(&mut self.gpu_part().keys);
        let held = keys.len();
        let own = KeyedParticles {
            particles: now.particles,
            keys,
        };
        let blocks = self.blocks(&own.particles);
        self.rebalance(&blocks);
        let migrated = self.traffic.migrated;
        let (own, _) = self.migrate(own, blocks);
        let changed = self.traffic.migrated != migrated || own.len() != held;
        self.gpu_part().keys = own.keys;
        let replaced = match changed {
            false => Ok(()),
            true => {
                let snapshot = Snapshot {
                    particles: own.particles,
                    ..now
                };
                self.gpu().replace_particles(&snapshot)
            }
        };
        self.agree_started(replaced)
    }

    /// Every rank learns whether every rank's part `started`; the failure
    /// of the lowest failing rank is everyone's.
    fn agree_started<T>(&mut self, started: Result<T, GpuError>) -> Result<T, RunError> {
        let failure = started.as_ref().err().map(|error| (0, error.to_string()));
        match (self.first_failure(failure), started) {
            (None, started) => Ok(started.expect("no rank failed")),
            (Some((rank, _)), Err(error)) if rank == self.rank() => Err(error.into()),
            (Some((rank, message)), _) => Err(RunError::Rank {
                rank,
                ranks: self.exchange.size(),
                message,
            }),
        }
    }

    /// Every rank learns whether the substep failed anywhere; the failure
    /// of the lowest key (then the lowest rank) is everyone's, a particle
    /// named by its key.
    fn agree_gpu(
        &mut self,
        result: Result<PartSubstep, GpuError>,
    ) -> Result<PartSubstep, RunError> {
        let own_failure = result.as_ref().err().map(|error| self.keyed_gpu(error));
        let failure = own_failure
            .as_ref()
            .map(|(key, error)| (*key, error.to_string()));
        match (self.first_failure(failure), own_failure, result) {
            (None, _, result) => Ok(result.expect("no rank failed")),
            (Some((rank, _)), Some((_, error)), _) if rank == self.rank() => Err(error.into()),
            (Some((rank, message)), _, _) => Err(RunError::Rank {
                rank,
                ranks: self.exchange.size(),
                message,
            }),
        }
    }

    /// `error` with its particle named by key, and that key (0 for a
    /// failure of the whole substep).
    fn keyed_gpu(&self, error: &GpuError) -> (u64, GpuError) {
        match error {
            GpuError::Snow(unstable @ SimulationError::Unstable { .. }) => {
                let (key, keyed) = self.keyed(unstable);
                (key, GpuError::Snow(keyed))
            }
            other => (0, GpuError::Device(other.to_string())),
        }
    }
}

/// A GPU rank's side of the trade of grid sums ([`PartTrade`]), timed as
/// [`Phase::Sums`].
struct GpuTrade<'a, E: Exchange> {
    exchange: &'a E,
    traffic: &'a mut RankTraffic,
}

impl<E: Exchange> GpuTrade<'_, E> {
    /// Runs `exchange_with` on the exchange, counting `words` sent and
    /// the time.
    fn timed<T>(&mut self, words: usize, exchange_with: impl FnOnce(&E) -> T) -> T {
        self.traffic.bytes_sent += (words * std::mem::size_of::<u32>()) as u64;
        let started = std::time::Instant::now();
        let result = exchange_with(self.exchange);
        self.traffic.exchange_seconds[Phase::Sums as usize] += started.elapsed().as_secs_f64();
        result
    }
}

impl<E: Exchange> PartTrade for GpuTrade<'_, E> {
    fn part(&self) -> usize {
        self.exchange.rank()
    }

    fn parts(&self) -> usize {
        self.exchange.size()
    }

    fn all_gather(&mut self, words: &[u32]) -> Vec<Vec<u32>> {
        let sent = words.len() * self.exchange.size();
        self.timed(sent, |exchange| exchange.all_gather(words))
    }

    fn exchange_with(&mut self, outgoing: Vec<Vec<u32>>, partners: &[usize]) -> Vec<Vec<u32>> {
        let sent = outgoing.iter().map(Vec::len).sum();
        self.timed(sent, |exchange| exchange.exchange_with(outgoing, partners))
    }
}
