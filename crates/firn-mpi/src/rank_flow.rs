//! One rank's part of a split curl-noise flow.
//!
//! A flow's particles never read each other, so it splits without halos:
//! every rank holds a copy of the whole flow and moves only its part of the
//! particles ([`firn_flow::FlowPart`]: chunk c of the particles on rank
//! c mod N), which gives them the bits one process gives them. The copies
//! stay the same size (every rank makes the particles the emitters add), and
//! after each frame rank 0 collects every rank's part into its copy, which
//! is then the state one process would hold: rank 0 writes the frame's
//! caches and checkpoints from it, as one process does. The price of the
//! copies is memory: every rank holds every particle (about 38 bytes each,
//! plus the trails), while the stepping splits N ways.

use firn_core::Scene;
use firn_flow::{FlowPart, FlowPartState, FlowSimulation, FlowSnapshot};
use glam::Vec3;

use crate::exchange::{Exchange, join_u64, split_u64};

/// One rank's part of a split flow: which particles it moves, and how it
/// talks to the others. Its copy of the flow is the caller's (rank 0 steps
/// the recording's own flow in place).
pub struct RankFlow<E: Exchange> {
    exchange: E,
    part: FlowPart,
    /// The message of this rank's part, kept from frame to frame (a fresh
    /// buffer would cost its pages' first touch every frame).
    message: Vec<u32>,
}

impl<E: Exchange> RankFlow<E> {
    /// Starts a split run of `scene`: rank 0 passes the state of the flow
    /// it runs and sends it to every rank; every other rank passes `None`
    /// and gets its copy of the flow back. Every rank must call it.
    pub fn start(
        exchange: E,
        scene: &Scene,
        snapshot: Option<&FlowSnapshot>,
    ) -> (RankFlow<E>, Option<FlowSimulation>) {
        let words = snapshot.map(snapshot_words).unwrap_or_default();
        let words = exchange.broadcast(words);
        let copy = snapshot.is_none().then(|| {
            FlowSimulation::from_snapshot(scene.clone(), snapshot_from_words(&words))
                .expect("rank 0's flow was made from the scene every rank loaded")
        });
        let part = FlowPart::new(exchange.rank(), exchange.size());
        let rank = RankFlow {
            exchange,
            part,
            message: Vec::new(),
        };
        (rank, copy)
    }

    /// How this rank talks to the others.
    pub fn exchange(&self) -> &E {
        &self.exchange
    }

    /// How many of `flow`'s particles this rank moves.
    pub fn own_particles(&self, flow: &FlowSimulation) -> usize {
        self.part.count(flow.len())
    }

    /// Moves this rank's part of `flow` to simulated time `until`; returns
    /// the substeps taken.
    pub fn advance_to(&self, flow: &mut FlowSimulation, until: f64) -> u32 {
        flow.advance_part_to(self.part, until)
    }

    /// Every rank's part collected into rank 0's `flow`, which then holds
    /// the whole flow's state; returns the bytes this rank sent. Every rank
    /// must call it.
    pub fn gather(&mut self, flow: &mut FlowSimulation) -> usize {
        self.message.clear();
        if self.exchange.rank() != 0 {
            write_part(flow, self.part, &mut self.message);
        }
        let sent = self.message.len() * size_of::<u32>();
        let Some(parts) = self.exchange.gather(&self.message) else {
            return sent;
        };
        let ranks = self.exchange.size();
        for (rank, words) in parts.iter().enumerate().skip(1) {
            flow.set_part_state(FlowPart::new(rank, ranks), &read_part(words))
                .expect("every rank's copy of the flow holds the same particles");
        }
        sent
    }
}

/// Appends numbers to a message of 32-bit words: each array after its
/// length, so that what arrives is bit for bit what left.
#[derive(Default)]
struct Writer(Vec<u32>);

impl Writer {
    fn u64(&mut self, value: u64) {
        self.0.extend(split_u64(value));
    }

    fn u32s(&mut self, values: &[u32]) {
        self.u64(values.len() as u64);
        self.0.extend_from_slice(values);
    }

    fn f32s(&mut self, values: &[f32]) {
        self.u64(values.len() as u64);
        self.0.extend_from_slice(bytemuck::cast_slice(values));
    }

    fn vec3s(&mut self, values: &[Vec3]) {
        self.u64(values.len() as u64);
        self.0.extend_from_slice(bytemuck::cast_slice(values));
    }
}

/// Reads what a [`Writer`] wrote, in the same order: the words not read yet.
struct Reader<'a>(&'a [u32]);

impl<'a> Reader<'a> {
    /// The next `count` words.
    fn words(&mut self, count: usize) -> &'a [u32] {
        assert!(self.0.len() >= count, "a flow message is whole");
        let (taken, rest) = self.0.split_at(count);
        self.0 = rest;
        taken
    }

    fn u64(&mut self) -> u64 {
        let words = self.words(2);
        join_u64(words[0], words[1])
    }

    fn u32s(&mut self) -> Vec<u32> {
        let count = self.u64() as usize;
        self.words(count).to_vec()
    }

    fn f32s(&mut self) -> Vec<f32> {
        let count = self.u64() as usize;
        bytemuck::cast_slice(self.words(count)).to_vec()
    }

    fn vec3s(&mut self) -> Vec<Vec3> {
        let count = self.u64() as usize;
        bytemuck::cast_slice(self.words(3 * count)).to_vec()
    }
}

/// A whole flow's state as words.
fn snapshot_words(snapshot: &FlowSnapshot) -> Vec<u32> {
    let mut out = Writer::default();
    out.u64(snapshot.substeps);
    out.u64(snapshot.births.len() as u64);
    for &births in &snapshot.births {
        out.u64(births);
    }
    out.vec3s(&snapshot.positions);
    out.vec3s(&snapshot.velocities);
    out.f32s(&snapshot.ages);
    out.f32s(&snapshot.lifetimes);
    out.u32s(&snapshot.generations);
    out.u32s(&snapshot.emitters);
    out.u32s(&[snapshot.trail_capacity, snapshot.trail_head]);
    out.vec3s(&snapshot.trail_points);
    out.u32s(&snapshot.trail_lengths);
    out.u32s(&snapshot.trail_generations);
    out.0
}

/// The state [`snapshot_words`] wrote.
fn snapshot_from_words(words: &[u32]) -> FlowSnapshot {
    let mut read = Reader(words);
    let substeps = read.u64();
    let emitters = read.u64() as usize;
    let births = (0..emitters).map(|_| read.u64()).collect();
    let positions = read.vec3s();
    let velocities = read.vec3s();
    let ages = read.f32s();
    let lifetimes = read.f32s();
    let generations = read.u32s();
    let emitters = read.u32s();
    let trail = read.u32s();
    FlowSnapshot {
        substeps,
        births,
        positions,
        velocities,
        ages,
        lifetimes,
        generations,
        emitters,
        trail_capacity: trail[0],
        trail_head: trail[1],
        trail_points: read.vec3s(),
        trail_lengths: read.u32s(),
        trail_generations: read.u32s(),
    }
}

/// Appends `part`'s state in `flow` to `words`: each attribute of all its
/// particles in turn (after the particle count), straight from the flow's
/// arrays.
fn write_part(flow: &FlowSimulation, part: FlowPart, words: &mut Vec<u32>) {
    words.extend(split_u64(part.count(flow.len()) as u64));
    append(words, flow, part, |rows| rows.positions);
    append(words, flow, part, |rows| rows.velocities);
    append(words, flow, part, |rows| rows.ages);
    append(words, flow, part, |rows| rows.lifetimes);
    append(words, flow, part, |rows| rows.generations);
    let trail_capacity = flow.trails().map_or(0, |trails| trails.capacity());
    words.extend(split_u64(trail_capacity as u64));
    append(words, flow, part, |rows| rows.trail_points);
    append(words, flow, part, |rows| rows.trail_lengths);
    append(words, flow, part, |rows| rows.trail_generations);
}

/// Appends one attribute of `part`'s particles in `flow` to `words`.
fn append<T: bytemuck::Pod>(
    words: &mut Vec<u32>,
    flow: &FlowSimulation,
    part: FlowPart,
    attribute: for<'a> fn(&FlowPartState<'a>) -> &'a [T],
) {
    for rows in flow.part_rows(part) {
        words.extend_from_slice(bytemuck::cast_slice(attribute(&rows)));
    }
}

/// The part's state [`write_part`] wrote, borrowed from `words`.
fn read_part(words: &[u32]) -> FlowPartState<'_> {
    let mut read = Reader(words);
    let count = read.u64() as usize;
    let positions = bytemuck::cast_slice(read.words(3 * count));
    let velocities = bytemuck::cast_slice(read.words(3 * count));
    let ages = bytemuck::cast_slice(read.words(count));
    let lifetimes = bytemuck::cast_slice(read.words(count));
    let generations = read.words(count);
    let trail_capacity = read.u64() as usize;
    let trails = if trail_capacity > 0 { count } else { 0 };
    FlowPartState {
        positions,
        velocities,
        ages,
        lifetimes,
        generations,
        trail_points: bytemuck::cast_slice(read.words(3 * trail_capacity * trails)),
        trail_lengths: read.words(trails),
        trail_generations: read.words(trails),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_snapshot_crosses_the_wire_bit_for_bit() {
        let snapshot = FlowSnapshot {
            substeps: 1 << 40,
            births: vec![3, u64::MAX],
            positions: vec![Vec3::new(1.0, -0.0, f32::MIN_POSITIVE); 2],
            velocities: vec![Vec3::new(f32::NAN, 2.5, -1e30); 2],
            ages: vec![0.25, 7.0],
            lifetimes: vec![f32::INFINITY, 1.0],
            generations: vec![0, 9],
            emitters: vec![1, 0],
            trail_capacity: 2,
            trail_head: 1,
            trail_points: vec![Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE],
            trail_lengths: vec![1, 2],
            trail_generations: vec![0, u32::MAX],
        };
        let back = snapshot_from_words(&snapshot_words(&snapshot));
        assert_eq!(snapshot_words(&back), snapshot_words(&snapshot));
        assert_eq!(back.trail_points, snapshot.trail_points);
    }

    #[test]
    fn a_part_crosses_the_wire_as_its_rows_one_after_the_other() {
        let scene = Scene::from_toml_str(
            "format = 1\nkind = \"flow\"\n[domain]\nmax = [10.0, 10.0, 10.0]\n[time]\nduration = 1.0\n\
             [flow]\n[[flow.emitters]]\nshape = \"box\"\ncenter = [5.0, 5.0, 5.0]\n\
             size = [10.0, 10.0, 10.0]\ncount = 5000\n\
             [render]\nstyles = [\"trails\"]\ntrail_length = 3\n",
            "part.toml",
        )
        .unwrap();
        let mut flow = FlowSimulation::new(scene).unwrap();
        flow.advance_frame();
        let part = FlowPart::new(1, 2);
        let mut words = Vec::new();
        write_part(&flow, part, &mut words);
        let read = read_part(&words);
        assert_eq!(read.len(), part.count(flow.len()));
        let mut offset = 0;
        for row in flow.part_rows(part) {
            let rows = offset..offset + row.len();
            assert_eq!(&read.positions[rows.clone()], row.positions);
            assert_eq!(&read.velocities[rows.clone()], row.velocities);
            assert_eq!(&read.ages[rows.clone()], row.ages);
            assert_eq!(&read.generations[rows.clone()], row.generations);
            assert_eq!(
                &read.trail_points[rows.start * 3..rows.end * 3],
                row.trail_points
            );
            assert_eq!(&read.trail_lengths[rows], row.trail_lengths);
            offset += row.len();
        }
        assert_eq!(offset, read.len());
        assert!(flow.set_part_state(part, &read).is_ok());
    }
}
