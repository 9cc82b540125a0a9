//! One solver type for every simulation: counters, particles on the host,
//! live parameter changes, states that continue bit for bit through a
//! checkpoint file, and the options and figures a benchmark needs.

mod common;

use std::path::Path;

use firn_core::Scene;
use firn_core::math::lanes::Simd;
use firn_core::scene::{ColorBy, SceneKind};
use firn_gpu::snow::Scatter;
use firn_run::checkpoint::{self, same_physics, scene_json};
use firn_run::simulation::HostState;
use firn_run::{Placement, Solver, SolverOptions};

/// Writes `solver`'s state as a checkpoint after `frame` at `path` and
/// returns the file's bytes.
fn checkpoint_bytes(solver: &Solver, path: &Path) -> Vec<u8> {
    let state = solver.state().expect("a CPU state");
    let scene = scene_json(solver.scene());
    let view = state.view(solver.scene()).expect("a view of the state");
    checkpoint::write(view, solver.frame(), &scene, path).expect("the checkpoint is written");
    std::fs::read(path).expect("the checkpoint is read")
}

/// Runs `scene` on the CPU through `frames` frames in one go, and through a
/// checkpoint after `split`; returns both final checkpoints.
fn uninterrupted_and_resumed(scene: Scene, split: u32, frames: u32) -> (Vec<u8>, Vec<u8>) {
    let folder = tempfile::tempdir().expect("a temporary folder");
    let mut whole = Solver::new(scene.clone(), &Placement::Cpu).expect("the scene starts");
    for _ in 0..frames {
        whole.advance_frame().expect("the scene steps");
    }
    let mut first = Solver::new(scene.clone(), &Placement::Cpu).expect("the scene starts");
    for _ in 0..split {
        first.advance_frame().expect("the scene steps");
    }
    let path = folder.path().join("split.firnckpt");
    checkpoint_bytes(&first, &path);
    let steps = first.steps();
    drop(first);
    let saved = checkpoint::read(&path, &scene).expect("the checkpoint reads back");
    assert_eq!(saved.frame, split);
    assert!(same_physics(&saved.scene_json, &scene_json(&scene)));
    let mut resumed =
        Solver::restore(scene, saved.state, &Placement::Cpu).expect("the state continues");
    assert_eq!((resumed.frame(), resumed.steps()), (split, steps));
    for _ in split..frames {
        resumed.advance_frame().expect("the scene steps");
    }
    assert_eq!(resumed.frame(), frames);
    (
        checkpoint_bytes(&whole, &folder.path().join("whole.firnckpt")),
        checkpoint_bytes(&resumed, &folder.path().join("resumed.firnckpt")),
    )
}

#[test]
fn a_snow_checkpoint_resumes_to_the_same_bits_as_an_uninterrupted_run() {
    let (whole, resumed) = uninterrupted_and_resumed(common::slab(), 2, 4);
    assert!(whole == resumed, "the resumed run's state differs");
}

#[test]
fn a_checkpoint_with_a_deforming_collider_resumes_to_the_same_bits() {
    use firn_core::scene::{Collider, ColliderGeometry, MeshSequenceCollider};
    use glam::Vec3;
    // A block under the slab rising 5 cm per mesh frame, one file per
    // frame: the resumed run rebuilds the fields of the frames it is
    // between from the files alone.
    let folder = tempfile::tempdir().expect("a temporary folder");
    for frame in 0..6 {
        let lift = 0.05 * frame as f32;
        let corners: String = (0..8)
            .map(|i| {
                let at = |bit: u32, low: f32, high: f32| if i & bit == 0 { low } else { high };
                let (x, y, z) = (at(1, 0.3, 0.7), at(2, lift, 0.1 + lift), at(4, 0.3, 0.7));
                format!("v {x} {y} {z}\n")
            })
            .collect();
        let faces = "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
        let file = folder.path().join(format!("lift_{:02}.obj", frame + 1));
        std::fs::write(file, corners + faces).expect("a mesh file");
    }
    let lifting = MeshSequenceCollider::load(
        folder.path().join("lift_##.obj"),
        (Vec3::ONE, Vec3::ZERO, None),
        (24.0, 0.0),
        0.05,
        MeshSequenceCollider::band_for(0.1, 0.05),
    )
    .expect("the sequence loads");
    let mut scene = common::slab();
    scene
        .colliders
        .push(Collider::new(ColliderGeometry::MeshSequence(Box::new(
            lifting,
        ))));
    let (whole, resumed) = uninterrupted_and_resumed(scene, 2, 5);
    assert!(whole == resumed, "the resumed run's state differs");
}

#[test]
fn a_flow_checkpoint_resumes_to_the_same_bits_as_an_uninterrupted_run() {
    let (whole, resumed) = uninterrupted_and_resumed(common::flow(), 3, 6);
    assert!(whole == resumed, "the resumed flow's state differs");
}

#[test]
fn a_solver_moves_between_threads_and_is_shared() {
    fn send_and_sync<T: Send + Sync>() {}
    send_and_sync::<Solver>();
}

#[test]
fn counters_follow_the_frames() {
    let mut solver = Solver::new(common::flow(), &Placement::Cpu).unwrap();
    assert_eq!((solver.frame(), solver.steps(), solver.time()), (0, 0, 0.0));
    assert!(!solver.on_gpu());
    assert_eq!(solver.placement().name(), "cpu");
    let taken = solver.advance_frame().unwrap();
    assert!(taken > 0);
    assert_eq!(solver.frame(), 1);
    assert_eq!(solver.steps(), u64::from(taken));
    assert!(
        (solver.time() - 1.0 / 30.0).abs() < 1e-9,
        "{}",
        solver.time()
    );
    solver.advance_to(0.25).unwrap();
    assert_eq!(solver.frame(), 7);
}

#[test]
fn particles_are_read_on_the_host_with_the_colour_quantity() {
    let mut snow = Solver::new(common::slab(), &Placement::Cpu).unwrap();
    snow.advance_frame().unwrap();
    let count = snow.particle_count();
    let particles = snow.host_particles(ColorBy::Density).expect("on the CPU");
    assert_eq!(particles.positions.len(), count);
    assert_eq!(particles.masses.map(<[f32]>::len), Some(count));
    assert_eq!(particles.values.map(|values| values.len()), Some(count));
    assert!(particles.trails.is_none());
    let host = snow.host().expect("on the CPU");
    assert!(host.particles(ColorBy::Position).values.is_none());
    assert_eq!(host.time(), snow.time());

    let flow = Solver::new(common::flow(), &Placement::Cpu).unwrap();
    let particles = flow.host_particles(ColorBy::Speed).expect("on the CPU");
    assert_eq!(particles.positions.len(), flow.particle_count());
    assert!(particles.masses.is_none());
    assert!(particles.values.is_some());
    let trails = particles.trails.expect("the scene draws trails");
    assert_eq!(trails.lengths.len(), flow.particle_count());
    assert_eq!(trails.points.len(), trails.capacity * flow.particle_count());
    assert!(flow.device_particles().is_none());
}

#[test]
fn parameters_change_while_it_runs_and_wrong_ones_are_refused() {
    let mut snow = Solver::new(common::slab(), &Placement::Cpu).unwrap();
    let mut materials = snow.scene().materials.clone();
    materials[0].youngs_modulus /= 2.0;
    snow.set_materials(&materials)
        .expect("a softer snow is allowed");
    assert_eq!(snow.scene().materials, materials);
    materials[0].density *= 2.0;
    let refused = snow.set_materials(&materials).unwrap_err().to_string();
    assert!(refused.contains("density"), "{refused}");
    let SceneKind::Flow(settings) = common::flow().kind else {
        panic!("a flow scene")
    };
    let refused = snow.set_flow(&settings).unwrap_err().to_string();
    assert_eq!(refused, "a snow scene has no flow parameters");

    let mut flow = Solver::new(common::flow(), &Placement::Cpu).unwrap();
    let mut changed = (*settings).clone();
    changed.background_strength = 0.6;
    flow.set_flow(&changed)
        .expect("a stronger background is allowed");
    assert_eq!(flow.scene().kind, SceneKind::Flow(Box::new(changed)));
    let refused = flow.set_materials(&materials).unwrap_err().to_string();
    assert_eq!(refused, "a flow scene has no snow materials");
}

/// `count` substeps of `scene` on the CPU with `options`: the solver after them.
fn substeps_with(scene: Scene, options: SolverOptions, count: u32) -> Solver {
    let mut solver = Solver::new(scene, &Placement::Cpu)
        .unwrap()
        .with_options(options);
    assert_eq!(solver.advance_substeps(count).unwrap(), count);
    assert_eq!(solver.steps(), u64::from(count));
    solver
}

#[test]
fn every_instruction_set_gives_the_same_bits() {
    let portable = SolverOptions {
        simd: Some(Simd::Portable),
        ..SolverOptions::default()
    };
    for scene in [common::slab(), common::flow()] {
        let own = substeps_with(scene.clone(), SolverOptions::default(), 5);
        let chosen = substeps_with(scene, portable, 5);
        assert_eq!(chosen.options(), portable);
        assert_eq!(own.options().gpu_scatter, None);
        assert!(own.state().unwrap() == chosen.state().unwrap());
    }
}

#[test]
fn substeps_are_profiled_and_their_memory_counted() {
    let mut snow = substeps_with(common::slab(), SolverOptions::default(), 3);
    snow.wait().unwrap();
    let times = snow.phase_times().expect("snow on the CPU is profiled");
    assert!(times.total() > 0.0);
    snow.reset_phase_times();
    assert_eq!(snow.phase_times().unwrap().total(), 0.0);
    assert!(snow.memory_bytes() > 0);

    let flow = substeps_with(common::flow(), SolverOptions::default(), 4);
    assert!(flow.phase_times().is_none());
    assert!(flow.memory_bytes() > 0);
}

#[test]
fn the_gpu_takes_its_scatter_and_steps_at_least_the_substeps_asked_for() {
    let Some(context) = firn_gpu::context_for_tests() else {
        return;
    };
    let atomic = SolverOptions {
        gpu_scatter: Some(Scatter::Atomic),
        simd: Some(Simd::Portable),
    };
    let mut snow = Solver::new(common::slab(), &Placement::Gpu(context.clone()))
        .unwrap()
        .with_options(atomic);
    assert_eq!(
        snow.options(),
        SolverOptions {
            simd: None,
            gpu_scatter: Some(Scatter::Atomic)
        }
    );
    let taken = snow.advance_substeps(4).unwrap();
    snow.wait().unwrap();
    assert!(taken >= 4, "{taken}");
    assert_eq!(snow.steps(), u64::from(taken));
    assert!(snow.phase_times().is_none());
    assert!(snow.memory_bytes() > 0);

    let mut flow = Solver::new(common::flow(), &Placement::Gpu(context)).unwrap();
    assert_eq!(flow.advance_substeps(3).unwrap(), 3);
    assert_eq!(flow.options(), SolverOptions::default());
}

#[test]
fn the_gpu_gives_its_bodies_poses_without_reading_the_particles_back() {
    let Some(context) = firn_gpu::context_for_tests() else {
        return;
    };
    let mut snow = Solver::new(common::box_on_slab(), &Placement::Gpu(context)).unwrap();
    snow.advance_frame().unwrap();
    assert!(snow.host_particles(ColorBy::Speed).is_none());
    let poses = snow.device_body_poses().expect("snow on the GPU has them");
    assert_eq!(poses.len(), 1);
    assert_eq!(poses, snow.host().unwrap().body_poses());
    assert!(poses[0].position != [0.45, 0.4, 0.5], "the box moved");
    assert!(
        Solver::new(common::slab(), &Placement::Cpu)
            .unwrap()
            .device_body_poses()
            .is_none()
    );
}

#[test]
fn both_backends_count_the_snow_and_not_the_drift() {
    let Some(context) = firn_gpu::context_for_tests() else {
        return;
    };
    for placement in [Placement::Cpu, Placement::Gpu(context)] {
        let mut solver = Solver::new(common::drift_slab(), &placement).unwrap();
        let at_start = solver.particle_count();
        solver.advance_to(0.04).unwrap();
        let (snow, drift) = match solver.host().unwrap() {
            HostState::Snow(simulation) => (simulation.particles().len(), simulation.drift().len()),
            HostState::Flow(_) => unreachable!("the slab is snow"),
        };
        assert!(drift > 0, "{}: the wind lifts drift", placement.name());
        assert_eq!(snow + drift, at_start, "{}", placement.name());
        assert_eq!(solver.particle_count(), snow, "{}", placement.name());
    }
}

/// The host states of two solvers of one scene, on the CPU and the GPU, at
/// time 0 and after a frame, through `compare`.
fn on_both(scene: Scene, mut compare: impl FnMut(HostState<'_>, HostState<'_>, &str)) {
    let Some(context) = firn_gpu::context_for_tests() else {
        return;
    };
    let mut cpu = Solver::new(scene.clone(), &Placement::Cpu).unwrap();
    let mut gpu = Solver::new(scene, &Placement::Gpu(context)).unwrap();
    assert!(
        gpu.host_particles(ColorBy::Speed).is_some(),
        "the start is on the host"
    );
    assert!(
        gpu.state().unwrap() == cpu.state().unwrap(),
        "both start alike"
    );
    compare(cpu.host().unwrap(), gpu.host().unwrap(), "at the start");
    cpu.advance_frame().unwrap();
    gpu.advance_frame().unwrap();
    assert!(
        gpu.host_particles(ColorBy::Speed).is_none(),
        "not read back yet"
    );
    compare(cpu.host().unwrap(), gpu.host().unwrap(), "after a frame");
    let read_back = gpu.host_particles(ColorBy::Speed).expect("read back");
    assert_eq!(read_back.positions.len(), gpu.particle_count());
}

#[test]
fn the_gpu_reads_back_into_a_state_the_cpus_views_read_alike() {
    on_both(common::slab(), |cpu, gpu, when| {
        let (HostState::Snow(cpu), HostState::Snow(gpu)) = (cpu, gpu) else {
            panic!("the slab is snow");
        };
        assert!((gpu.time() - cpu.time()).abs() < 1e-9, "{when}");
        assert_eq!(gpu.particles().len(), cpu.particles().len(), "{when}");
        let (on_cpu, on_gpu) = (cpu.diagnostics(), gpu.diagnostics());
        assert_eq!(on_gpu.mass, on_cpu.mass, "{when}");
        let h = f64::from(cpu.scene().domain.cell_size);
        for axis in 0..3 {
            let shift = (on_gpu.center_of_mass[axis] - on_cpu.center_of_mass[axis]).abs();
            assert!(
                shift <= 1e-3 * h,
                "{when}: the centre of mass moved {shift} m"
            );
        }
        let (cpu_j, gpu_j) = (
            cpu.color_values(ColorBy::PlasticJ),
            gpu.color_values(ColorBy::PlasticJ),
        );
        assert_eq!(gpu_j.map(|j| j.len()), cpu_j.map(|j| j.len()), "{when}");
        if when == "at the start" {
            assert_eq!(gpu.particles(), cpu.particles());
            assert_eq!(gpu.densities(), cpu.densities());
        }
    });
}

#[test]
fn a_flow_on_the_gpu_reads_back_into_a_state_the_cpus_views_read_alike() {
    on_both(common::flow(), |cpu, gpu, when| {
        let (HostState::Flow(cpu), HostState::Flow(gpu)) = (cpu, gpu) else {
            panic!("a flow");
        };
        assert_eq!(gpu.time(), cpu.time(), "{when}");
        assert_eq!(gpu.births(), cpu.births(), "{when}");
        assert_eq!(gpu.generations(), cpu.generations(), "{when}");
        let worst = (gpu.positions().iter().zip(cpu.positions()))
            .map(|(a, b)| a.distance(*b))
            .fold(0.0, f32::max);
        assert!(worst < 1e-4, "{when}: positions differ by {worst} m");
        let rings = |view: firn_flow::FlowView<'_>| view.trails().map(|t| t.oldest_first().1);
        assert_eq!(rings(gpu), rings(cpu), "{when}");
    });
}
