//! Per-kernel parity: the WGSL SVD, B-spline weights, snow model, the
//! semi-implicit solve's stress differential and the colliders (poses,
//! distances, contact; turning and deforming) against the CPU functions
//! they mirror, on the same inputs.

mod common;

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use firn_core::math::bspline::{cubic_weights, quadratic_weights};
use firn_core::math::lanes::{F32s, Mat3s};
use firn_core::math::svd::svd3;
use firn_core::scene::Collider;
use firn_core::{Material, Scene};
use firn_gpu::buffers::{read_back, storage_buffer, zeroed_storage_buffer};
use firn_gpu::shaders::SNOW_PARITY;
use firn_gpu::snow::ColliderBuffers;
use firn_gpu::snow::bindings::ParityBindings;
use firn_gpu::{GpuContext, context_for_tests};
use firn_mpm::contact::ColliderSet;
use firn_mpm::implicit::StressDifferential;
use firn_mpm::snow_model::{ElasticUpdate, MaterialConstants, MaterialLanes};
use glam::{Mat3, Vec3};
use proptest::strategy::{Strategy, ValueTree};
use proptest::test_runner::{Config, TestRunner};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Matrix([[f32; 4]; 3]);

impl From<Mat3> for Matrix {
    fn from(m: Mat3) -> Matrix {
        Matrix([
            m.x_axis.extend(0.0).into(),
            m.y_axis.extend(0.0).into(),
            m.z_axis.extend(0.0).into(),
        ])
    }
}

impl From<Matrix> for Mat3 {
    fn from(m: Matrix) -> Mat3 {
        let c = |v: [f32; 4]| Vec3::new(v[0], v[1], v[2]);
        Mat3::from_cols(c(m.0[0]), c(m.0[1]), c(m.0[2]))
    }
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuMaterial([f32; 8]);

/// Runs `entry` of the parity program over `count` items; returns
/// (matrices_out, vectors_out).
fn run_parity(
    context: &Arc<GpuContext>,
    entry: &str,
    matrices: &[Matrix],
    vectors: &[[f32; 4]],
    outputs: (usize, usize),
    count: usize,
) -> (Vec<Matrix>, Vec<[f32; 4]>) {
    // The collider entry point's arrays, bound but not read here.
    let ball = [Collider::sphere(Vec3::ZERO, 1.0)];
    run_parity_with(context, entry, (matrices, vectors, &ball), outputs, count)
}

/// [`run_parity`] with `colliders` bound as well.
fn run_parity_with(
    context: &Arc<GpuContext>,
    entry: &str,
    (matrices, vectors, colliders): (&[Matrix], &[[f32; 4]], &[Collider]),
    outputs: (usize, usize),
    count: usize,
) -> (Vec<Matrix>, Vec<[f32; 4]>) {
    let collider_buffers = ColliderBuffers::of(context, colliders);
    run_parity_on(
        context,
        entry,
        (matrices, vectors, &collider_buffers),
        outputs,
        count,
    )
}

/// [`run_parity`] with colliders already packed and uploaded.
fn run_parity_on(
    context: &Arc<GpuContext>,
    entry: &str,
    (matrices, vectors, collider_buffers): (&[Matrix], &[[f32; 4]], &ColliderBuffers),
    outputs: (usize, usize),
    count: usize,
) -> (Vec<Matrix>, Vec<[f32; 4]>) {
    let device = &context.device;
    let material = MaterialConstants::new(&Material::preset("thesis").unwrap());
    let packed = GpuMaterial([
        material.mu0,
        material.lambda0,
        material.hardening,
        material.min_stretch,
        material.max_stretch,
        material.wave_speed_squared,
        0.0,
        0.0,
    ]);
    let inputs_m = storage_buffer(context, "matrices in", matrices);
    let inputs_v = storage_buffer(context, "vectors in", vectors);
    let out_m = zeroed_storage_buffer(context, "matrices out", (outputs.0 * 48) as u64);
    let out_v = zeroed_storage_buffer(context, "vectors out", (outputs.1 * 16) as u64);
    let material_buffer = storage_buffer(context, "material", &[packed]);
    let layout = ParityBindings::TABLE.layout(device);
    let [pipeline] = SNOW_PARITY.compute_pipelines(device, [(entry, &[&layout])]);
    let bind_group = ParityBindings {
        matrices_in: &inputs_m,
        vectors_in: &inputs_v,
        matrices_out: &out_m,
        vectors_out: &out_v,
        parity_material: &material_buffer,
        colliders: &collider_buffers.colliders,
        collider_keys: &collider_buffers.keys,
        collider_fields: &collider_buffers.fields,
        collider_poses: &collider_buffers.poses,
    }
    .bind_group(device, &layout);
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(count.div_ceil(64) as u32, 1, 1);
    }
    context.queue.submit([encoder.finish()]);
    let m = read_back::<Matrix>(context, &[(&out_m, outputs.0)])
        .unwrap()
        .remove(0);
    let v = read_back::<[f32; 4]>(context, &[(&out_v, outputs.1)])
        .unwrap()
        .remove(0);
    (m, v)
}

fn random_matrices(count: usize, spread: f32) -> Vec<Mat3> {
    let mut runner = TestRunner::new(Config::default());
    let strategy = proptest::array::uniform9(-spread..spread);
    (0..count)
        .map(|_| {
            let entries = strategy.new_tree(&mut runner).unwrap().current();
            Mat3::IDENTITY + Mat3::from_cols_array(&entries)
        })
        .collect()
}

fn max_difference(a: Mat3, b: Mat3) -> f32 {
    (a - b)
        .abs()
        .to_cols_array()
        .into_iter()
        .fold(0.0, f32::max)
}

#[test]
fn the_wgsl_svd_matches_svd3() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let inputs = random_matrices(512, 0.6);
    let matrices: Vec<Matrix> = inputs.iter().map(|&m| m.into()).collect();
    let (out, sigmas) = run_parity(
        &context,
        "svd_parity",
        &matrices,
        &[[0.0; 4]],
        (1024, 512),
        512,
    );
    let mut worst = 0.0f32;
    for (n, &f) in inputs.iter().enumerate() {
        let cpu = svd3(f);
        let (u, v) = (Mat3::from(out[2 * n]), Mat3::from(out[2 * n + 1]));
        let sigma = Vec3::new(sigmas[n][0], sigmas[n][1], sigmas[n][2]);
        let reconstructed = u * Mat3::from_diagonal(sigma) * v.transpose();
        worst = worst.max(max_difference(reconstructed, f));
        assert!(
            (sigma - cpu.sigma).abs().max_element() < 2e-5,
            "σ {sigma} vs {} for {f}",
            cpu.sigma
        );
        assert!(
            max_difference(u, cpu.u) < 1e-3 && max_difference(v, cpu.v) < 1e-3,
            "U, V differ for {f}"
        );
        assert!(sigma.x >= sigma.y && sigma.y >= sigma.z.abs());
    }
    assert!(worst < 1e-5, "U Σ Vᵀ misses F by {worst:e}");
}

#[test]
fn the_wgsl_weights_match_the_cpu_weights() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let points: Vec<[f32; 4]> = (0..300)
        .map(|n| {
            let t = n as f32;
            [
                3.0 + (t * 0.37) % 5.0,
                7.0 + (t * 0.61) % 3.0,
                1.5 + (t * 0.113) % 9.0,
                0.0,
            ]
        })
        .collect();
    let (_, out) = run_parity(
        &context,
        "weights_parity",
        &[Matrix([[0.0; 4]; 3])],
        &points,
        (1, 300 * 16),
        300,
    );
    for (n, point) in points.iter().enumerate() {
        let x = Vec3::new(point[0], point[1], point[2]);
        let at = |k: usize| Vec3::new(out[16 * n + k][0], out[16 * n + k][1], out[16 * n + k][2]);
        let (quadratic, cubic) = (quadratic_weights(x), cubic_weights(x));
        assert_eq!(at(0), quadratic.base.as_vec3(), "quadratic base at {x}");
        assert_eq!(at(1), cubic.base.as_vec3(), "cubic base at {x}");
        for k in 0..3 {
            assert!((at(2 + k) - quadratic.values[k]).abs().max_element() < 1e-6);
            assert!((at(5 + k) - quadratic.slopes[k]).abs().max_element() < 1e-6);
        }
        for k in 0..4 {
            assert!((at(8 + k) - cubic.values[k]).abs().max_element() < 1e-6);
            assert!((at(12 + k) - cubic.slopes[k]).abs().max_element() < 1e-6);
        }
    }
}

#[test]
fn the_wgsl_snow_model_matches_the_cpu_update() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let constants = MaterialConstants::new(&Material::preset("thesis").unwrap());
    // Half far outside the yield surface (the SVD path), half rotated and
    // strained within it (Newton's rotation, F_E and J_P kept).
    let mut trials = random_matrices(128, 0.08);
    let rotations = random_matrices(128, 1.0);
    let small = random_matrices(128, 0.002);
    trials.extend(rotations.iter().zip(&small).map(|(&m, &strain)| {
        let rotation = firn_core::math::svd::svd3(m);
        rotation.u * rotation.v.transpose() * strain
    }));
    let inside = trials
        .iter()
        .filter(|&&trial| {
            MaterialLanes::splat(&constants)
                .within_yield_surface(&Mat3s::<1>::splat(trial))
                .all()
        })
        .count();
    assert!(
        (100..=160).contains(&inside),
        "{inside} of 256 trials inside the yield surface; both paths need testing"
    );
    let states: Vec<[f32; 4]> = (0..256)
        .map(|n| [0.6 + 0.4 * (n as f32 / 256.0), 1e-4, 0.0, 0.0])
        .collect();
    let matrices: Vec<Matrix> = trials.iter().map(|&m| m.into()).collect();
    let (out, scalars) = run_parity(
        &context,
        "stress_parity",
        &matrices,
        &states,
        (512, 256),
        256,
    );
    for (n, &trial) in trials.iter().enumerate() {
        let mut lanes = Mat3s::<1>::splat(Mat3::ZERO);
        lanes.set_lane(0, trial);
        let cpu = ElasticUpdate::new(
            &lanes,
            F32s([states[n][0]]),
            F32s([states[n][1]]),
            &MaterialLanes::splat(&constants),
        );
        let (elastic, stress) = (Mat3::from(out[2 * n]), Mat3::from(out[2 * n + 1]));
        let cpu_stress = cpu.stress.lane(0);
        let stress_scale = cpu_stress
            .abs()
            .to_cols_array()
            .into_iter()
            .fold(1e-3, f32::max);
        assert!(
            max_difference(elastic, cpu.elastic.lane(0)) < 2e-6,
            "F_E differs for {trial}"
        );
        assert!(
            max_difference(stress, cpu_stress) < 1e-4 * stress_scale,
            "stress {stress} vs {cpu_stress}"
        );
        assert!((scalars[n][0] - cpu.plastic_j.lane(0)).abs() < 1e-5 * cpu.plastic_j.lane(0));
        assert!((scalars[n][1] / cpu.hardening_factor.lane(0) - 1.0).abs() < 1e-5);
    }
}

#[test]
fn the_wgsl_stress_differential_matches_the_cpu_one() {
    let Some(context) = context_for_tests() else {
        return;
    };
    // F_E within the plasticity clamp's reach (singular values near 1,
    // stretched and compressed), random directions, stiff to soft snow.
    let count = 256;
    let elastic = random_matrices(count, 0.05);
    let directions = random_matrices(count, 1.0);
    let parameters: Vec<[f32; 4]> = (0..count)
        .map(|n| {
            let t = n as f32 / count as f32;
            [1e4 + 2e6 * t, 3e6 - 2e6 * t, 1e-3 * (1.0 + t), 0.0]
        })
        .collect();
    let matrices: Vec<Matrix> = elastic
        .iter()
        .zip(&directions)
        .flat_map(|(&f, &d)| [f.into(), (d - Mat3::IDENTITY).into()])
        .collect();
    let (out, _) = run_parity(
        &context,
        "stress_differential_parity",
        &matrices,
        &parameters,
        (count, 1),
        count,
    );
    for n in 0..count {
        let [mu, lambda, volume0, _] = parameters[n];
        let direction = directions[n] - Mat3::IDENTITY;
        let cpu = StressDifferential::new(elastic[n], mu, lambda, volume0).apply(direction);
        let scale = cpu.abs().to_cols_array().into_iter().fold(1e-3, f32::max);
        let gpu = Mat3::from(out[n]);
        assert!(
            max_difference(gpu, cpu) < 1e-4 * scale,
            "dP {gpu} vs {cpu} at F_E = {}",
            elastic[n]
        );
    }
}

/// A closed unit cube centred at the origin, faces wound outwards.
const CUBE_OBJ: &str = "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5\n\
v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

/// Colliders that turn, of every shape, and one that does not: a tilted
/// turntable box, a rolling wheel, a box keyframed through turns (one the
/// long way round) along a Catmull-Rom path, a tilting plane, a turning
/// mesh, a static turned cylinder and an unturned keyframed sphere.
const TURNING_COLLIDERS: &str = r#"format = 1
[domain]
max = [2.0, 2.0, 2.0]
cell_size = 0.05
[time]
duration = 2.0
[[bodies]]
shape = "sphere"
center = [1.0, 1.0, 1.0]
radius = 0.1

[[colliders]]
shape = "box"
center = [0.5, 0.5, 0.5]
size = [0.6, 0.1, 0.4]
rotation = [10.0, 0.0, 20.0]
angular_velocity = [0.0, 3.0, 0.0]
mode = "sticky"

[[colliders]]
shape = "cylinder"
center = [0.3, 0.4, 1.0]
radius = 0.25
height = 0.14
rotation = [90.0, 0.0, 0.0]
velocity = [1.0, 0.0, 0.0]
angular_velocity = [0.0, 0.0, -4.0]
friction = 0.5

[[colliders]]
shape = "box"
center = [1.0, 1.0, 1.0]
size = [0.3, 0.2, 0.5]
path = "catmull-rom"
mode = "slip"
friction = 0.3
keyframes = [
    { time = 0.25, position = [1.0, 1.0, 1.0] },
    { time = 0.75, position = [1.2, 1.1, 1.0], rotation = [0.0, 90.0, 0.0] },
    { time = 1.0, position = [1.3, 1.0, 1.2], quaternion = [0.0, -0.5, 0.5, -0.70710678] },
    { time = 1.5, position = [1.1, 0.9, 1.3], rotation = [30.0, 0.0, 200.0] },
]

[[colliders]]
shape = "plane"
point = [1.0, 0.2, 1.0]
normal = [0.0, 1.0, 0.0]
angular_velocity = [0.5, 0.0, 0.0]
friction = 0.4

[[colliders]]
shape = "mesh"
mesh = "cube.obj"
scale = [0.3, 0.2, 0.4]
center = [1.5, 0.5, 0.5]
sdf_spacing = 0.02
velocity = [0.2, 0.0, 0.0]
angular_velocity = [1.0, 2.0, 0.0]
mode = "sticky"

[[colliders]]
shape = "cylinder"
center = [0.5, 1.5, 1.5]
radius = 0.2
height = 0.5
rotation = [0.0, 0.0, 45.0]
friction = 0.2

[[colliders]]
shape = "sphere"
center = [1.5, 1.5, 0.5]
radius = 0.2
keyframes = [
    { time = 0.0, position = [1.5, 1.5, 0.5] },
    { time = 1.0, position = [1.6, 1.4, 0.6] },
]
"#;

/// Placement, distance, normal and contact of every collider of
/// [`TURNING_COLLIDERS`] at points around it at times before, between and
/// after keys, in WGSL and on the CPU (`Collider::pose_at`,
/// `PlacedCollider::signed_distance` and `collide`).
#[test]
fn the_wgsl_colliders_turn_and_collide_as_the_cpu_ones() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cube.obj"), CUBE_OBJ).unwrap();
    let path = dir.path().join("turning.toml").display().to_string();
    let scene = Scene::from_toml_str(TURNING_COLLIDERS, &path).unwrap();
    let colliders = &scene.colliders;
    let mut set = ColliderSet::new(&scene.domain, colliders);
    let times = [0.0, 0.125, 0.3, 0.5, 0.8125, 0.9, 1.25, 1.75];
    let mut state = 2024_u32;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1 << 24) as f32 * 2.0 - 1.0
    };
    // (collider, time, point, velocity)
    let mut cases = Vec::new();
    for (c, collider) in colliders.iter().enumerate() {
        let reach = collider.geometry.reach().min(0.5) + 0.1;
        for &t in &times {
            let center = collider.pose_at(t).position;
            for _ in 0..40 {
                let point = center + Vec3::new(next(), next(), next()) * reach;
                let velocity = Vec3::new(next(), next(), next()) * 2.0;
                cases.push((c, t, point, velocity));
            }
        }
    }
    let inputs: Vec<[f32; 4]> = cases
        .iter()
        .flat_map(|&(c, t, point, velocity)| {
            [
                point.extend(t as f32).into(),
                velocity.extend(c as f32).into(),
            ]
        })
        .collect();
    let (_, out) = run_parity_with(
        &context,
        "collider_parity",
        (&[Matrix([[0.0; 4]; 3])], &inputs, colliders),
        (1, 6 * cases.len()),
        cases.len(),
    );
    let vector = |v: [f32; 4]| Vec3::new(v[0], v[1], v[2]);
    let mut worst = [0.0f32; 3];
    let (mut inside, mut turned) = (0, 0);
    for (n, &(c, t, point, velocity)) in cases.iter().enumerate() {
        let gpu = &out[6 * n..6 * n + 6];
        let pose = colliders[c].pose_at(t);
        let placed = &set.placed_at(t)[c];
        let (distance, normal) = placed.distance_and_normal(point);
        let collided = placed.collide(point, velocity);
        let at = format!("collider {c} at t = {t}, x = {point}");
        assert_eq!(gpu[4][3] == 1.0, pose.turns(), "{at}: turned");
        let pose_error = [
            (vector(gpu[1]) - pose.position).abs().max_element(),
            (glam::Vec4::from(gpu[2]) - glam::Vec4::from(pose.rotation))
                .abs()
                .max_element(),
            (vector(gpu[3]) - pose.velocity).abs().max_element(),
            (vector(gpu[4]) - pose.angular_velocity).abs().max_element(),
        ]
        .into_iter()
        .fold(0.0, f32::max);
        let surface_error = (gpu[1][3] - distance)
            .abs()
            .max((vector(gpu[5]) - normal).abs().max_element());
        let contact_error = (vector(gpu[0]) - collided).abs().max_element();
        // Quantities of order one (m, m/s, rad/s). The slerp's acos and sin
        // and the rate's atan2 round differently in WGSL (whose atan2 may
        // err by 4096 ulp) and glam (a polynomial acos): the poses differ
        // by up to 2.2e-5 (measured on lavapipe). A box's normal just
        // outside an edge turns by that error over the distance to the
        // edge, and the contact with it: 1.2e-4 and 1.4e-4 measured.
        assert!(
            pose_error < 1e-4 && surface_error < 5e-4 && contact_error < 5e-4,
            "{at}: pose {pose_error:e}, surface {surface_error:e}, contact {contact_error:e}\n\
             gpu {gpu:?}\ncpu {pose:?}, {distance}, {normal}, {collided}"
        );
        for (w, e) in worst
            .iter_mut()
            .zip([pose_error, surface_error, contact_error])
        {
            *w = w.max(e);
        }
        inside += usize::from(distance <= 0.0);
        turned += usize::from(pose.turns() && distance <= 0.0);
    }
    // The points must probe the turned contact, not only the free side.
    assert!(
        turned > cases.len() / 10,
        "only {turned} of {} points met a turned collider",
        cases.len()
    );
    eprintln!(
        "{} points, {inside} inside: pose within {:.1e}, distance and normal {:.1e}, contact {:.1e}",
        cases.len(),
        worst[0],
        worst[1],
        worst[2]
    );
}

/// Two deforming boxes: one sinking, squashed and sheared at 10 mesh
/// frames a second from t = 0.05 s, sticky (so its contact is the
/// surface's own velocity), and one that grows sideways at 25 a second,
/// with frictional contact.
fn deforming_boxes(folder: &std::path::Path) -> Scene {
    use common::{BoxFrame, write_box_sequence};
    let sinking: Vec<BoxFrame> = (0..4)
        .map(|k| {
            let k = k as f32;
            BoxFrame {
                low: Vec3::new(0.3, 0.4 - 0.05 * k, 0.35),
                high: Vec3::new(0.6, 0.6 - 0.03 * k, 0.65),
                shear: Vec3::new(0.02 * k, 0.0, -0.01 * k),
            }
        })
        .collect();
    let sinking_folder = folder.join("sinking");
    std::fs::create_dir(&sinking_folder).unwrap();
    let sinking = write_box_sequence(&sinking_folder, &sinking);
    let growing: Vec<BoxFrame> = (0..6)
        .map(|k| {
            let k = k as f32;
            BoxFrame {
                low: Vec3::new(1.2 - 0.02 * k, 0.3, 1.2),
                high: Vec3::new(1.4 + 0.03 * k, 0.5, 1.45),
                shear: Vec3::ZERO,
            }
        })
        .collect();
    let growing = write_box_sequence(folder, &growing);
    let text = format!(
        r#"format = 1
[domain]
max = [2.0, 2.0, 2.0]
cell_size = 0.05
[time]
duration = 1.0
[[bodies]]
shape = "sphere"
center = [1.0, 1.5, 1.0]
radius = 0.1

[[colliders]]
shape = "mesh"
sequence = "sinking/{sinking}"
frame_rate = 10
start = 0.05
sdf_spacing = 0.02
mode = "sticky"

[[colliders]]
shape = "mesh"
sequence = "{growing}"
frame_rate = 25
sdf_spacing = 0.025
friction = 0.4
"#
    );
    let path = folder.join("deforming.toml").display().to_string();
    Scene::from_toml_str(&text, &path).unwrap()
}

/// Distance, normal and contact of [`deforming_boxes`] at points in and
/// around them at times before, within and after their sequences, in WGSL
/// (the bands of the mesh frames around each time uploaded as a run does)
/// and on the CPU (`PlacedCollider::distance_and_normal` and `collide`).
#[test]
fn the_wgsl_deforming_colliders_collide_as_the_cpu_ones() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let scene = deforming_boxes(dir.path());
    let colliders = &scene.colliders;
    let mut set = ColliderSet::new(&scene.domain, colliders);
    let mut buffers = ColliderBuffers::of(&context, colliders);
    let mut state = 46_u32;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1 << 24) as f32
    };
    let vector = |v: [f32; 4]| Vec3::new(v[0], v[1], v[2]);
    let mut worst = [0.0f32; 3];
    let (mut inside, mut moving, mut total) = (0, 0, 0);
    // Before both, in their first intervals, later ones (the bands of one
    // frame kept from the interval before), and after both.
    for t in [0.0, 0.02, 0.0625, 0.1, 0.1875, 0.27, 0.3125, 0.6] {
        buffers.load_mesh_frames(&context, t);
        let placed = set.placed_at(t);
        // (collider, point, velocity)
        let mut cases = Vec::new();
        for (c, collider) in colliders.iter().enumerate() {
            let (low, high) = match &collider.geometry {
                firn_core::scene::ColliderGeometry::MeshSequence(sequence) => sequence.bounds(),
                _ => unreachable!("every collider here deforms"),
            };
            let reach = Vec3::splat(0.08);
            for _ in 0..200 {
                let share = Vec3::new(next(), next(), next());
                let point = low - reach + share * (high - low + 2.0 * reach);
                let velocity = (Vec3::new(next(), next(), next()) - 0.5) * 4.0;
                cases.push((c, point, velocity));
            }
        }
        let inputs: Vec<[f32; 4]> = cases
            .iter()
            .flat_map(|&(c, point, velocity)| {
                [
                    point.extend(t as f32).into(),
                    velocity.extend(c as f32).into(),
                ]
            })
            .collect();
        let (_, out) = run_parity_on(
            &context,
            "collider_parity",
            (&[Matrix([[0.0; 4]; 3])], &inputs, &buffers),
            (1, 6 * cases.len()),
            cases.len(),
        );
        for (n, &(c, point, velocity)) in cases.iter().enumerate() {
            let gpu = &out[6 * n..6 * n + 6];
            let (distance, normal) = placed[c].distance_and_normal(point);
            let collided = placed[c].collide(point, velocity);
            let errors = [
                (gpu[1][3] - distance).abs(),
                (vector(gpu[5]) - normal).abs().max_element(),
                (vector(gpu[0]) - collided).abs().max_element(),
            ];
            // Lengths of order 0.1 m, speeds of order 1 m/s: f32 round-off
            // in the lattice coordinates (WGSL's division), the blend's
            // fraction (from f32 time on the GPU) and the closest points;
            // lavapipe measured 1.5e-8 m, 1.2e-7 and 3e-8 m/s.
            assert!(
                errors[0] < 1e-6 && errors[1] < 1e-5 && errors[2] < 1e-5,
                "collider {c} at t = {t}, x = {point}: distance, normal, contact differ by \
                 {errors:?}\ngpu {gpu:?}\ncpu {distance}, {normal}, {collided}"
            );
            for (w, e) in worst.iter_mut().zip(errors) {
                *w = w.max(e);
            }
            inside += usize::from(distance <= 0.0);
            moving +=
                usize::from(distance <= 0.0 && collided != velocity && collided != Vec3::ZERO);
            total += 1;
        }
    }
    // The points must probe the moving surface's contact, not only the free side.
    assert!(
        moving > total / 20,
        "only {moving} of {total} points met a moving surface"
    );
    eprintln!(
        "{total} points, {inside} inside ({moving} moved by a moving surface): distance within \
         {:.1e} m, normal {:.1e}, contact {:.1e} m/s",
        worst[0], worst[1], worst[2]
    );
}
