//! One rank's share of a split snow run: [`RankSnow`] owns the particles of
//! its slab and steps them with [`firn_mpm::Simulation`], exchanging with the other
//! ranks every substep so that the result is the one process's bit for
//! bit:
//!
//! 1. **migration**: particles whose block left the slab go to its owner;
//!    the slabs move first when the particle counts grew uneven;
//! 2. **renumbering**, on the substeps where one process sorts its array
//!    by block ([`REORDER_INTERVAL`]): each particle's key becomes its
//!    place in that sorted array, the particles of lower ranks first;
//! 3. the substep itself, every block summing its particles in key order
//!    (the rank's `SnowPart` hands the solver the keys, by which it orders
//!    each block's particles, [`firn_mpm::Simulation::step_part`]), hence in the
//!    one-process order; in its scatter the ranks **trade block sums**:
//!    each sends the sums of its blocks next to a neighbour's to that
//!    neighbour (`SlabTrade`, [`firn_mpm::block_sums`]), so every node a
//!    rank reads sums the one process's blocks in the one process's order;
//! 4. **agreement**: a failure anywhere stops every rank with the failing
//!    rank's message (the lowest key first, as one process reports the
//!    lowest index), and the largest speeds, reduced over the ranks, give
//!    every rank the same next Δt.
//!
//! Steps 1 and 2 share one pass of block indices over the own particles
//! (carried through the migration).

use firn_core::Scene;
use firn_io::IoError;
use firn_mpm::binning::block_key;
use firn_mpm::grid::GridLayout;
use firn_mpm::simulation::REORDER_INTERVAL;
use firn_mpm::{Particles, PermuteBuffers, Snapshot};
use firn_run::{RunDirectory, RunError, caches, checkpoint};

use crate::exchange::{Exchange, join_u64, split_u64};
use crate::packing::{KeyedParticles, WORDS_PER_PARTICLE, bytes_to_words, words_to_bytes};
use crate::part::{Slab, SnowPart};
use crate::slabs::{Slabs, neighbour_reach};

mod agreement;
mod gpu;
mod slab_trade;

use slab_trade::SlabTrade;

/// The slabs move when the busiest rank holds this much more than its
/// share of the particles (1.02: 2 % more). A slab may end at any block,
/// so a new cut balances to within about one block's particles.
pub const REBALANCE_ABOVE: f64 = 1.02;

/// The steps of a substep in which a rank exchanges with the others.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// The particle histogram that decides whether the slabs move.
    Balance,
    /// Particles that left the slab.
    Migration,
    /// The particle counts of the renumbering.
    Renumbering,
    /// The block sums of the scatter.
    Sums,
    /// Failures and the next Δt.
    Agreement,
    /// The state gathered on rank 0 (frames, checkpoints).
    Gathering,
}

impl Phase {
    /// Every phase, in substep order.
    pub const ALL: [Phase; 6] = [
        Phase::Balance,
        Phase::Migration,
        Phase::Renumbering,
        Phase::Sums,
        Phase::Agreement,
        Phase::Gathering,
    ];

    /// The phase's name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Balance => "balance",
            Phase::Migration => "migration",
            Phase::Renumbering => "renumbering",
            Phase::Sums => "sums",
            Phase::Agreement => "agreement",
            Phase::Gathering => "gathering",
        }
    }
}

/// What a rank sent and how it balanced, since it started.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RankTraffic {
    /// Substeps taken.
    pub substeps: u64,
    /// Particles this rank sent away because they left its slab.
    pub migrated: u64,
    /// Bytes of particles and block sums this rank sent to other ranks.
    pub bytes_sent: u64,
    /// Times the slabs moved.
    pub rebalances: u64,
    /// Seconds spent in exchanges (transfer and waiting for the others),
    /// by [`Phase`] (in the order of [`Phase::ALL`]).
    pub exchange_seconds: [f64; 6],
}

/// One rank's part of a split snow run.
pub struct RankSnow<E: Exchange> {
    exchange: E,
    part: Slab,
    slabs: Slabs,
    layout: GridLayout,
    buffers: PermuteBuffers,
    traffic: RankTraffic,
}

impl<E: Exchange> RankSnow<E> {
    /// Starts a split run of `scene` from `snapshot`, which rank 0 holds
    /// (the others pass `None`): rank 0 cuts the slabs by particle count
    /// and sends each rank its particles, keyed by their place in the
    /// snapshot, and every rank the rigid bodies. Every rank must call it.
    pub fn scatter(exchange: E, scene: Scene, snapshot: Option<Snapshot>) -> RankSnow<E> {
        let start = Start::receive(&exchange, &scene, snapshot);
        let part = SnowPart::new(
            scene,
            (start.time, start.steps),
            start.bounds,
            start.rigid.as_deref(),
            start.own,
        );
        RankSnow::of(exchange, Slab::Cpu(Box::new(part)), start.slabs)
    }

    /// A rank of `part` between `slabs`, which has sent nothing yet.
    fn of(exchange: E, part: Slab, slabs: Slabs) -> RankSnow<E> {
        let scene = part.scene();
        let layout = GridLayout::new(scene.domain.min, scene.domain.max, scene.domain.cell_size);
        RankSnow {
            exchange,
            part,
            slabs,
            layout,
            buffers: PermuteBuffers::default(),
            traffic: RankTraffic::default(),
        }
    }

    /// How this rank talks to the others.
    pub fn exchange(&self) -> &E {
        &self.exchange
    }

    /// This rank's number.
    pub fn rank(&self) -> usize {
        self.exchange.rank()
    }

    /// The particles this rank owns now.
    pub fn owned(&self) -> usize {
        self.part.keys().len()
    }

    /// The keys of the own particles.
    fn own_keys(&self) -> &[u64] {
        self.part.keys()
    }

    /// The current slabs.
    pub fn slabs(&self) -> &Slabs {
        &self.slabs
    }

    /// What this rank sent, and how often the slabs moved.
    pub fn traffic(&self) -> RankTraffic {
        self.traffic
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        self.part.scene()
    }

    /// Substeps until time `until`, as [`firn_mpm::Simulation::advance_to`]; returns
    /// the number of substeps. Every rank must call it.
    pub fn advance_to(&mut self, until: f64) -> Result<u32, RunError> {
        if let Slab::Gpu(_) = self.part {
            return self.advance_gpu_to(until);
        }
        let mut substeps = 0;
        while until - self.part.time() > 1e-9 {
            self.step(until)?;
            substeps += 1;
        }
        Ok(substeps)
    }

    /// The rank's particles in the CPU solver (a rank on the CPU backend).
    fn cpu_part(&mut self) -> &mut SnowPart {
        match &mut self.part {
            Slab::Cpu(part) => part,
            Slab::Gpu(_) => panic!("a rank on the GPU backend steps by frames (advance_to)"),
        }
    }

    /// One substep of the whole run on the CPU backend, never past
    /// `until`; returns its Δt. Every rank must call it.
    pub fn step(&mut self, until: f64) -> Result<f32, RunError> {
        let own = self.cpu_part().take();
        let blocks = self.blocks(&own.particles);
        self.rebalance(&blocks);
        let (mut own, blocks) = self.migrate(own, blocks);
        if self
            .cpu_part()
            .simulation()
            .steps()
            .is_multiple_of(REORDER_INTERVAL)
        {
            self.renumber(&mut own, &blocks);
        }
        self.cpu_part().set(own);
        let Slab::Cpu(part) = &mut self.part else {
            unreachable!("checked by cpu_part")
        };
        let mut trade = SlabTrade {
            exchange: &self.exchange,
            slabs: &self.slabs,
            layout: self.layout,
            neighbours: self
                .slabs
                .neighbours(self.exchange.rank(), neighbour_reach(self.layout.blocks)),
            traffic: &mut self.traffic,
        };
        let result = part.step(until, &mut trade);
        let dt = self.agree(result)?;
        let (speed, waves) = self.cpu_part().simulation().motion_bounds();
        let bounds = self.timed(Phase::Agreement, |exchange| {
            exchange.max_f32(&[speed, waves])
        });
        self.cpu_part().set_motion_bounds([bounds[0], bounds[1]]);
        self.traffic.substeps += 1;
        Ok(dt)
    }

    /// The whole run's state on rank 0, in the one-process order (`None` on
    /// the other ranks). Every rank must call it.
    pub fn gather(&mut self) -> Option<Snapshot> {
        let own = self.own_snapshot();
        let mut words = Vec::with_capacity(self.owned() * WORDS_PER_PARTICLE);
        for (p, &key) in self.own_keys().iter().enumerate() {
            crate::packing::pack(&own.particles, key, p, &mut words);
        }
        let parts = self.timed(Phase::Gathering, |exchange| exchange.gather(&words))?;
        let mut all = KeyedParticles::default();
        for part in &parts {
            all.unpack(part);
        }
        all.sort_by_key(&mut self.buffers);
        assert!(
            all.keys
                .iter()
                .enumerate()
                .all(|(place, &key)| key == place as u64),
            "the ranks' particles are not each particle exactly once"
        );
        Some(Snapshot {
            particles: all.particles,
            ..own
        })
    }

    /// Writes this rank's own particles as part `rank` of frame `index`'s
    /// VTK cache in `run`, atomically; then every rank learns whether every
    /// rank wrote its piece (a failure anywhere is everyone's, with the
    /// lowest failing rank's message). Returns the piece's path relative
    /// to the run directory. Every rank must call it.
    pub fn write_vtk_piece(&mut self, index: u32, run: &RunDirectory) -> Result<String, RunError> {
        let name = RunDirectory::vtk_piece_name(index, self.rank());
        let own = self.own_snapshot();
        let written = caches::write_snow_vtk_piece(
            own.view(self.scene()),
            self.owned(),
            index,
            &run.path().join(&name),
        );
        self.agree_written(written)?;
        Ok(name)
    }

    /// Writes this rank's piece of the checkpoint after frame `frame` of
    /// the scene `scene_json` in `run`, atomically: its own particles and
    /// their keys. Every rank learns whether every piece was written.
    /// Returns the piece's path relative to the run directory and the
    /// particles of all pieces. Every rank must call it.
    pub fn write_checkpoint_piece(
        &mut self,
        frame: u32,
        scene_json: &serde_json::Value,
        run: &RunDirectory,
    ) -> Result<(String, u64), RunError> {
        let name = RunDirectory::checkpoint_piece_name(frame, self.rank());
        let path = run.path().join(&name);
        let written =
            firn_io::ensure_writable_dir(path.parent().unwrap_or(run.path())).and_then(|()| {
                checkpoint::write_piece(
                    self.own_snapshot().view(self.scene()),
                    self.own_keys(),
                    frame,
                    scene_json,
                    &path,
                )
            });
        self.agree_written(written)?;
        let owned = self.owned() as u64;
        let total = self.timed(Phase::Agreement, |exchange| exchange.sum_u64(&[owned]));
        Ok((name, total[0]))
    }

    /// This rank's own particles and the run's counters, as a snapshot.
    fn own_snapshot(&self) -> Snapshot {
        // Only a GPU lost in the middle of the run fails here; mpirun then
        // ends every rank.
        self.part.snapshot().unwrap_or_else(|error| {
            panic!("rank {} cannot read its particles: {error}", self.rank())
        })
    }

    /// Every rank learns whether every rank's file was `written`; the
    /// failure of the lowest failing rank is everyone's.
    fn agree_written(&mut self, written: Result<(), IoError>) -> Result<(), RunError> {
        let failure = written.as_ref().err().map(|error| (0, error.to_string()));
        match self.first_failure(failure) {
            None => Ok(()),
            Some((rank, _)) if rank == self.rank() => Err(written.expect_err("failed").into()),
            Some((rank, message)) => Err(RunError::Rank {
                rank,
                ranks: self.exchange.size(),
                message,
            }),
        }
    }

    /// Runs `exchange_with` on the exchange, timing it as part of `phase`.
    fn timed<T>(&mut self, phase: Phase, exchange_with: impl FnOnce(&E) -> T) -> T {
        let started = std::time::Instant::now();
        let result = exchange_with(&self.exchange);
        self.traffic.exchange_seconds[phase as usize] += started.elapsed().as_secs_f64();
        result
    }

    /// How far, in block indices, the blocks within one block of a block
    /// lie from it ([`neighbour_reach`]).
    fn reach(&self) -> u32 {
        neighbour_reach(self.layout.blocks)
    }

    /// The ranks this one trades block sums with.
    fn neighbours(&self) -> Vec<usize> {
        self.slabs.neighbours(self.rank(), self.reach())
    }

    /// The block index of every particle.
    fn blocks(&self, particles: &Particles) -> Vec<u32> {
        block_indices(particles, &self.layout)
    }

    /// Moves the slabs when the particle counts per rank grew too uneven
    /// (every rank sees the same counts, so all move them alike). Each
    /// substep the ranks reduce two numbers, the busiest rank's particles
    /// and the total; only when they are over [`REBALANCE_ABOVE`] do they
    /// sum the per-block histogram that places the new cuts.
    fn rebalance(&mut self, blocks: &[u32]) {
        let ranks = self.exchange.size();
        if ranks == 1 {
            return;
        }
        let owned = blocks.len() as u64;
        let [busiest, total] = self.timed(Phase::Balance, |exchange| {
            let busiest = exchange.max_u64(&[owned])[0];
            [busiest, exchange.sum_u64(&[owned])[0]]
        });
        if total == 0 || (busiest * ranks as u64) as f64 <= REBALANCE_ABOVE * total as f64 {
            return;
        }
        let histogram = Slabs::block_histogram(blocks, &self.layout);
        let histogram = self.timed(Phase::Balance, |exchange| exchange.sum_u64(&histogram));
        let now = self.slabs.imbalance(&histogram);
        if now <= REBALANCE_ABOVE {
            return;
        }
        let balanced = Slabs::balanced(&histogram, self.exchange.size());
        if balanced.imbalance(&histogram) < now {
            self.slabs = balanced;
            self.traffic.rebalances += 1;
        }
    }

    /// Sends the particles outside this rank's slab to their owners and
    /// takes in those that entered it, with the block index of each
    /// (`blocks`, those of `own`, kept alike). A leaver's place takes the
    /// last particle and the arrivals go at the end: the array's order is
    /// no one's (the solver orders each block's particles by key). The
    /// migrants go to the neighbours only, unless one went further (a
    /// rebalance, a particle past the neighbour reach) anywhere: then to all.
    fn migrate(
        &mut self,
        mut own: KeyedParticles,
        mut blocks: Vec<u32>,
    ) -> (KeyedParticles, Vec<u32>) {
        let neighbours = self.neighbours();
        let mut outgoing = vec![Vec::new(); self.exchange.size()];
        let mut leavers = Vec::new();
        let mut far = false;
        let slab = self.slabs.blocks(self.exchange.rank());
        for (p, &block) in blocks.iter().enumerate() {
            if slab.contains(&block) {
                continue;
            }
            let owner = self.slabs.owner(block);
            far |= !neighbours.contains(&owner);
            own.pack(p, &mut outgoing[owner]);
            leavers.push(p);
            self.traffic.migrated += 1;
        }
        self.count_sent(&outgoing);
        let incoming = self.timed(Phase::Migration, |exchange| {
            if exchange.max_u64(&[u64::from(far)])[0] == 1 {
                exchange.exchange(outgoing)
            } else {
                exchange.exchange_with(outgoing, &neighbours)
            }
        });
        let stayed = own.len();
        for words in &incoming {
            own.unpack(words);
        }
        let layout = &self.layout;
        blocks.extend(
            own.particles.position[stayed..]
                .iter()
                .map(|&x| block_key(layout, x) as u32),
        );
        for &p in leavers.iter().rev() {
            own.swap_remove(p);
            blocks.swap_remove(p);
        }
        (own, blocks)
    }

    /// Renumbers the particles as one process reorders its array: sorted
    /// by block, and by key within a block (the one process's array is in
    /// key order and its sort is stable), lower ranks' blocks first; a
    /// particle's key becomes its place in that order. `blocks` holds each
    /// particle's block index.
    fn renumber(&mut self, own: &mut KeyedParticles, blocks: &[u32]) {
        let mut order: Vec<u32> = (0..own.len() as u32).collect();
        order.sort_unstable_by_key(|&p| (blocks[p as usize], own.keys[p as usize]));
        own.permute(&order, &mut self.buffers);
        let count = own.len() as u64;
        let first = self.timed(Phase::Renumbering, |exchange| {
            exchange.exclusive_sum_u64(count)
        });
        for (key, place) in own.keys.iter_mut().zip(first..) {
            *key = place;
        }
    }

    /// Adds the particle words in `outgoing` to the bytes sent.
    fn count_sent(&mut self, outgoing: &[Vec<u32>]) {
        let words: usize = outgoing.iter().map(Vec::len).sum();
        self.traffic.bytes_sent += (words * std::mem::size_of::<u32>()) as u64;
    }
}

/// The block index of every particle (as the binning sorts them).
fn block_indices(particles: &Particles, layout: &GridLayout) -> Vec<u32> {
    particles
        .position
        .iter()
        .map(|&x| block_key(layout, x) as u32)
        .collect()
}

/// What rank 0 sends each rank to start: the time, the substeps, the speed
/// bounds and the slabs, then the rank's particles keyed by their place.
fn parts_of(snapshot: &Snapshot, layout: &GridLayout, ranks: usize) -> Vec<Vec<u32>> {
    let particles = &snapshot.particles;
    let blocks = block_indices(particles, layout);
    let histogram = Slabs::block_histogram(&blocks, layout);
    let slabs = Slabs::balanced(&histogram, ranks);
    let mut header = Vec::new();
    header.extend(split_u64(snapshot.time.to_bits()));
    header.extend(split_u64(snapshot.steps));
    header.push(snapshot.max_speed_squared.to_bits());
    header.push(snapshot.max_wave_speed_squared.to_bits());
    header.extend(slabs.to_words());
    let mut parts = vec![header; ranks];
    for (p, &block) in blocks.iter().enumerate() {
        crate::packing::pack(particles, p as u64, p, &mut parts[slabs.owner(block)]);
    }
    parts
}

/// What a rank starts a split run from ([`Start::receive`]).
struct Start {
    time: f64,
    steps: u64,
    /// The largest |v_p|² and squared wave speed of the whole run.
    bounds: [f32; 2],
    slabs: Slabs,
    own: KeyedParticles,
    /// The rigid bodies' saved world, if the scene has bodies.
    rigid: Option<Vec<u8>>,
}

impl Start {
    /// Rank 0 (which holds `snapshot`; the others pass `None`) cuts the
    /// slabs by particle count and sends each rank its particles, keyed by
    /// their place in the snapshot, and every rank the rigid bodies. Every
    /// rank must call it.
    fn receive<E: Exchange>(exchange: &E, scene: &Scene, snapshot: Option<Snapshot>) -> Start {
        let layout = GridLayout::new(scene.domain.min, scene.domain.max, scene.domain.cell_size);
        let outgoing = match &snapshot {
            Some(snapshot) => parts_of(snapshot, &layout, exchange.size()),
            None => vec![Vec::new(); exchange.size()],
        };
        let rigid = snapshot
            .as_ref()
            .and_then(|snapshot| snapshot.rigid.as_deref())
            .map(bytes_to_words)
            .unwrap_or_default();
        let rigid = exchange.broadcast(rigid);
        let message = exchange.exchange(outgoing).swap_remove(0);
        let (header, records) = message.split_at(6 + exchange.size() + 1);
        let mut own = KeyedParticles::default();
        own.unpack(records);
        Start {
            time: f64::from_bits(join_u64(header[0], header[1])),
            steps: join_u64(header[2], header[3]),
            bounds: [f32::from_bits(header[4]), f32::from_bits(header[5])],
            slabs: Slabs::from_words(&header[6..]),
            own,
            rigid: (!rigid.is_empty()).then(|| words_to_bytes(&rigid)),
        }
    }
}
