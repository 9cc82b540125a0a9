//! What an interactive viewer needs of the GPU backend: parameters changed
//! between frames (`GpuSnow::set_materials`, `GpuFlow::set_settings`), the
//! particle arrays a renderer reads in place (`particle_arrays`), and a
//! device opened on an adapter of the viewer's own choosing
//! (`rank_adapters`, `GpuContext::open`).
//!
//! Every test skips (with a note) where no adapter is found; CI sets
//! `FIRN_REQUIRE_GPU=1` and runs them on Mesa's lavapipe.

use std::sync::Arc;

use firn_core::scene::{FlowEmission, FlowSettings, SceneKind, Wind};
use firn_core::{Material, Scene};
use firn_flow::{FlowError, FlowSnapshot, Trails};
use firn_gpu::buffers::read_back;
use firn_gpu::draw::StridedArray;
use firn_gpu::{GpuContext, GpuError, GpuFlow, GpuSnow, context_for_tests, rank_adapters};
use firn_mpm::SimulationError;
use glam::Vec3;

/// A slab of snow resting on the floor, adaptive Δt.
fn slab() -> Scene {
    let text = r#"format = 1
name = "slab"

[domain]
max = [0.5, 0.4, 0.5]
cell_size = 0.05

[time]
duration = 0.6
fps = 30
step = "adaptive"
dt = 0.002

[solver]
transfer = "apic"

[[bodies]]
shape = "box"
center = [0.25, 0.1, 0.25]
size = [0.2, 0.2, 0.2]
"#;
    Scene::from_toml_str(text, "slab.toml").expect("the test scene is valid")
}

/// The scene's materials with Young's modulus divided by `factor`.
fn softened(scene: &Scene, factor: f32) -> Vec<Material> {
    let mut materials = scene.materials.clone();
    for material in &mut materials {
        material.youngs_modulus /= factor;
    }
    materials
}

/// Mean height and top height (the mean of the highest tenth) of the snow.
fn heights(snow: &GpuSnow) -> (f32, f32) {
    let mut ys: Vec<f32> = snow
        .snapshot()
        .unwrap()
        .particles
        .position
        .iter()
        .map(|x| x.y)
        .collect();
    ys.sort_by(f32::total_cmp);
    let mean = ys.iter().sum::<f32>() / ys.len() as f32;
    let top = &ys[ys.len() * 9 / 10..];
    (mean, top.iter().sum::<f32>() / top.len() as f32)
}

#[test]
fn snow_softened_live_sags_more_on_the_gpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = slab();
    let mut stiff = GpuSnow::new(context.clone(), scene.clone()).unwrap();
    let mut soft = GpuSnow::new(context, scene.clone()).unwrap();
    soft.set_materials(&softened(&scene, 10.0)).unwrap();
    assert_eq!(soft.scene().materials[0].youngs_modulus, 1.4e4);
    stiff.advance_to(0.6).unwrap();
    soft.advance_to(0.6).unwrap();
    let ((stiff_mean, stiff_top), (soft_mean, soft_top)) = (heights(&stiff), heights(&soft));
    eprintln!(
        "at rest: mean height {stiff_mean:.5} m (E) vs {soft_mean:.5} m (E/10), top \
         {stiff_top:.5} m vs {soft_top:.5} m"
    );
    // Measured: mean heights 100.23 and 95.24 mm (5.0 mm apart), tops 190.63
    // and 183.51 mm (7.1 mm apart).
    assert!(
        stiff_mean - soft_mean > 2e-3,
        "the softer slab's mean height is {soft_mean}, the stiffer's {stiff_mean}"
    );
    assert!(
        stiff_top - soft_top > 3e-3,
        "the softer slab's top is at {soft_top}, the stiffer's at {stiff_top}"
    );
}

#[test]
fn materials_set_at_the_start_run_as_a_scene_with_them_on_the_gpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = slab();
    let soft_materials = softened(&scene, 10.0);
    let mut changed = GpuSnow::new(context.clone(), scene.clone()).unwrap();
    changed.set_materials(&soft_materials).unwrap();
    let mut soft_scene = scene.clone();
    soft_scene.materials = soft_materials;
    let mut fresh = GpuSnow::new(context, soft_scene.clone()).unwrap();
    assert_eq!(changed.scene(), &soft_scene);
    changed.advance_to(0.1).unwrap();
    fresh.advance_to(0.1).unwrap();
    let (changed, fresh) = (changed.snapshot().unwrap(), fresh.snapshot().unwrap());
    assert_eq!(changed.steps, fresh.steps, "the same adaptive substeps");
    assert!(
        changed == fresh,
        "a change at t = 0 differs from a run of the changed scene"
    );
}

#[test]
fn bad_materials_are_refused_on_the_gpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = slab();
    let mut snow = GpuSnow::new(context, scene.clone()).unwrap();
    let mut materials = scene.materials.clone();
    materials[0].poisson_ratio = 0.5;
    let error = snow.set_materials(&materials).unwrap_err();
    let GpuError::Snow(SimulationError::Materials(error)) = error else {
        panic!("not a materials error: {error}");
    };
    assert_eq!(error.key.as_deref(), Some("materials.snow.poisson_ratio"));
    let mut materials = scene.materials.clone();
    materials[0].density *= 2.0;
    let error = snow.set_materials(&materials).unwrap_err().to_string();
    assert!(
        error.contains("materials.snow.density cannot change"),
        "{error}"
    );
    assert_eq!(snow.scene(), &scene, "refused changes change nothing");
}

/// A wind set on a running GPU run at the start runs as the scene with it;
/// a wind the scene loader refuses changes nothing.
#[test]
fn a_wind_set_at_the_start_runs_as_a_scene_with_it_on_the_gpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = slab();
    let mut wind = Wind::uniform(Vec3::X, 4.0);
    wind.drag = 30.0;
    let mut changed = GpuSnow::new(context.clone(), scene.clone()).unwrap();
    let mut bad = wind.clone();
    bad.drag = -1.0;
    let error = changed.set_wind(&bad).unwrap_err();
    let GpuError::Snow(SimulationError::Wind(error)) = error else {
        panic!("not a wind error: {error}");
    };
    assert_eq!(error.key.as_deref(), Some("wind.drag"));
    assert_eq!(changed.scene(), &scene, "a refused wind changes nothing");
    changed.set_wind(&wind).unwrap();
    let mut windy_scene = scene.clone();
    windy_scene.wind = Some(wind);
    let mut fresh = GpuSnow::new(context, windy_scene.clone()).unwrap();
    assert_eq!(changed.scene(), &windy_scene);
    changed.advance_to(0.05).unwrap();
    fresh.advance_to(0.05).unwrap();
    assert!(
        changed.snapshot().unwrap() == fresh.snapshot().unwrap(),
        "a wind set at t = 0 differs from a run of the windy scene"
    );
}

/// A flow from a box around a sphere, with short lives and trails.
fn flow_scene() -> Scene {
    let text = r#"format = 1
kind = "flow"

[domain]
max = [100.0, 100.0, 100.0]

[time]
duration = 2.0
fps = 20

[flow]
noise_share = 0.5
noise_strength = 5.0
length_scale = 20.0
background_strength = 4.0
evolution_rate = 0.2
seed = 5

[[flow.obstacles]]
center = [50.0, 50.0, 50.0]
radius = 10.0
influence = 6.0

[[flow.emitters]]
shape = "box"
center = [50.0, 50.0, 50.0]
size = [100.0, 100.0, 100.0]
count = 2000
lifetime = 0.5
lifetime_spread = 0.3

[render]
styles = ["trails"]
trail_length = 4
"#;
    Scene::from_toml_str(text, "flow.toml").expect("the test scene is valid")
}

#[test]
fn flow_settings_set_at_the_start_run_as_a_scene_with_them_on_the_gpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = flow_scene();
    let settings = FlowSettings {
        noise_share: 0.8,
        noise_strength: 9.0,
        length_scale: 12.0,
        ..scene.kind.flow().unwrap().clone()
    };
    let mut changed = GpuFlow::new(context.clone(), scene.clone()).unwrap();
    let mut unchanged = GpuFlow::new(context.clone(), scene.clone()).unwrap();
    changed.set_settings(settings.clone()).unwrap();
    let changed_scene = Scene {
        kind: SceneKind::Flow(Box::new(settings)),
        ..scene.clone()
    };
    let mut fresh = GpuFlow::new(context, changed_scene.clone()).unwrap();
    assert_eq!(changed.scene(), &changed_scene);
    for flow in [&mut changed, &mut fresh, &mut unchanged] {
        flow.advance_to(0.5).unwrap();
    }
    let (changed, fresh) = (changed.snapshot().unwrap(), fresh.snapshot().unwrap());
    assert!(
        changed == fresh,
        "a change at t = 0 differs from a run of the changed scene"
    );
    let unchanged = unchanged.snapshot().unwrap();
    let moved = changed.positions[0].distance(unchanged.positions[0]);
    assert!(
        moved > 0.1,
        "the new field moved particle 0 by only {moved} m"
    );
}

#[test]
fn changed_emitters_are_refused_on_the_gpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = flow_scene();
    let mut flow = GpuFlow::new(context, scene.clone()).unwrap();
    let mut settings = scene.kind.flow().unwrap().clone();
    settings.emitters[0].emission = FlowEmission::Count(10);
    let error = flow.set_settings(settings).unwrap_err();
    let GpuError::Flow(FlowError::Scene(error)) = error else {
        panic!("not a scene error: {error}");
    };
    assert_eq!(error.key.as_deref(), Some("flow.emitters"));
    assert!(error.message.contains("emitters cannot change"));
    assert_eq!(flow.scene(), &scene);
}

/// The first `count` values of a strided quantity of `components` words,
/// copied out of its buffer.
fn read_strided(
    context: &GpuContext,
    array: StridedArray<'_>,
    count: u32,
    components: u32,
) -> Vec<Vec<u32>> {
    let words = (count * array.stride) as usize;
    let all = read_back::<u32>(context, &[(array.buffer, words)])
        .unwrap()
        .remove(0);
    (0..count)
        .map(|i| {
            let start = (i * array.stride + array.offset) as usize;
            all[start..start + components as usize].to_vec()
        })
        .collect()
}

fn vec3_bits(vectors: &[Vec3]) -> Vec<Vec<u32>> {
    vectors
        .iter()
        .map(|v| v.to_array().map(f32::to_bits).to_vec())
        .collect()
}

fn scalar_bits(values: &[f32]) -> Vec<Vec<u32>> {
    values.iter().map(|v| vec![v.to_bits()]).collect()
}

#[test]
fn snow_particle_arrays_are_the_snapshot_in_place() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let mut snow = GpuSnow::new(context.clone(), slab()).unwrap();
    snow.advance_to(0.05).unwrap();
    let snapshot = snow.snapshot().unwrap().particles;
    let arrays = snow.particle_arrays();
    let n = arrays.count;
    assert_eq!(n as usize, snapshot.len());
    let read = |array, components| read_strided(&context, array, n, components);
    assert_eq!(read(arrays.positions, 3), vec3_bits(&snapshot.position));
    assert_eq!(read(arrays.velocities, 3), vec3_bits(&snapshot.velocity));
    assert!(arrays.trails.is_none());
    let state = arrays.snow.expect("snow arrays");
    assert_eq!(read(state.mass, 1), scalar_bits(&snapshot.mass));
    assert_eq!(read(state.volume0, 1), scalar_bits(&snapshot.volume0));
    assert_eq!(read(state.plastic_j, 1), scalar_bits(&snapshot.plastic_j));
    let columns = read(state.elastic, 12);
    for (words, elastic) in columns.iter().zip(&snapshot.elastic) {
        let column =
            |c: usize| Vec3::from_array(std::array::from_fn(|r| f32::from_bits(words[4 * c + r])));
        assert_eq!(
            [column(0), column(1), column(2)],
            elastic.to_cols_array_2d().map(Vec3::from_array)
        );
    }
}

#[test]
fn flow_particle_arrays_and_trails_are_the_snapshot_in_place() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let mut flow = GpuFlow::new(context.clone(), flow_scene()).unwrap();
    // Three frames: the first position and three more recorded into rings
    // of four, so the head has come round to slot 0 again.
    flow.advance_to(0.15).unwrap();
    let snapshot: FlowSnapshot = flow.snapshot().unwrap();
    let arrays = flow.particle_arrays();
    let n = arrays.count;
    assert_eq!(n as usize, snapshot.positions.len());
    assert!(arrays.snow.is_none());
    let read = |array, components| read_strided(&context, array, n, components);
    assert_eq!(read(arrays.positions, 3), vec3_bits(&snapshot.positions));
    assert_eq!(read(arrays.velocities, 3), vec3_bits(&snapshot.velocities));

    let rings = arrays.trails.expect("the scene keeps trails");
    assert_eq!(rings.capacity, snapshot.trail_capacity);
    assert_eq!(rings.head, snapshot.trail_head);
    assert_eq!(rings.head, 0, "the head wrapped");
    assert_eq!(rings.count as usize, snapshot.trail_lengths.len());
    let capacity = rings.capacity as usize;
    let count = rings.count as usize;
    let mut read_words = read_back::<u32>(
        &context,
        &[(rings.points, 3 * capacity * count), (rings.lengths, count)],
    )
    .unwrap();
    let lengths = read_words.pop().unwrap();
    let points: Vec<Vec3> = read_words[0]
        .chunks(3)
        .map(|xyz| Vec3::from_array(std::array::from_fn(|k| f32::from_bits(xyz[k]))))
        .collect();
    assert_eq!(lengths, snapshot.trail_lengths);
    assert_eq!(points, snapshot.trail_points);
    // The documented convention: the k-th newest point of ring i is in slot
    // (head + capacity - k) % capacity, as firn_flow::Trails reads it.
    let trails = Trails::from_raw(
        capacity,
        rings.head as usize,
        snapshot.trail_points.clone(),
        snapshot.trail_lengths.clone(),
        snapshot.trail_generations.clone(),
    )
    .unwrap();
    let head = rings.head as usize;
    let mut full_rings = 0;
    for i in 0..count {
        let newest_first: Vec<Vec3> = (0..lengths[i] as usize)
            .map(|k| points[i * capacity + (head + capacity - k) % capacity])
            .collect();
        let expected: Vec<Vec3> = trails.iter(i).rev().collect();
        assert_eq!(newest_first, expected, "ring {i}");
        full_rings += usize::from(lengths[i] as usize == capacity);
    }
    assert!(full_rings > 0, "some rings are full");
}

#[test]
fn a_device_opens_on_an_adapter_of_the_callers_instance() {
    if context_for_tests().is_none() {
        return;
    }
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let found = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::PRIMARY));
    let ranked = rank_adapters(found);
    let best = ranked.first().expect("a usable adapter");
    let context: Arc<GpuContext> = GpuContext::open(best).unwrap();
    assert_eq!(context.adapter.name, best.get_info().name);
    assert_eq!(context.limits, best.limits());
    let mut flow = GpuFlow::new(context, flow_scene()).unwrap();
    flow.advance_to(0.1).unwrap();
    assert!(
        flow.snapshot()
            .unwrap()
            .positions
            .iter()
            .all(|x| x.is_finite())
    );
}

#[test]
fn a_grown_sphere_settles_the_particles_as_on_the_cpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = flow_scene();
    let mut settings = scene.kind.flow().unwrap().clone();
    let center = Vec3::new(45.0, 50.0, 50.0);
    settings.obstacles[0].center = center;
    settings.obstacles[0].radius = 20.0;
    let mut gpu = GpuFlow::new(context, scene.clone()).unwrap();
    let mut cpu = firn_flow::FlowSimulation::new(scene).unwrap();
    gpu.set_settings(settings.clone()).unwrap();
    cpu.set_settings(settings).unwrap();
    let snapshot = gpu.snapshot().unwrap();
    let inside = snapshot
        .positions
        .iter()
        .filter(|x| x.distance(center) < 20.0)
        .count();
    assert_eq!(inside, 0, "particles inside the grown sphere");
    let (mut position_error, mut velocity_error, mut speed) = (0.0f32, 0.0f32, 0.0f32);
    for p in 0..cpu.len() {
        position_error = position_error.max(snapshot.positions[p].distance(cpu.positions()[p]));
        velocity_error = velocity_error.max(snapshot.velocities[p].distance(cpu.velocities()[p]));
        speed = speed.max(cpu.velocities()[p].length());
    }
    eprintln!("settled: |Δx| ≤ {position_error:e} m, |Δv| ≤ {velocity_error:e} m/s of {speed} m/s");
    assert!(
        position_error <= 1e-4,
        "positions differ by {position_error} m"
    );
    assert!(
        velocity_error <= 1e-5 * speed,
        "velocities differ by {velocity_error} m/s"
    );
}
