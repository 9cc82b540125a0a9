//! A split run's checkpoint pieces (one per MPI rank, each particle with its
//! key) merge by key into the one-process state, and pieces that do not
//! hold every particle exactly once are refused.

mod common;

use firn_mpm::{Particles, Snapshot};
use firn_run::RunDirectory;
use firn_run::checkpoint::{self, PieceManifest, read_pieces, scene_json};
use firn_run::error::CheckpointError;
use firn_run::simulation::SolverState;

/// Particles `places` of `all`, in that order.
fn some_of(all: &Particles, places: &[usize]) -> Particles {
    let order: Vec<u32> = places.iter().map(|&p| p as u32).collect();
    let mut part = all.clone();
    part.permute(&order, &mut firn_mpm::PermuteBuffers::default());
    part
}

/// Writes `all` (taken after frame 0) as two pieces holding the particles
/// of `places` each, with their places as keys, and their manifest; reads
/// them back.
fn round_trip(all: &Snapshot, places: [Vec<usize>; 2]) -> Result<Snapshot, CheckpointError> {
    let scene = common::slab();
    let folder = tempfile::tempdir().unwrap();
    let mut pieces = Vec::new();
    for (rank, places) in places.iter().enumerate() {
        let name = RunDirectory::checkpoint_piece_name(0, rank);
        let path = folder.path().join(&name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        let piece = Snapshot {
            particles: some_of(&all.particles, places),
            ..all.clone()
        };
        let keys: Vec<u64> = places.iter().map(|&p| p as u64).collect();
        checkpoint::write_piece(&piece, &keys, 0, &scene_json(&scene), &path).unwrap();
        pieces.push(name);
    }
    let manifest = PieceManifest {
        frame: 0,
        particles: all.particles.len() as u64,
        pieces,
    };
    let path = folder.path().join("checkpoint-pieces.json");
    checkpoint::write_piece_manifest(&manifest, &path).unwrap();
    let saved = read_pieces(&path, folder.path(), &scene)?;
    match saved.state {
        SolverState::Snow(snapshot) => Ok(snapshot),
        SolverState::Flow(_) => panic!("a snow checkpoint reads back as snow"),
    }
}

#[test]
fn pieces_merge_by_key_into_the_one_process_order() {
    let all = Snapshot::initial(&common::slab()).unwrap();
    let count = all.particles.len();
    assert!(count > 10);
    // Interleaved and out of order, as ranks hold them after migrations.
    let odd: Vec<usize> = (0..count).filter(|p| p % 2 == 1).rev().collect();
    let even: Vec<usize> = (0..count).filter(|p| p % 2 == 0).collect();
    let merged = round_trip(&all, [odd, even]).unwrap();
    let bits = |particles: &Particles| -> Vec<[u32; 3]> {
        particles
            .position
            .iter()
            .map(|x| x.to_array().map(f32::to_bits))
            .collect()
    };
    assert_eq!(bits(&merged.particles), bits(&all.particles));
    assert_eq!(merged.particles.velocity, all.particles.velocity);
    assert_eq!(merged.time.to_bits(), all.time.to_bits());
}

#[test]
fn pieces_that_miss_or_repeat_a_particle_are_refused() {
    let all = Snapshot::initial(&common::slab()).unwrap();
    let count = all.particles.len();
    let first: Vec<usize> = (0..count / 2).collect();
    let missing_one: Vec<usize> = (count / 2 + 1..count).collect();
    let error = round_trip(&all, [first.clone(), missing_one])
        .err()
        .expect("a missing particle is refused")
        .to_string();
    assert!(error.contains("exactly once"), "{error}");
    let repeated: Vec<usize> = (count / 2 - 1..count).collect();
    let error = round_trip(&all, [first, repeated])
        .err()
        .expect("a repeated particle is refused")
        .to_string();
    assert!(error.contains("exactly once"), "{error}");
}
