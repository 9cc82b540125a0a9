//! The flow simulation: determinism across thread counts and code paths,
//! checkpoints, emitters, lifetimes, rebirth and trails.

mod common;

use common::scene;
use firn_core::Scene;
use firn_flow::{FlowError, FlowPart, FlowPartState, FlowSimulation, FlowSnapshot, Simd};
use glam::Vec3;

/// Everything at once: obstacles, drifting noise, RK4, a rate emitter with
/// spread lifetimes and a birth velocity, a count emitter, trails.
const BUSY: &str = "noise_share = 0.6
length_scale = 20.0
background_direction = [1.0, 0.2, 0.0]
background_strength = 6.0
evolution_rate = 0.2
integration = \"rk4\"
substeps = 3
seed = 99

[[flow.obstacles]]
center = [55.0, 50.0, 50.0]
radius = 10.0
influence = 6.0

[[flow.emitters]]
shape = \"disc\"
center = [10.0, 50.0, 50.0]
radius = 8.0
normal = [1.0, 0.0, 0.0]
rate = 3000.0
lifetime = 1.5
lifetime_spread = 0.4
velocity = [10.0, 0.0, 0.0]
velocity_decay = 0.3

[[flow.emitters]]
shape = \"box\"
center = [50.0, 50.0, 50.0]
size = [100.0, 100.0, 100.0]
count = 5000
lifetime = 2.0

[render]
styles = [\"points\", \"trails\"]
trail_length = 8
";

fn busy() -> Scene {
    scene(BUSY, 100.0, 4.0, 20.0)
}

fn run(frames: u32, threads: usize, simd: Simd) -> FlowSnapshot {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut flow = FlowSimulation::new(busy()).unwrap();
        flow.set_simd(simd);
        for _ in 0..frames {
            flow.advance_frame();
        }
        flow.snapshot()
    })
}

fn bits(snapshot: &FlowSnapshot) -> Vec<u32> {
    let mut bits: Vec<u32> = Vec::new();
    for v in snapshot.positions.iter().chain(&snapshot.velocities) {
        bits.extend(v.to_array().map(f32::to_bits));
    }
    bits.extend(snapshot.ages.iter().map(|a| a.to_bits()));
    bits.extend(snapshot.lifetimes.iter().map(|a| a.to_bits()));
    bits.extend(&snapshot.generations);
    for v in &snapshot.trail_points {
        bits.extend(v.to_array().map(f32::to_bits));
    }
    bits
}

#[test]
fn same_seed_same_bits_on_one_or_two_threads() {
    let one = run(20, 1, Simd::detect());
    let two = run(20, 2, Simd::detect());
    assert!(one.positions.len() > 5000);
    assert!(bits(&one) == bits(&two), "1 and 2 threads differ");
    assert_eq!(one, two);
}

#[test]
fn every_code_path_gives_the_same_bits() {
    let portable = run(10, 2, Simd::Portable);
    for simd in [Simd::Avx2, Simd::Avx512] {
        if simd.is_available() {
            assert!(
                bits(&run(10, 2, simd)) == bits(&portable),
                "{simd:?} and portable differ"
            );
        }
    }
}

#[test]
fn another_seed_gives_another_flow() {
    let a = run(5, 2, Simd::detect());
    let mut flow = FlowSimulation::new(scene(
        &BUSY.replace("seed = 99", "seed = 98"),
        100.0,
        4.0,
        20.0,
    ))
    .unwrap();
    for _ in 0..5 {
        flow.advance_frame();
    }
    assert_ne!(a.positions, flow.snapshot().positions);
}

#[test]
fn a_resumed_run_continues_bit_for_bit() {
    let mut straight = FlowSimulation::new(busy()).unwrap();
    for _ in 0..12 {
        straight.advance_frame();
    }
    let mut first = FlowSimulation::new(busy()).unwrap();
    for _ in 0..5 {
        first.advance_frame();
    }
    let mut resumed = FlowSimulation::from_snapshot(busy(), first.snapshot()).unwrap();
    assert_eq!(resumed.time(), first.time());
    for _ in 0..7 {
        resumed.advance_frame();
    }
    assert_eq!(resumed.snapshot(), straight.snapshot());
}

/// A part's state, owned: its runs of particles one after the other.
#[derive(Default)]
struct PartState {
    positions: Vec<Vec3>,
    velocities: Vec<Vec3>,
    ages: Vec<f32>,
    lifetimes: Vec<f32>,
    generations: Vec<u32>,
    trail_points: Vec<Vec3>,
    trail_lengths: Vec<u32>,
    trail_generations: Vec<u32>,
}

impl PartState {
    fn of(flow: &FlowSimulation, part: FlowPart) -> PartState {
        let mut state = PartState::default();
        for rows in flow.part_rows(part) {
            state.positions.extend_from_slice(rows.positions);
            state.velocities.extend_from_slice(rows.velocities);
            state.ages.extend_from_slice(rows.ages);
            state.lifetimes.extend_from_slice(rows.lifetimes);
            state.generations.extend_from_slice(rows.generations);
            state.trail_points.extend_from_slice(rows.trail_points);
            state.trail_lengths.extend_from_slice(rows.trail_lengths);
            state
                .trail_generations
                .extend_from_slice(rows.trail_generations);
        }
        state
    }

    fn borrow(&self) -> FlowPartState<'_> {
        FlowPartState {
            positions: &self.positions,
            velocities: &self.velocities,
            ages: &self.ages,
            lifetimes: &self.lifetimes,
            generations: &self.generations,
            trail_points: &self.trail_points,
            trail_lengths: &self.trail_lengths,
            trail_generations: &self.trail_generations,
        }
    }
}

#[test]
fn parts_stepped_apart_and_collected_give_the_whole_flows_bits() {
    // As firn-mpi's ranks do: every process steps its part of a copy of the
    // flow, and after each frame the first collects the others' parts.
    let mut whole = FlowSimulation::new(busy()).unwrap();
    let parts = 3;
    let mut copies: Vec<FlowSimulation> = (0..parts)
        .map(|_| FlowSimulation::new(busy()).unwrap())
        .collect();
    let frame_time = 1.0 / busy().time.fps;
    for frame in 1..=10 {
        whole.advance_frame();
        let until = f64::from(frame) * frame_time;
        for (part, copy) in copies.iter_mut().enumerate() {
            copy.advance_part_to(FlowPart::new(part, parts), until);
        }
        let (first, others) = copies.split_first_mut().unwrap();
        for (index, copy) in others.iter().enumerate() {
            let part = FlowPart::new(index + 1, parts);
            let state = PartState::of(copy, part);
            first.set_part_state(part, &state.borrow()).unwrap();
        }
        assert!(
            bits(&first.snapshot()) == bits(&whole.snapshot()),
            "frame {frame}: the parts differ from the whole"
        );
        assert_eq!(first.snapshot(), whole.snapshot());
    }
    assert!(whole.len() > 3 * 1024, "every part holds particles");
    let other = PartState::of(&copies[1], FlowPart::new(1, parts));
    let refused = copies[0].set_part_state(FlowPart::new(0, parts), &other.borrow());
    assert!(matches!(refused, Err(FlowError::SnapshotMismatch(_))));
}

#[test]
fn the_initial_snapshot_is_where_a_flow_starts_and_reads_as_one() {
    let scene = busy();
    let initial = FlowSnapshot::initial(&scene).unwrap();
    let flow = FlowSimulation::new(scene.clone()).unwrap();
    assert!(initial == flow.snapshot(), "the flow starts elsewhere");
    assert_eq!(initial.trail_capacity, 8);
    assert!(initial.velocities.iter().all(|v| *v != Vec3::ZERO));
    let (of_snapshot, of_flow) = (initial.view(&scene).unwrap(), flow.view());
    assert_eq!(of_snapshot.time(), of_flow.time());
    assert_eq!(of_snapshot.positions(), flow.positions());
    assert_eq!(of_snapshot.field(), *flow.field());
    let rings = |view: firn_flow::FlowView<'_>| view.trails().map(|t| t.oldest_first());
    assert_eq!(rings(of_snapshot), flow.trails().map(|t| t.oldest_first()));
    assert_eq!(rings(of_snapshot), rings(of_flow));
    assert!(of_snapshot.snapshot() == initial);
}

#[test]
fn a_snapshot_of_another_scene_is_refused() {
    let flow = FlowSimulation::new(busy()).unwrap();
    let mut snapshot = flow.snapshot();
    snapshot.ages.pop();
    assert!(matches!(
        FlowSimulation::from_snapshot(busy(), snapshot),
        Err(FlowError::SnapshotMismatch(_))
    ));
    let snow = Scene::from_toml_str(
        "format = 1\n[domain]\nmax = [1.0, 1.0, 1.0]\ncell_size = 0.1\n[time]\nduration = 1.0\n\
         [[bodies]]\nshape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\nradius = 0.3\n",
        "snow.toml",
    )
    .unwrap();
    assert!(matches!(
        FlowSimulation::new(snow),
        Err(FlowError::NotAFlowScene)
    ));
}

#[test]
fn rate_emitters_follow_their_schedule_and_lives_end() {
    let mut flow = FlowSimulation::new(busy()).unwrap();
    // At t = 0: the 5000 of the count emitter and the first of the rate emitter.
    assert_eq!(flow.len(), 5001);
    flow.advance_to(0.5);
    assert_eq!(flow.time(), 0.5);
    // 3000 per second, one at t = 0: floor(0.5 × 3000) + 1.
    assert_eq!(flow.len(), 5000 + 1501);
    flow.advance_to(3.0);
    // The rate emitter keeps ceil(3000 × 1.5) = 4500 particles.
    assert_eq!(flow.len(), 5000 + 4500);
    let particles = flow.particles();
    let reborn = particles.generations.iter().filter(|g| **g > 0).count();
    assert!(reborn > 4000, "{reborn}");
    for p in 0..flow.len() {
        assert!(particles.ages[p] < particles.lifetimes[p], "particle {p}");
        assert!(particles.ages[p] >= 0.0);
        let life = particles.lifetimes[p];
        if particles.emitters[p] == 0 {
            assert!((0.9..=2.1).contains(&life), "lifetime {life}");
        } else {
            assert_eq!(life, 2.0);
        }
        let x = particles.positions[p];
        assert!(x.cmpge(Vec3::ZERO).all() && x.cmple(Vec3::splat(100.0)).all());
    }
    assert_eq!(flow.ids(), 0..flow.len() as u32);
}

/// Mean x of the disc's particles older than 0.2 s at t = 0.3 s.
fn mean_x_of_early_disc_particles(body: &str) -> f32 {
    let mut flow = FlowSimulation::new(scene(body, 100.0, 4.0, 20.0)).unwrap();
    flow.advance_to(0.3);
    let particles = flow.particles();
    let early: Vec<f32> = (0..flow.len())
        .filter(|p| particles.emitters[*p] == 0 && particles.ages[*p] > 0.2)
        .map(|p| particles.positions[p].x)
        .collect();
    assert!(early.len() > 100);
    early.iter().sum::<f32>() / early.len() as f32
}

#[test]
fn the_birth_velocity_carries_particles_out_of_the_emitter() {
    // 10 m/s fading over 0.3 s adds 3 (1 − e^(−age / 0.3)) ≈ 1.5 to 1.9 m.
    let with = mean_x_of_early_disc_particles(BUSY);
    let without = mean_x_of_early_disc_particles(
        &BUSY.replace("velocity = [10.0, 0.0, 0.0]\nvelocity_decay = 0.3\n", ""),
    );
    assert!(
        with - without > 1.3 && with - without < 2.1,
        "{with} vs {without}"
    );
}

#[test]
fn particles_that_leave_the_domain_are_born_again() {
    // A fast uniform flow along +x: everything leaves through x = 100.
    let body = "noise_share = 0.0\nbackground_strength = 40.0\nsubsteps = 1\n\n\
                [[flow.emitters]]\nshape = \"box\"\ncenter = [50.0, 50.0, 50.0]\n\
                size = [10.0, 10.0, 10.0]\ncount = 500\n";
    let mut flow = FlowSimulation::new(scene(body, 100.0, 10.0, 10.0)).unwrap();
    for _ in 0..20 {
        flow.advance_frame();
        for x in flow.positions() {
            assert!(x.x <= 100.0, "{x}");
        }
    }
    // 4 m per frame from x ≈ 50: each particle left (and came back) at least
    // once in 20 frames, with a new age.
    assert!(flow.generations().iter().all(|g| *g >= 1));
    assert!(flow.ages().iter().all(|a| *a < 2.0));
}

#[test]
fn trails_keep_the_last_frames_oldest_first() {
    let mut flow = FlowSimulation::new(busy()).unwrap();
    let trails = flow.trails().expect("the scene renders trails");
    assert_eq!(trails.capacity(), 8);
    assert_eq!(trails.len(0), 1);
    let mut history: Vec<Vec3> = vec![flow.positions()[0]];
    for _ in 0..11 {
        flow.advance_frame();
        history.push(flow.positions()[0]);
    }
    let trails = flow.trails().unwrap();
    // Particle 0 (the disc's first, living at least 0.9 s) lived all 0.55 s.
    assert_eq!(flow.generations()[0], 0);
    let kept: Vec<Vec3> = trails.iter(0).collect();
    assert_eq!(kept, history[history.len() - 8..].to_vec());
    assert_eq!(*kept.last().unwrap(), flow.positions()[0]);

    // A particle born again in the last frame has a fresh trail of one.
    let previous = flow.generations().to_vec();
    flow.advance_frame();
    let reborn = (0..flow.len())
        .filter(|p| *p < previous.len() && flow.generations()[*p] != previous[*p])
        .collect::<Vec<_>>();
    assert!(!reborn.is_empty());
    let trails = flow.trails().unwrap();
    for p in reborn {
        assert_eq!(trails.len(p), 1);
        assert_eq!(trails.iter(p).next(), Some(flow.positions()[p]));
    }
    // Trails are off unless the scene renders them.
    let plain = scene(
        &BUSY.replace("styles = [\"points\", \"trails\"]", "styles = [\"points\"]"),
        100.0,
        4.0,
        20.0,
    );
    assert!(FlowSimulation::new(plain).unwrap().trails().is_none());
}

#[test]
fn colors_by_position_follow_the_seed() {
    let flow = FlowSimulation::new(busy()).unwrap();
    let colors = flow.colors_by_position();
    assert_eq!(colors.len(), flow.len());
    for (color, x) in colors.iter().zip(flow.positions()) {
        let expected = ((*x - 50.0).abs() / 50.0).to_array();
        for c in 0..3 {
            assert!((color[c] - expected[c]).abs() < 1e-6);
        }
    }
}
