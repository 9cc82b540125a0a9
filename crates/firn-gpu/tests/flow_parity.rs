//! The GPU flow against its reference, `firn_flow`: the noise, the field
//! and births function by function, whole runs particle by particle, and
//! snapshots that continue bit for bit.
//!
//! Every test skips (with a note) where no adapter is found; CI sets
//! `FIRN_REQUIRE_GPU=1` and runs them on Mesa's lavapipe.

use firn_core::Scene;
use firn_core::scene::{
    FlowCurl, FlowEmission, FlowEmitter, FlowEmitterShape, FlowIntegrator, FlowSettings,
    RenderStyle, SceneKind,
};
use firn_flow::{FlowField, FlowSimulation, FlowSnapshot};
use firn_gpu::flow::FlowProbe;
use firn_gpu::{GpuError, GpuFlow, context_for_tests};
use glam::{DVec3, Vec3};

/// Deterministic points uniform in the box `min..max`.
fn points(count: usize, min: Vec3, max: Vec3) -> Vec<Vec3> {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut unit = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 40) as f32 / 16_777_216.0
    };
    (0..count)
        .map(|_| min + Vec3::new(unit(), unit(), unit()) * (max - min))
        .collect()
}

fn demo_scene() -> Scene {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/curl-noise-demo.toml"
    );
    Scene::load(path.as_ref()).expect("the bundled demo loads")
}

fn settings_of(scene: &mut Scene) -> &mut FlowSettings {
    match &mut scene.kind {
        SceneKind::Flow(settings) => settings,
        SceneKind::Snow => panic!("the demo is a flow scene"),
    }
}

/// The demo with few particles and short lives, so a second of flow on a
/// software adapter has births, rebirths (expired and escaped) and trails.
fn small_demo() -> Scene {
    let mut scene = demo_scene();
    scene.render.trail_length = 4;
    let settings = settings_of(&mut scene);
    settings.emitters[0].emission = FlowEmission::Rate(600.0);
    settings.emitters[0].lifetime = Some(1.5);
    settings.emitters[1].emission = FlowEmission::Count(1500);
    settings.emitters[1].lifetime = Some(0.5);
    scene
}

/// The small demo with the other code paths: RK4, central differences, a
/// ball emitter with a birth velocity, and particles that live forever.
fn small_variant() -> Scene {
    let mut scene = small_demo();
    let settings = settings_of(&mut scene);
    settings.integrator = FlowIntegrator::Rk4;
    settings.curl = FlowCurl::FiniteDifference { step: 0.05 };
    settings.emitters.push(FlowEmitter {
        shape: FlowEmitterShape::Sphere {
            center: Vec3::new(20.0, 60.0, 40.0),
            radius: 8.0,
        },
        emission: FlowEmission::Count(500),
        lifetime: None,
        lifetime_spread: 0.0,
        velocity: Vec3::new(0.0, 20.0, 5.0),
        velocity_decay: 0.3,
    });
    scene
}

/// Largest |a − b| over pairs, and the largest |b|.
fn largest_difference(a: &[Vec3], b: &[Vec3]) -> (f32, f32) {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .fold((0.0f32, 0.0f32), |(error, size), (a, b)| {
            (error.max(a.distance(*b)), size.max(b.length()))
        })
}

#[test]
fn noise_and_gradient_match_the_cpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let probe = FlowProbe::new(context, &demo_scene()).unwrap();
    // Noise coordinates as the field forms them: x / L plus offsets of up
    // to 16 cells, both signs.
    let mut at = points(400, Vec3::splat(-20.0), Vec3::splat(25.0));
    at.push(Vec3::new(3.0, -2.0, 5.0));
    let gpu = probe.noise(&at).unwrap();
    let (mut value_error, mut gradient_error, mut largest_gradient) = (0.0f32, 0.0f32, 0.0f32);
    for (p, (value, gradient)) in at.iter().zip(&gpu) {
        let (cpu_value, cpu_gradient) = firn_flow::noise::noise(*p);
        value_error = value_error.max((value - cpu_value).abs());
        gradient_error = gradient_error.max(gradient.distance(cpu_gradient));
        largest_gradient = largest_gradient.max(cpu_gradient.length());
    }
    eprintln!(
        "noise: |Δn| ≤ {value_error:e}, |Δ∇n| ≤ {gradient_error:e} (|∇n| ≤ {largest_gradient})"
    );
    assert!(value_error <= 2e-6, "noise values differ by {value_error}");
    assert!(
        gradient_error <= 2e-5,
        "noise gradients differ by {gradient_error}"
    );
    assert!(largest_gradient > 1.0, "the points reach steep noise");
    // A lattice point: only its own kernel is non-zero, and g · d = 0 there.
    assert_eq!(gpu.last().unwrap().0, 0.0);
}

/// Points of the demo's box, a third of them within the sphere's influence.
fn field_points() -> Vec<Vec3> {
    let mut at = points(200, Vec3::ZERO, Vec3::splat(100.0));
    let near = points(100, Vec3::splat(-25.0), Vec3::splat(25.0));
    at.extend(
        near.iter()
            .map(|d| Vec3::splat(50.0) + d.normalize() * (15.5 + d.length() * 0.35)),
    );
    at
}

/// Largest |v_gpu − v_cpu| / max(|v_cpu|, 1) at `field_points` at time `t`.
fn field_error(scene: &Scene, probe: &FlowProbe, t: f64) -> f32 {
    let field = FlowField::new(scene.kind.flow().unwrap());
    let at = field_points();
    let gpu = probe.velocities(&at, t).unwrap();
    at.iter()
        .zip(&gpu)
        .map(|(x, v)| {
            let cpu = field.velocity(*x, t);
            v.distance(cpu) / cpu.length().max(1.0)
        })
        .fold(0.0, f32::max)
}

#[test]
fn velocities_match_the_cpu_field() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = demo_scene();
    let probe = FlowProbe::new(context.clone(), &scene).unwrap();
    let analytic = field_error(&scene, &probe, 0.0).max(field_error(&scene, &probe, 7.3));
    let variant = small_variant();
    let differences = field_error(&variant, &FlowProbe::new(context, &variant).unwrap(), 2.1);
    eprintln!("velocity: relative error {analytic:e} (exact curl), {differences:e} (differences)");
    assert!(analytic <= 2e-5, "exact curl differs by {analytic}");
    // Central differences over h = 0.05 m divide the potential's round-off
    // (about 1e-6 of |ψ| ≈ 20) by 2h.
    assert!(
        differences <= 1e-3,
        "difference curl differs by {differences}"
    );
}

/// The six points x ± h e_axis around each centre, in that order.
fn stencil(centres: &[Vec3], h: f32) -> Vec<Vec3> {
    let mut points = Vec::new();
    for x in centres {
        for axis in 0..3 {
            let step = Vec3::AXES[axis] * h;
            points.extend([*x + step, *x - step]);
        }
    }
    points
}

/// Central differences of `velocities` on `stencil` (f32 spacing as the
/// points really have it): ∂v/∂x_axis per centre and axis.
fn columns(stencil: &[Vec3], velocities: &[Vec3]) -> Vec<[DVec3; 3]> {
    (0..stencil.len() / 6)
        .map(|c| {
            std::array::from_fn(|axis| {
                let (ahead, behind) = (6 * c + 2 * axis, 6 * c + 2 * axis + 1);
                let spacing = f64::from(stencil[ahead][axis] - stencil[behind][axis]);
                (velocities[ahead] - velocities[behind]).as_dvec3() / spacing
            })
        })
        .collect()
}

#[test]
fn the_gpu_field_is_divergence_free() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let probe = FlowProbe::new(context, &demo_scene()).unwrap();
    // The ramp α has continuous second derivatives only, so differences
    // are not taken across the edge of the sphere's influence (r = 25 m).
    let centres: Vec<Vec3> = field_points()
        .into_iter()
        .filter(|x| (x.distance(Vec3::splat(50.0)) - 25.0).abs() > 0.3)
        .collect();
    // Richardson extrapolation of steps h and h/2 cancels the h² error of
    // central differences. What is left is f32 round-off of v divided by h:
    // the CPU's f32 field measures the same 1.1e-4 here, its f64 field 1e-5.
    let h = 0.2;
    let differences = |h: f32| {
        let points = stencil(&centres, h);
        columns(&points, &probe.velocities(&points, 1.0).unwrap())
    };
    let (coarse, fine) = (differences(h), differences(0.5 * h));
    let (mut worst, mut gradient_sum) = (0.0f64, 0.0f64);
    for (coarse, fine) in coarse.iter().zip(&fine) {
        let jacobian: [DVec3; 3] =
            std::array::from_fn(|axis| (4.0 * fine[axis] - coarse[axis]) / 3.0);
        let divergence = jacobian[0].x + jacobian[1].y + jacobian[2].z;
        let gradient = jacobian
            .iter()
            .map(|column| column.length_squared())
            .sum::<f64>()
            .sqrt();
        gradient_sum += gradient;
        worst = worst.max(divergence.abs() / gradient.max(0.1));
    }
    let mean_gradient = gradient_sum / centres.len() as f64;
    eprintln!("divergence: |∇·v| ≤ {worst:e} |∇v| (mean |∇v| = {mean_gradient:.3} 1/s)");
    assert!(mean_gradient > 0.5, "the field has structure");
    assert!(worst <= 3e-4, "|∇·v| / |∇v| reaches {worst}");
}

#[test]
fn births_match_the_cpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let mut scene = small_variant();
    let settings = settings_of(&mut scene);
    settings.seed = 0xDEAD_BEEF_1234;
    let settings = settings.clone();
    let probe = FlowProbe::new(context, &scene).unwrap();
    let requests: Vec<[u32; 3]> = (0..settings.emitters.len() as u32)
        .flat_map(|e| (0..200u32).map(move |i| [e, i * 7919, i % 5]))
        .collect();
    let gpu = probe.births(&requests).unwrap();
    let (mut position_error, mut lifetime_error) = (0.0f32, 0.0f32);
    for (request, (position, lifetime)) in requests.iter().zip(&gpu) {
        let emitter = &settings.emitters[request[0] as usize];
        let (id, generation) = (u64::from(request[1]), u64::from(request[2]));
        let cpu = firn_flow::emitters::birth_position(emitter, settings.seed, id, generation);
        let cpu_lifetime = firn_flow::emitters::lifetime(emitter, settings.seed, id, generation);
        position_error = position_error.max(position.distance(cpu));
        if cpu_lifetime.is_infinite() {
            assert_eq!(*lifetime, cpu_lifetime);
        } else {
            lifetime_error = lifetime_error.max((lifetime - cpu_lifetime).abs() / cpu_lifetime);
        }
    }
    eprintln!("births: |Δx| ≤ {position_error:e} m, relative |Δlifetime| ≤ {lifetime_error:e}");
    // Disc and ball births use sin, cos and the cube root; radii are ≤ 40 m.
    assert!(
        position_error <= 1e-4,
        "birth positions differ by {position_error} m"
    );
    assert!(
        lifetime_error <= 1e-6,
        "lifetimes differ by {lifetime_error}"
    );
}

/// Runs `scene` to `until` on both backends in frames, checking that they
/// take the same substeps; returns the final snapshots.
fn run_both(scene: &Scene, until: f64) -> Option<(FlowSnapshot, FlowSnapshot)> {
    let context = context_for_tests()?;
    let mut cpu = FlowSimulation::new(scene.clone()).unwrap();
    let mut gpu = GpuFlow::new(context, scene.clone()).unwrap();
    assert_eq!(gpu.snapshot().unwrap(), cpu.snapshot(), "both start alike");
    let frame = 1.0 / scene.time.fps;
    let mut t = 0.0;
    while t < until - 1e-9 {
        t += frame;
        assert_eq!(gpu.advance_to(t).unwrap(), cpu.advance_to(t));
        assert_eq!(gpu.len(), cpu.len());
        assert_eq!(gpu.time(), cpu.time());
    }
    Some((cpu.snapshot(), gpu.snapshot().unwrap()))
}

/// Compares two runs' final states (at least `minimum_rebirths` in the
/// CPU's); returns the largest position error of particles in the same life.
fn compare_runs(cpu: &FlowSnapshot, gpu: &FlowSnapshot, label: &str, minimum_rebirths: u32) -> f32 {
    assert_eq!(gpu.births, cpu.births);
    assert_eq!(gpu.substeps, cpu.substeps);
    assert_eq!(gpu.positions.len(), cpu.positions.len());
    assert_eq!(gpu.emitters, cpu.emitters);
    let same_life: Vec<usize> = (0..cpu.positions.len())
        .filter(|p| gpu.generations[*p] == cpu.generations[*p])
        .collect();
    let reborn: u32 = cpu.generations.iter().sum();
    let differing = cpu.positions.len() - same_life.len();
    let pick = |values: &[Vec3]| same_life.iter().map(|p| values[*p]).collect::<Vec<_>>();
    let (position_error, _) = largest_difference(&pick(&gpu.positions), &pick(&cpu.positions));
    let (velocity_error, speed) =
        largest_difference(&pick(&gpu.velocities), &pick(&cpu.velocities));
    let centre = |positions: Vec<Vec3>| {
        positions.iter().map(|x| x.as_dvec3()).sum::<DVec3>() / positions.len() as f64
    };
    let centre_error = centre(pick(&gpu.positions)).distance(centre(pick(&cpu.positions)));
    eprintln!(
        "{label}: {} particles, {reborn} rebirths, {differing} in another life; \
         |Δx| ≤ {position_error:e} m, |Δv| ≤ {velocity_error:e} m/s (|v| ≤ {speed}), \
         centres of mass {centre_error:e} m apart",
        cpu.positions.len()
    );
    assert!(
        reborn >= minimum_rebirths,
        "{label}: the run exercises rebirth"
    );
    // A particle within round-off of the domain's boundary or of the end of
    // its life may be reborn on one backend a substep before the other.
    assert!(
        differing * 200 <= cpu.positions.len(),
        "{label}: {differing} lives differ"
    );
    assert!(
        centre_error <= 1e-3,
        "{label}: centres of mass {centre_error} m apart"
    );
    assert!(
        velocity_error <= 1e-3 * speed,
        "{label}: velocities differ by {velocity_error}"
    );
    position_error
}

#[test]
fn a_second_of_the_small_demo_follows_the_cpu() {
    let scene = small_demo();
    let Some((cpu, gpu)) = run_both(&scene, 1.0) else {
        return;
    };
    let position_error = compare_runs(&cpu, &gpu, "RK2, exact curl", 1000);
    assert!(
        position_error <= 1e-3,
        "positions differ by {position_error} m"
    );
    assert_eq!(gpu.trail_capacity, cpu.trail_capacity);
    assert_eq!(gpu.trail_head, cpu.trail_head);
    assert_eq!(gpu.trail_lengths.len(), cpu.trail_lengths.len());
    let same = (0..cpu.trail_lengths.len())
        .filter(|p| gpu.trail_generations[*p] == cpu.trail_generations[*p])
        .filter(|p| gpu.trail_lengths[*p] == cpu.trail_lengths[*p])
        .count();
    assert!(same * 200 >= cpu.trail_lengths.len() * 199, "trails differ");
    let ring = cpu.trail_capacity as usize;
    let trail_error = (0..cpu.trail_lengths.len())
        .filter(|p| gpu.trail_generations[*p] == cpu.trail_generations[*p])
        .flat_map(|p| p * ring..p * ring + cpu.trail_lengths[p] as usize)
        .map(|slot| gpu.trail_points[slot].distance(cpu.trail_points[slot]))
        .fold(0.0, f32::max);
    eprintln!(
        "trails: {same} of {} alike, points ≤ {trail_error:e} m apart",
        cpu.trail_lengths.len()
    );
    assert!(
        trail_error <= 1e-3,
        "trail points differ by {trail_error} m"
    );
}

#[test]
fn the_bundled_demo_follows_the_cpu() {
    let Some((cpu, gpu)) = run_both(&demo_scene(), 0.5) else {
        return;
    };
    let position_error = compare_runs(&cpu, &gpu, "the bundled demo", 10);
    assert!(
        position_error <= 1e-3,
        "positions differ by {position_error} m"
    );
}

#[test]
fn rk4_differences_and_kicks_follow_the_cpu() {
    let mut scene = small_variant();
    scene
        .render
        .styles
        .retain(|style| *style != RenderStyle::Trails);
    let Some((cpu, gpu)) = run_both(&scene, 0.5) else {
        return;
    };
    assert_eq!(gpu.trail_capacity, 0);
    let position_error = compare_runs(&cpu, &gpu, "RK4, central differences, kicks", 300);
    assert!(
        position_error <= 5e-3,
        "positions differ by {position_error} m"
    );
}

#[test]
fn snapshots_continue_bit_for_bit() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = small_demo();
    let mut first = GpuFlow::new(context.clone(), scene.clone()).unwrap();
    first.advance_to(0.3).unwrap();
    let middle = first.snapshot().unwrap();
    // The CPU takes the GPU's state as its own.
    FlowSimulation::from_snapshot(scene.clone(), middle.clone()).unwrap();
    let mut second = GpuFlow::from_snapshot(context, scene.clone(), &middle).unwrap();
    assert_eq!(second.time(), first.time());
    assert_eq!(second.snapshot().unwrap(), middle);
    assert_eq!(first.advance_to(0.6).unwrap(), 18);
    assert_eq!(second.advance_to(0.6).unwrap(), 18);
    assert_eq!(second.snapshot().unwrap(), first.snapshot().unwrap());
    assert_eq!(first.len(), second.len());
    assert!(first.memory_bytes() > 0 && first.memory_bytes() == second.memory_bytes());
}

#[test]
fn snow_scenes_and_mismatched_snapshots_are_refused() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/snowball-drop.toml"
    );
    let snow = Scene::load(path.as_ref()).unwrap();
    assert!(matches!(
        GpuFlow::check_supported(&snow),
        Err(GpuError::Unsupported { .. })
    ));
    assert!(GpuFlow::check_supported(&demo_scene()).is_ok());
    let Some(context) = context_for_tests() else {
        return;
    };
    let mut snapshot = FlowSimulation::new(small_demo()).unwrap().snapshot();
    snapshot.births.push(0);
    let refused = GpuFlow::from_snapshot(context, small_demo(), &snapshot);
    assert!(matches!(refused, Err(GpuError::Flow(_))));
}
