//! A flow split between ranks (threads of one process, exchanging as MPI
//! ranks would) gives the one process's bits after every frame, for 1 to 4
//! ranks: every particle, its age, life and generation, and its trail.

use std::path::Path;
use std::thread;

use firn_core::Scene;
use firn_flow::{FlowSimulation, FlowSnapshot};
use firn_mpi::{Exchange, RankFlow, ThreadRanks};

fn stream() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/stream.toml");
    Scene::load(&path).unwrap()
}

/// The whole state on rank 0 after each of `frames` frames, split between
/// `ranks` ranks.
fn split_run(scene: &Scene, ranks: usize, frames: u32) -> Vec<FlowSnapshot> {
    let handles: Vec<_> = ThreadRanks::group(ranks)
        .into_iter()
        .map(|exchange| {
            let scene = scene.clone();
            thread::spawn(move || {
                let root = exchange.rank() == 0;
                let own = root.then(|| FlowSimulation::new(scene.clone()).unwrap());
                let snapshot = own.as_ref().map(FlowSimulation::snapshot);
                let (mut rank, copy) = RankFlow::start(exchange, &scene, snapshot.as_ref());
                let mut flow = own.or(copy).unwrap();
                let mut states = Vec::new();
                for frame in 1..=frames {
                    rank.advance_to(&mut flow, f64::from(frame) / scene.time.fps);
                    rank.gather(&mut flow);
                    if root {
                        states.push(flow.snapshot());
                    }
                }
                states
            })
        })
        .collect();
    let mut results: Vec<_> = handles.into_iter().map(|h| h.join().unwrap()).collect();
    assert!(
        results[1..].iter().all(Vec::is_empty),
        "only rank 0 gathers"
    );
    results.swap_remove(0)
}

fn one_process(scene: &Scene, frames: u32) -> Vec<FlowSnapshot> {
    let mut flow = FlowSimulation::new(scene.clone()).unwrap();
    (1..=frames)
        .map(|frame| {
            flow.advance_to(f64::from(frame) / scene.time.fps);
            flow.snapshot()
        })
        .collect()
}

/// Every number's bits (so that NaN or −0 could not hide a difference).
fn bits(snapshot: &FlowSnapshot) -> Vec<u32> {
    let mut bits = Vec::new();
    for v in snapshot
        .positions
        .iter()
        .chain(&snapshot.velocities)
        .chain(&snapshot.trail_points)
    {
        bits.extend(v.to_array().map(f32::to_bits));
    }
    bits.extend(
        snapshot
            .ages
            .iter()
            .chain(&snapshot.lifetimes)
            .map(|a| a.to_bits()),
    );
    bits.extend(&snapshot.generations);
    bits.extend(&snapshot.trail_lengths);
    bits.extend(&snapshot.trail_generations);
    bits
}

#[test]
fn split_flows_give_the_one_process_bits_every_frame() {
    let scene = stream();
    let frames = 8;
    let whole = one_process(&scene, frames);
    let last = whole.last().unwrap();
    assert!(last.positions.len() > 4 * 1024, "every rank has a part");
    assert!(
        last.generations.iter().any(|g| *g > 0),
        "some particles were born again"
    );
    assert!(last.trail_capacity > 0, "trails are kept");
    for ranks in 1..=4 {
        let split = split_run(&scene, ranks, frames);
        assert_eq!(split.len(), whole.len());
        for (frame, (parts, one)) in split.iter().zip(&whole).enumerate() {
            assert!(
                bits(parts) == bits(one),
                "frame {} differs with {ranks} ranks",
                frame + 1
            );
            assert_eq!(parts.births, one.births);
            assert_eq!(parts.substeps, one.substeps);
        }
    }
}

#[test]
fn flows_are_not_refused_on_several_ranks() {
    assert_eq!(firn_mpi::driver::refusal(&stream(), 3), None);
}
