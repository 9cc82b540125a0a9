//! A run split between ranks (here threads of one process, exchanging as
//! MPI ranks would) gives the one process's bits for 1, 2, 3 and 4 ranks,
//! both transfer schemes, with wind; every particle is kept exactly once.

mod common;

use std::path::Path;
use std::thread;

use common::bits;
use firn_core::Scene;
use firn_core::scene::{Transfer, Wind};
use firn_mpi::{Exchange, RankSnow, ThreadRanks};
use firn_mpm::{Simulation, Snapshot};

fn crossing(transfer: Transfer, wind: bool) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/crossing.toml");
    let mut scene = Scene::load(&path).unwrap();
    scene.solver.transfer = transfer;
    if wind {
        scene.wind = Some(Wind::uniform(glam::Vec3::new(-1.0, 0.3, 0.0), 15.0));
    }
    scene
}

/// The whole state after each of `frames` frames, split between `ranks`
/// ranks, and each rank's traffic.
fn split_run(
    scene: &Scene,
    ranks: usize,
    frames: u32,
) -> (Vec<Snapshot>, Vec<firn_mpi::RankTraffic>) {
    let initial = Snapshot::initial(scene).unwrap();
    let handles: Vec<_> = ThreadRanks::group(ranks)
        .into_iter()
        .map(|exchange| {
            let scene = scene.clone();
            let snapshot = (exchange.rank() == 0).then(|| initial.clone());
            thread::spawn(move || {
                let fps = scene.time.fps;
                let mut rank = RankSnow::scatter(exchange, scene, snapshot);
                let mut states = Vec::new();
                for frame in 1..=frames {
                    rank.advance_to(f64::from(frame) / fps).unwrap();
                    states.extend(rank.gather());
                }
                (states, rank.traffic())
            })
        })
        .collect();
    let mut results: Vec<_> = handles.into_iter().map(|h| h.join().unwrap()).collect();
    let traffic = results.iter().map(|(_, t)| *t).collect();
    (std::mem::take(&mut results[0].0), traffic)
}

fn one_process(scene: &Scene, frames: u32) -> Vec<Snapshot> {
    let mut simulation = Simulation::new(scene.clone()).unwrap();
    (1..=frames)
        .map(|frame| {
            simulation
                .advance_to(f64::from(frame) / scene.time.fps)
                .unwrap();
            simulation.snapshot()
        })
        .collect()
}

fn assert_same_bits(scene: &Scene, frames: u32, label: &str) {
    let reference = one_process(scene, frames);
    let initial_mass: f64 = reference[0]
        .particles
        .mass
        .iter()
        .map(|&m| f64::from(m))
        .sum();
    for ranks in 1..=4 {
        let (states, traffic) = split_run(scene, ranks, frames);
        assert_eq!(states.len(), reference.len());
        for (frame, (split, whole)) in states.iter().zip(&reference).enumerate() {
            assert_eq!(split.particles.len(), whole.particles.len());
            let mass: f64 = split.particles.mass.iter().map(|&m| f64::from(m)).sum();
            assert_eq!(mass, initial_mass, "{label}: mass changed");
            assert_eq!(
                split.steps,
                whole.steps,
                "{label}, {ranks} ranks, frame {}",
                frame + 1
            );
            assert!(
                bits(&split.particles) == bits(&whole.particles),
                "{label}: {ranks} ranks differ from one process in frame {}",
                frame + 1
            );
            assert_eq!(
                split.max_speed_squared.to_bits(),
                whole.max_speed_squared.to_bits()
            );
        }
        if ranks > 1 {
            let migrated: u64 = traffic.iter().map(|t| t.migrated).sum();
            assert!(
                migrated > 0,
                "{label}: no particle crossed a slab boundary with {ranks} ranks"
            );
            // The balls meet in the middle: the slabs must follow them.
            assert!(
                traffic.iter().all(|t| t.rebalances > 0),
                "{label}: the slabs never moved"
            );
        }
    }
}

#[test]
fn split_runs_give_the_one_process_bits_with_pic_flip() {
    assert_same_bits(&crossing(Transfer::PicFlip, false), 4, "pic-flip");
}

#[test]
fn split_runs_give_the_one_process_bits_with_apic_and_wind() {
    assert_same_bits(&crossing(Transfer::Apic, true), 3, "apic with wind");
}

/// The crossing scene with a free box the right snowball hits on its way.
fn crossing_with_a_box() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/crossing.toml");
    let text = std::fs::read_to_string(path).unwrap().replace(
        "[render]",
        "[[rigid_bodies]]\nshape = \"box\"\ncenter = [0.72, 0.3, 0.2]\nsize = [0.1, 0.1, 0.1]\nrotation = [0.0, 30.0, 10.0]\ndensity = 400.0\n\n[render]",
    );
    let mut scene = Scene::from_toml_str(&text, "crossing-with-a-box").unwrap();
    scene.solver.transfer = Transfer::Apic;
    scene
}

#[test]
fn split_runs_give_the_one_process_bits_with_a_rigid_body() {
    let scene = crossing_with_a_box();
    let frames = 3;
    let reference = one_process(&scene, frames);
    // The snow pushes the box: by the last frame the right ball has
    // carried it 4 cm or more along −x (alone it would only fall).
    let body = Simulation::from_snapshot(scene.clone(), reference[2].clone())
        .unwrap()
        .rigid_bodies()[0];
    assert!(
        body.position.x < 0.68,
        "the snow did not push the box: {body:?}"
    );
    for ranks in 1..=4 {
        let (states, _) = split_run(&scene, ranks, frames);
        for (frame, (split, whole)) in states.iter().zip(&reference).enumerate() {
            let frame = frame + 1;
            assert!(
                bits(&split.particles) == bits(&whole.particles),
                "{ranks} ranks: the snow differs from one process in frame {frame}"
            );
            assert!(
                split.rigid.is_some() && split.rigid == whole.rigid,
                "{ranks} ranks: the box differs from one process in frame {frame}"
            );
        }
    }
}

/// What does not run split yet is refused on several ranks with the table
/// to change, and runs on one.
#[test]
fn spindrift_and_semi_implicit_are_refused_on_several_ranks() {
    let mut drifting = crossing(Transfer::Apic, true);
    if let Some(wind) = drifting.wind.as_mut() {
        wind.spindrift = Some(firn_core::scene::Spindrift::default());
    }
    let message = firn_mpi::driver::refusal(&drifting, 2).expect("spindrift is refused");
    assert!(message.contains("[wind.spindrift]"), "{message}");
    assert!(message.contains("fix:"), "{message}");
    assert_eq!(firn_mpi::driver::refusal(&drifting, 1), None);
    assert_eq!(
        firn_mpi::driver::refusal(&crossing(Transfer::Apic, true), 2),
        None
    );
}

#[test]
fn a_split_run_that_blows_up_names_the_one_process_particle() {
    // A fixed step far past the elastic limit: the snow blows up, many
    // particles at once, on every rank. One process
    // names the lowest index among them; a split run must name the same
    // particle (the lowest key), whatever the order of a rank's array.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/crossing.toml");
    let text = std::fs::read_to_string(path)
        .unwrap()
        .replace("step = \"adaptive\"", "step = \"fixed\"")
        .replace("cfl = 0.4\n", "")
        .replace("dt = 2e-3", "dt = 3e-2");
    let scene = Scene::from_toml_str(&text, "unstable").unwrap();
    let until = scene.time.duration;
    let expected = Simulation::new(scene.clone())
        .unwrap()
        .advance_to(until)
        .expect_err("the one process blows up")
        .to_string();
    assert!(expected.contains("particle"), "{expected}");
    for ranks in 2..=3 {
        let initial = Snapshot::initial(&scene).unwrap();
        let handles: Vec<_> = ThreadRanks::group(ranks)
            .into_iter()
            .map(|exchange| {
                let scene = scene.clone();
                let snapshot = (exchange.rank() == 0).then(|| initial.clone());
                thread::spawn(move || {
                    let mut rank = RankSnow::scatter(exchange, scene, snapshot);
                    rank.advance_to(until)
                        .expect_err("every rank stops")
                        .to_string()
                })
            })
            .collect();
        let messages: Vec<String> = handles.into_iter().map(|h| h.join().unwrap()).collect();
        assert!(
            messages.iter().all(|message| message.contains(&expected)),
            "{ranks} ranks: {messages:?}, one process: {expected}"
        );
    }
}
