//! A run recorded into its directory and read back: frame caches, the
//! manifest, pictures handed in by the front door, checkpoints, and a run
//! resumed to the same bytes as one never interrupted.

mod common;

use std::ops::ControlFlow;
use std::path::Path;

use firn_core::Scene;
use firn_core::scene::{ColorBy, Spindrift, Wind};
use firn_io::RunStatus;
use firn_run::error::{ReadRunError, ResumeError};
use firn_run::recording::{FrameToPicture, Observer, Progress};
use firn_run::{Placement, Recording, RunDirectory, Solver};

/// An observer that remembers what it was told and "draws" a file name,
/// and stops the run after the frame `stop_after` if set.
#[derive(Default)]
struct Notes {
    pictured: Vec<(u32, usize)>,
    /// Per picture, the triangles of the surface handed in with it.
    surfaces: Vec<Option<usize>>,
    recorded: Vec<Progress>,
    animated: Vec<u32>,
    stop_after: Option<u32>,
}

impl Observer for Notes {
    fn pictures(&mut self, frame: &FrameToPicture<'_>) -> Result<Vec<String>, String> {
        self.pictured
            .push((frame.index, frame.particles.positions.len()));
        self.surfaces
            .push(frame.surface.map(|surface| surface.triangles.len()));
        Ok(vec![format!("images/test/{}.png", frame.index)])
    }

    fn frame_recorded(&mut self, progress: &Progress) -> ControlFlow<()> {
        self.recorded.push(*progress);
        if self.stop_after == Some(progress.frame) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }

    fn animations(&mut self, _scene: &Scene, frames: &[u32]) -> Result<Vec<String>, String> {
        self.animated = frames.to_vec();
        Ok(vec!["images/test.gif".into()])
    }
}

/// Starts `scene` on the CPU in `path` and records frame 0.
fn start(scene: Scene, path: &Path, observer: &mut Notes) -> Recording {
    let run = RunDirectory::new(path);
    run.create(&scene).expect("the run directory is created");
    let solver = Solver::new(scene, &Placement::Cpu).expect("the scene starts");
    Recording::start(solver, run, None, observer).expect("frame 0 is recorded")
}

#[test]
fn a_recorded_frame_cache_reads_back_as_written() {
    let folder = tempfile::tempdir().unwrap();
    let mut notes = Notes::default();
    let mut recording = start(common::slab(), folder.path(), &mut notes);
    recording
        .run_to(3, &mut notes)
        .expect("three frames are recorded");
    assert_eq!(recording.frame(), 3);
    let frames: Vec<u32> = notes
        .recorded
        .iter()
        .map(|progress| progress.frame)
        .collect();
    assert_eq!(frames, [1, 2, 3]);
    assert!(notes.pictured.is_empty(), "pictures are off in the scene");

    let run = RunDirectory::new(folder.path());
    assert!(RunDirectory::holds_run(folder.path()));
    assert!(run.checkpoint_path().is_file() && run.collection_path().is_file());
    let read = run.read().expect("the run reads back");
    assert_eq!(read.scene.name, "slab");
    assert_eq!(read.manifest.status, RunStatus::Running);
    let indices: Vec<u32> = read.manifest.frames.iter().map(|f| f.index).collect();
    assert_eq!(indices, [0, 1, 2, 3]);
    let last = &read.manifest.frames[3];
    assert_eq!(
        last.files,
        [
            RunDirectory::cache_name(firn_core::scene::CacheFormat::Ply, 3),
            RunDirectory::cache_name(firn_core::scene::CacheFormat::Vtk, 3)
        ]
    );
    let cached = run.read_frame(last).expect("the frame's cache reads back");
    assert_eq!(cached.path(), folder.path().join("ply/frame_00003.ply"));
    let particles = recording
        .solver()
        .host_particles(ColorBy::Density)
        .expect("on the CPU");
    let bits = |positions: &[glam::Vec3]| -> Vec<[u32; 3]> {
        positions
            .iter()
            .map(|x| x.to_array().map(f32::to_bits))
            .collect()
    };
    let positions = cached.positions().expect("x, y and z are cached");
    assert_eq!(bits(&positions), bits(particles.positions));
    assert_eq!(cached.masses(), particles.masses);
    let density = cached
        .color_values(ColorBy::Density)
        .expect("density is cached");
    assert_eq!(density, particles.values);
    assert_eq!(cached.color_values(ColorBy::Uniform), Ok(None));
}

/// A run resumed by fewer MPI ranks, or by one process, rewrites each frame
/// in fewer pieces: the pieces the earlier run wrote beyond them go, as
/// nothing lists them any more.
#[test]
fn a_frame_rewritten_whole_leaves_no_stale_pieces() {
    let folder = tempfile::tempdir().unwrap();
    let vtk = folder.path().join("vtk");
    std::fs::create_dir_all(&vtk).unwrap();
    let stale = [1, 2].map(|part| RunDirectory::vtk_piece_name(2, part));
    let other_frame = RunDirectory::vtk_piece_name(9, 1);
    for name in stale.iter().chain([&other_frame]) {
        std::fs::write(folder.path().join(name), "stale").unwrap();
    }
    let mut notes = Notes::default();
    let mut recording = start(common::slab(), folder.path(), &mut notes);
    recording
        .run_to(2, &mut notes)
        .expect("two frames are recorded");
    for name in &stale {
        assert!(
            !folder.path().join(name).exists(),
            "{name} is left beside the whole frame"
        );
    }
    assert!(folder.path().join("vtk/frame_00002.vtp").is_file());
    assert!(
        folder.path().join(&other_frame).exists(),
        "a frame not rewritten keeps its pieces"
    );
}

#[test]
fn pictures_and_animations_come_from_the_observer() {
    let folder = tempfile::tempdir().unwrap();
    let mut scene = common::slab();
    scene.render.enabled = true;
    let mut notes = Notes::default();
    let mut recording = start(scene, folder.path(), &mut notes);
    let last = recording.solver().scene().time.frame_count();
    recording
        .run_to(last, &mut notes)
        .expect("the run finishes");
    let count = recording.solver().particle_count();
    let expected: Vec<(u32, usize)> = (0..=last).map(|index| (index, count)).collect();
    assert_eq!(notes.pictured, expected);
    assert_eq!(notes.animated, (0..=last).collect::<Vec<_>>());
    let read = RunDirectory::new(folder.path()).read().unwrap();
    assert_eq!(read.manifest.status, RunStatus::Finished);
    assert_eq!(read.manifest.animations, ["images/test.gif"]);
    assert_eq!(read.manifest.frames[2].images, ["images/test/2.png"]);
    assert_eq!(notes.surfaces, vec![None; notes.pictured.len()]);
}

#[test]
fn the_pictures_get_the_surface_the_mesh_cache_made() {
    let folder = tempfile::tempdir().unwrap();
    let mut scene = common::slab();
    scene.render.enabled = true;
    scene.output.formats = vec![firn_core::scene::CacheFormat::Mesh];
    scene.domain.cell_size = 0.05;
    let mut notes = Notes::default();
    let mut recording = start(scene, folder.path(), &mut notes);
    recording.run_to(1, &mut notes).expect("the run finishes");
    let name = RunDirectory::cache_name(firn_core::scene::CacheFormat::Mesh, 1);
    let bytes = std::fs::read(folder.path().join(name)).unwrap();
    let header = String::from_utf8_lossy(&bytes[..bytes.len().min(400)]);
    let faces: usize = header
        .lines()
        .find_map(|line| line.strip_prefix("element face "))
        .expect("the mesh cache has faces")
        .parse()
        .unwrap();
    assert!(faces > 0, "the slab has a surface");
    assert_eq!(notes.surfaces.len(), 2, "frames 0 and 1");
    assert!(notes.surfaces.iter().all(Option::is_some));
    assert_eq!(notes.surfaces[1], Some(faces), "frame 1's surface");
}

#[test]
fn a_resumed_run_writes_the_same_bytes_as_an_uninterrupted_one() {
    let (whole, parts) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let scene = common::slab();
    let last = scene.time.frame_count();
    let mut notes = Notes::default();
    start(scene.clone(), whole.path(), &mut notes)
        .run_to(last, &mut notes)
        .unwrap();
    start(scene.clone(), parts.path(), &mut notes)
        .run_to(3, &mut notes)
        .unwrap();
    let mut resumed = Recording::resume(scene, RunDirectory::new(parts.path()), &Placement::Cpu)
        .expect("the run resumes");
    assert_eq!(resumed.frame(), 3);
    resumed.run_to(last, &mut notes).unwrap();
    for file in [
        format!("ply/frame_{last:05}.ply"),
        format!("vtk/frame_{last:05}.vtp"),
        "particles.pvd".into(),
        "checkpoint.firnckpt".into(),
    ] {
        let read = |folder: &Path| std::fs::read(folder.join(&file)).unwrap();
        assert!(read(whole.path()) == read(parts.path()), "{file} differs");
    }
    let manifest = RunDirectory::new(parts.path()).read().unwrap().manifest;
    assert_eq!(manifest.frames.len() as u32, last + 1);
    assert_eq!(manifest.status, RunStatus::Finished);
}

#[test]
fn a_run_stopped_by_its_observer_resumes_to_the_same_bytes() {
    let (whole, parts) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let mut scene = common::slab();
    scene.render.enabled = true;
    let last = scene.time.frame_count();
    let mut notes = Notes::default();
    start(scene.clone(), whole.path(), &mut notes)
        .run_to(last, &mut notes)
        .unwrap();
    // Frame 3 is between two of the scene's checkpoints (every second frame).
    let mut stopping = Notes {
        stop_after: Some(3),
        ..Notes::default()
    };
    let mut stopped = start(scene.clone(), parts.path(), &mut stopping);
    stopped
        .run_to(last, &mut stopping)
        .expect("a stop is not a failure");
    assert_eq!(stopped.frame(), 3);
    assert!(
        stopping.animated.is_empty(),
        "a stopped run is not animated"
    );
    assert!(!parts.path().join("ply/frame_00004.ply").exists());
    let manifest = RunDirectory::new(parts.path()).read().unwrap().manifest;
    assert_eq!(manifest.status, RunStatus::Running);
    assert_eq!(manifest.frames.len(), 4);
    assert!(manifest.animations.is_empty());

    let mut resumed = Recording::resume(scene, RunDirectory::new(parts.path()), &Placement::Cpu)
        .expect("the stopped run resumes");
    assert_eq!(
        resumed.frame(),
        3,
        "from a checkpoint of the frame it stopped at"
    );
    resumed.run_to(last, &mut notes).unwrap();
    for index in 1..=last {
        let file = format!("ply/frame_{index:05}.ply");
        let read = |folder: &Path| std::fs::read(folder.join(&file)).unwrap();
        assert!(read(whole.path()) == read(parts.path()), "{file} differs");
    }
    let manifest = RunDirectory::new(parts.path()).read().unwrap().manifest;
    assert_eq!(manifest.status, RunStatus::Finished);
    assert_eq!(manifest.frames.len() as u32, last + 1);
}

#[test]
fn a_run_resumes_only_from_its_own_checkpoint() {
    let folder = tempfile::tempdir().unwrap();
    let scene = common::slab();
    let run = RunDirectory::new(folder.path());
    let missing = Recording::resume(scene.clone(), run.clone(), &Placement::Cpu);
    assert!(matches!(missing, Err(ResumeError::NoCheckpoint { .. })));
    let mut notes = Notes::default();
    start(scene.clone(), folder.path(), &mut notes)
        .run_to(2, &mut notes)
        .unwrap();
    let mut other = scene;
    other.solver.gravity *= 2.0;
    let differs = Recording::resume(other, run, &Placement::Cpu);
    assert!(matches!(differs, Err(ResumeError::SceneDiffers { .. })));
}

#[test]
fn a_folder_without_a_run_says_how_to_fix_it() {
    let folder = tempfile::tempdir().unwrap();
    assert!(!RunDirectory::holds_run(folder.path()));
    let error = RunDirectory::new(folder.path())
        .read()
        .err()
        .expect("no run");
    assert!(matches!(error, ReadRunError::Manifest { .. }));
    assert!(
        error
            .to_string()
            .contains("fix: pass the directory of a run made by `firn run`")
    );
}

#[test]
fn a_flow_frame_caches_its_velocities_and_ages() {
    let folder = tempfile::tempdir().unwrap();
    let mut notes = Notes::default();
    let mut recording = start(common::flow(), folder.path(), &mut notes);
    recording.run_to(2, &mut notes).unwrap();
    let run = recording.run_directory();
    let read = run.read().unwrap();
    let cached = run.read_frame(&read.manifest.frames[2]).unwrap();
    let particles = recording
        .solver()
        .host_particles(ColorBy::Speed)
        .expect("on the CPU");
    assert_eq!(cached.positions().as_deref(), Some(particles.positions));
    assert_eq!(cached.color_values(ColorBy::Speed), Ok(particles.values));
    assert_eq!(cached.color_values(ColorBy::Density), Err("density"));
}

/// The slab as loose powder in a gale with spindrift.
fn blown_slab() -> Scene {
    let mut scene = common::slab();
    scene.materials[0].density = 100.0;
    scene.wind = Some(Wind {
        spindrift: Some(Spindrift {
            rate: 20.0,
            ..Spindrift::default()
        }),
        ..Wind::uniform(glam::Vec3::X, 8.0)
    });
    scene
}

#[test]
fn a_resumed_run_with_spindrift_writes_the_same_bytes_and_keeps_the_mass() {
    let (whole, parts) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let scene = blown_slab();
    let last = scene.time.frame_count();
    let mut notes = Notes::default();
    start(scene.clone(), whole.path(), &mut notes)
        .run_to(last, &mut notes)
        .unwrap();
    start(scene.clone(), parts.path(), &mut notes)
        .run_to(3, &mut notes)
        .unwrap();
    let mut resumed = Recording::resume(scene, RunDirectory::new(parts.path()), &Placement::Cpu)
        .expect("the run resumes");
    resumed.run_to(last, &mut notes).unwrap();
    for file in [
        format!("ply/frame_{last:05}.ply"),
        format!("drift/frame_{last:05}.ply"),
        format!("drift/frame_{last:05}.vtp"),
        "checkpoint.firnckpt".into(),
    ] {
        let read = |folder: &Path| std::fs::read(folder.join(&file)).unwrap();
        assert!(read(whole.path()) == read(parts.path()), "{file} differs");
    }
    let manifest = RunDirectory::new(parts.path()).read().unwrap().manifest;
    let balances: Vec<_> = manifest
        .frames
        .iter()
        .map(|frame| frame.mass.expect("a mass balance per frame"))
        .collect();
    let start_mass = balances[0].snow;
    assert_eq!(balances[0].drift_particles, 0);
    // Each sum is taken in particle order and read back from JSON, so the
    // totals agree to rounding (the exact multiset test is firn-mpm's).
    for balance in &balances {
        assert!(
            (balance.total - start_mass).abs() <= 1e-12 * start_mass,
            "{balance:?} against {start_mass}"
        );
        let sum = balance.snow + balance.drift + balance.escaped;
        assert!((sum - balance.total).abs() <= 1e-12 * start_mass);
        assert_eq!(
            balance.snow_particles + balance.drift_particles + balance.escaped_particles,
            balances[0].snow_particles
        );
    }
    let end = balances.last().unwrap();
    assert!(end.drift_particles > 0, "nothing drifts: {end:?}");
    assert!(
        manifest.frames[last as usize]
            .files
            .contains(&format!("drift/frame_{last:05}.ply"))
    );
    let drift =
        firn_io::read_ply(&parts.path().join(format!("drift/frame_{last:05}.ply"))).unwrap();
    assert_eq!(
        drift.floats("mass").unwrap().len() as u64,
        end.drift_particles
    );
}

#[test]
fn a_snow_checkpoint_without_drift_still_loads() {
    let folder = tempfile::tempdir().unwrap();
    let scene = common::slab();
    let mut notes = Notes::default();
    start(scene.clone(), folder.path(), &mut notes)
        .run_to(2, &mut notes)
        .unwrap();
    let path = RunDirectory::new(folder.path()).checkpoint_path();
    let mut checkpoint = firn_io::Checkpoint::read(&path).unwrap();
    checkpoint
        .arrays
        .retain(|(name, _)| !name.starts_with("drift_"));
    if let Some(meta) = checkpoint.meta.as_object_mut() {
        meta.remove("escaped_count");
        meta.remove("escaped_mass_bits");
    }
    checkpoint.write(&path).unwrap();
    let mut resumed = Recording::resume(scene, RunDirectory::new(folder.path()), &Placement::Cpu)
        .expect("a checkpoint from before spindrift resumes");
    assert_eq!(resumed.frame(), 2);
    resumed.run_to(3, &mut notes).unwrap();
}

/// A split run's checkpoint pieces (one per MPI rank, each particle with
/// its key) merge by key into the one-process state, and pieces that do not
/// hold every particle exactly once are refused.
mod checkpoint_pieces {
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
        let scene = super::common::slab();
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
            checkpoint::write_piece(piece.view(&scene), &keys, 0, &scene_json(&scene), &path)
                .unwrap();
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
        let all = Snapshot::initial(&super::common::slab()).unwrap();
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
        let all = Snapshot::initial(&super::common::slab()).unwrap();
        let count = all.particles.len();
        let first: Vec<usize> = (0..count / 2).collect();
        let missing_one: Vec<usize> = (count / 2 + 1..count).collect();
        let error = round_trip(&all, [first.clone(), missing_one])
            .expect_err("a missing particle is refused")
            .to_string();
        assert!(error.contains("exactly once"), "{error}");
        let repeated: Vec<usize> = (count / 2 - 1..count).collect();
        let error = round_trip(&all, [first, repeated])
            .expect_err("a repeated particle is refused")
            .to_string();
        assert!(error.contains("exactly once"), "{error}");
    }
}

#[test]
fn the_manifest_records_each_colliders_pose_per_frame() {
    let folder = tempfile::tempdir().unwrap();
    let mut scene = common::slab();
    let spin = glam::Vec3::new(0.0, 2.0, 0.0);
    scene.colliders.push(
        firn_core::scene::Collider::cuboid(glam::Vec3::new(0.5, 0.05, 0.5), glam::Vec3::splat(0.1))
            .moving_and_spinning(glam::Vec3::new(0.1, 0.0, 0.0), spin),
    );
    let mut notes = Notes::default();
    let mut recording = start(scene, folder.path(), &mut notes);
    recording.run_to(2, &mut notes).expect("the run goes on");
    let read = RunDirectory::new(folder.path()).read().unwrap();
    for frame in &read.manifest.frames {
        let [pose] = frame.colliders[..] else {
            panic!("one pose per collider: {:?}", frame.colliders);
        };
        let t = frame.time as f32;
        assert!(
            (pose.position[0] - (0.5 + 0.1 * t)).abs() < 1e-6,
            "{pose:?}"
        );
        let turned = glam::Quat::from_array(pose.rotation);
        let expected = glam::Quat::from_rotation_y(2.0 * t);
        assert!(
            turned.dot(expected).abs() > 1.0 - 1e-6,
            "{turned:?} at {t} s"
        );
    }
}

#[test]
fn the_manifest_records_each_rigid_bodys_pose_per_frame() {
    let folder = tempfile::tempdir().unwrap();
    let scene = common::box_on_slab();
    let start_rotation = scene.rigid_bodies[0].rotation;
    // The same scene stepped frame by frame outside a recording.
    let mut alone = firn_mpm::Simulation::new(scene.clone()).unwrap();
    let mut notes = Notes::default();
    let mut recording = start(scene, folder.path(), &mut notes);
    recording.run_to(2, &mut notes).expect("the run goes on");
    let read = RunDirectory::new(folder.path()).read().unwrap();
    let frames = &read.manifest.frames;
    assert_eq!(frames.len(), 3);
    for frame in frames {
        if frame.index > 0 {
            alone.advance_to(f64::from(frame.index) / 24.0).unwrap();
        }
        let [pose] = frame.rigid_bodies[..] else {
            panic!("one pose per body: {:?}", frame.rigid_bodies);
        };
        let [body] = alone.rigid_bodies()[..] else {
            panic!("one body")
        };
        assert_eq!(pose.position, body.position.to_array());
        assert_eq!(pose.rotation, body.rotation.to_array());
        assert_eq!(pose.velocity, body.velocity.to_array());
        assert_eq!(pose.angular_velocity, body.angular_velocity.to_array());
    }
    let (first, last) = (&frames[0].rigid_bodies[0], &frames[2].rigid_bodies[0]);
    assert_eq!(first.position, [0.45, 0.4, 0.5]);
    assert_eq!(first.rotation, start_rotation.to_array());
    assert!(last.position[1] < first.position[1] - 0.05, "{last:?}");
    let turned = glam::Quat::from_array(last.rotation).angle_between(start_rotation);
    assert!(turned > 0.1, "turned by {turned} rad: {last:?}");
    assert!(
        read.manifest.frames.iter().all(|f| f.colliders.is_empty()),
        "no colliders"
    );
}
