//! A run split between ranks with a GPU each (here threads of one process
//! sharing Mesa's lavapipe, exchanging as MPI ranks would) gives one GPU
//! process's bits for 1 to 4 ranks (APIC; PIC/FLIP on 3); particles cross
//! the slabs and grid sums are traded. Skipped without a GPU adapter
//! unless `FIRN_REQUIRE_GPU=1`.

mod common;

use std::path::Path;
use std::sync::Arc;
use std::thread;

use common::bits;
use firn_core::Scene;
use firn_core::scene::Transfer;
use firn_gpu::{GpuContext, GpuSnow};
use firn_mpi::{Exchange, RankSnow, RankTraffic, ThreadRanks};
use firn_mpm::Snapshot;

fn crossing(transfer: Transfer) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/crossing.toml");
    let mut scene = Scene::load(&path).unwrap();
    scene.solver.transfer = transfer;
    scene
}

fn one_gpu(context: &Arc<GpuContext>, scene: &Scene, frames: u32) -> Vec<Snapshot> {
    let mut gpu = GpuSnow::new(context.clone(), scene.clone()).unwrap();
    (1..=frames)
        .map(|frame| {
            gpu.advance_to(f64::from(frame) / scene.time.fps).unwrap();
            gpu.snapshot().unwrap()
        })
        .collect()
}

/// The whole state after each frame on rank 0, and each rank's traffic.
fn split_gpus(
    context: &Arc<GpuContext>,
    scene: &Scene,
    ranks: usize,
    frames: u32,
) -> (Vec<Snapshot>, Vec<RankTraffic>) {
    let initial = Snapshot::initial(scene).unwrap();
    let handles: Vec<_> = ThreadRanks::group(ranks)
        .into_iter()
        .map(|exchange| {
            let (scene, context) = (scene.clone(), context.clone());
            let snapshot = (exchange.rank() == 0).then(|| initial.clone());
            thread::spawn(move || {
                let fps = scene.time.fps;
                let mut rank = RankSnow::scatter_gpu(exchange, context, scene, snapshot).unwrap();
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

fn assert_one_gpu_bits(transfer: Transfer, rank_counts: &[usize]) {
    let Some(context) = firn_gpu::context::context_for_tests() else {
        return;
    };
    let scene = crossing(transfer);
    let frames = 3;
    let reference = one_gpu(&context, &scene, frames);
    for &ranks in rank_counts {
        let (states, traffic) = split_gpus(&context, &scene, ranks, frames);
        assert_eq!(states.len(), reference.len());
        for (frame, (split, whole)) in states.iter().zip(&reference).enumerate() {
            let frame = frame + 1;
            assert_eq!(split.steps, whole.steps, "{ranks} ranks, frame {frame}");
            assert!(
                bits(&split.particles) == bits(&whole.particles),
                "{transfer:?}: {ranks} ranks differ from one GPU in frame {frame}"
            );
        }
        if ranks > 1 {
            let migrated: u64 = traffic.iter().map(|t| t.migrated).sum();
            assert!(
                migrated > 0,
                "no particle crossed a slab with {ranks} ranks"
            );
            assert!(
                traffic.iter().any(|t| t.bytes_sent > 0),
                "no sums were traded with {ranks} ranks"
            );
        }
    }
}

#[test]
fn gpu_ranks_give_one_gpu_process_bits_with_apic() {
    assert_one_gpu_bits(Transfer::Apic, &[1, 2, 3, 4]);
}

/// Three ranks only: lavapipe is slow, and the split is the same.
#[test]
fn gpu_ranks_give_one_gpu_process_bits_with_pic_flip() {
    assert_one_gpu_bits(Transfer::PicFlip, &[3]);
}
