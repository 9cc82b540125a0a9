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

/// One rank's part of a split flow.
pub struct RankFlow<E: Exchange> {
    exchange: E,
    simulation: FlowSimulation,
    part: FlowPart,
}

impl<E: Exchange> RankFlow<E> {
    /// Starts a split run of `scene` from `snapshot`, which rank 0 holds
    /// (the others pass `None`): rank 0 sends every rank the whole state.
    /// Every rank must call it.
    pub fn start(exchange: E, scene: Scene, snapshot: Option<FlowSnapshot>) -> RankFlow<E> {
        let words = snapshot.as_ref().map(snapshot_words).unwrap_or_default();
        let words = exchange.broadcast(words);
        let snapshot = snapshot.unwrap_or_else(|| snapshot_from_words(&words));
        let simulation = FlowSimulation::from_snapshot(scene, snapshot)
            .expect("rank 0's flow was made from the scene every rank loaded");
        let part = FlowPart::new(exchange.rank(), exchange.size());
        RankFlow {
            exchange,
            simulation,
            part,
        }
    }

    /// How this rank talks to the others.
    pub fn exchange(&self) -> &E {
        &self.exchange
    }

    /// This rank's copy of the flow (current in its own part only, except
    /// on rank 0 right after [`RankFlow::gather`]).
    pub fn simulation(&self) -> &FlowSimulation {
        &self.simulation
    }

    /// Moves this rank's part to simulated time `until`; returns the
    /// substeps taken.
    pub fn advance_to(&mut self, until: f64) -> u32 {
        self.simulation.advance_part_to(self.part, until)
    }

    /// Every rank's part collected on rank 0: the whole flow's state there,
    /// `None` on the others. Every rank must call it.
    pub fn gather(&mut self) -> Option<FlowSnapshot> {
        let words = if self.exchange.rank() == 0 {
            Vec::new()
        } else {
            part_words(&self.simulation.part_state(self.part))
        };
        let parts = self.exchange.gather(words)?;
        let ranks = self.exchange.size();
        for (rank, words) in parts.iter().enumerate().skip(1) {
            let state = part_from_words(words);
            self.simulation
                .set_part_state(FlowPart::new(rank, ranks), &state)
                .expect("every rank's copy of the flow holds the same particles");
        }
        Some(self.simulation.snapshot())
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
        self.0.extend(values.iter().map(|v| v.to_bits()));
    }

    fn vec3s(&mut self, values: &[Vec3]) {
        self.u64(values.len() as u64);
        for v in values {
            self.0.extend(v.to_array().map(f32::to_bits));
        }
    }
}

/// Reads what a [`Writer`] wrote, in the same order.
struct Reader<'a>(std::slice::Iter<'a, u32>);

impl Reader<'_> {
    fn word(&mut self) -> u32 {
        *self.0.next().expect("a flow message is whole")
    }

    fn u64(&mut self) -> u64 {
        let high = self.word();
        join_u64(high, self.word())
    }

    fn u32s(&mut self) -> Vec<u32> {
        let count = self.u64() as usize;
        (0..count).map(|_| self.word()).collect()
    }

    fn f32s(&mut self) -> Vec<f32> {
        self.u32s().into_iter().map(f32::from_bits).collect()
    }

    fn vec3s(&mut self) -> Vec<Vec3> {
        let count = self.u64() as usize;
        (0..count)
            .map(|_| Vec3::new(self.f32(), self.f32(), self.f32()))
            .collect()
    }

    fn f32(&mut self) -> f32 {
        f32::from_bits(self.word())
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
    let mut read = Reader(words.iter());
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

/// A part's state as words.
fn part_words(state: &FlowPartState) -> Vec<u32> {
    let mut out = Writer::default();
    out.vec3s(&state.positions);
    out.vec3s(&state.velocities);
    out.f32s(&state.ages);
    out.f32s(&state.lifetimes);
    out.u32s(&state.generations);
    out.vec3s(&state.trail_points);
    out.u32s(&state.trail_lengths);
    out.u32s(&state.trail_generations);
    out.0
}

/// The state [`part_words`] wrote.
fn part_from_words(words: &[u32]) -> FlowPartState {
    let mut read = Reader(words.iter());
    FlowPartState {
        positions: read.vec3s(),
        velocities: read.vec3s(),
        ages: read.f32s(),
        lifetimes: read.f32s(),
        generations: read.u32s(),
        trail_points: read.vec3s(),
        trail_lengths: read.u32s(),
        trail_generations: read.u32s(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn states_cross_the_wire_bit_for_bit() {
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
        let part = FlowPartState {
            positions: snapshot.positions.clone(),
            velocities: snapshot.velocities.clone(),
            ages: snapshot.ages.clone(),
            lifetimes: snapshot.lifetimes.clone(),
            generations: snapshot.generations.clone(),
            trail_points: snapshot.trail_points.clone(),
            trail_lengths: snapshot.trail_lengths.clone(),
            trail_generations: snapshot.trail_generations.clone(),
        };
        let back = part_from_words(&part_words(&part));
        assert_eq!(part_words(&back), part_words(&part));
        assert_eq!(back.generations, part.generations);
    }
}
