//! Per-kernel parity: the WGSL SVD, B-spline weights, snow model and the
//! semi-implicit solve's stress differential against the CPU functions they
//! mirror, on the same inputs.

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use firn_core::Material;
use firn_core::math::bspline::{cubic_weights, quadratic_weights};
use firn_core::math::lanes::{F32s, Mat3s};
use firn_core::math::svd::svd3;
use firn_gpu::buffers::{read_back, storage_buffer, zeroed_storage_buffer};
use firn_gpu::shaders::SNOW_PARITY;
use firn_gpu::snow::bindings::ParityBindings;
use firn_gpu::{GpuContext, context_for_tests};
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
