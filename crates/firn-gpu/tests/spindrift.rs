//! Spindrift (`[wind.spindrift]`) on the GPU against the CPU solver, its
//! reference: the scene's mass is conserved bit for bit across the
//! hand-overs between snow, drift and the escaped tally; the drift per
//! frame (count, mass, centroid) follows the CPU's, and from the same
//! state both lift the same particles; a wind below the
//! threshold changes no bit; the drift moves downwind; and a run resumed
//! from a snapshot with drift in the air continues as the straight run.
//!
//! The draws hash the bits of each particle's position, and the GPU's
//! positions differ from the CPU's by round-off after the first gather, so
//! the two backends lift different (equally likely) particles: the drift is
//! compared as a sample, its count and mass within a few standard
//! deviations of a binomial draw and its centroid within a cell.

use firn_core::Scene;
use firn_gpu::{GpuSnow, context_for_tests};
use firn_mpm::{Drift, Escaped, Particles, Simulation};
use glam::Vec3;

/// A slab of fresh powder (100 kg/m³) on the floor of a small box in a
/// steady `speed` m/s wind along +x, with fast spindrift.
fn slab(speed: f32, threshold: f32) -> Scene {
    let text = format!(
        r#"format = 1
name = "slab-in-wind"

[domain]
max = [0.64, 0.32, 0.4]
cell_size = 0.04

[time]
duration = 0.1
fps = 50
step = "fixed"
dt = 5e-4

[solver]
transfer = "apic"

[materials.fresh]
preset = "snow"
density = 100.0

[[bodies]]
shape = "box"
center = [0.2, 0.06, 0.2]
size = [0.24, 0.12, 0.24]
material = "fresh"

[wind]
background_direction = [1.0, 0.0, 0.0]
background_strength = {speed}
noise_share = 0.0

[wind.spindrift]
threshold_speed = {threshold}
rate = 40.0
fall_speed = 0.5
"#
    );
    Scene::from_toml_str(&text, "slab.toml").expect("the test scene is valid")
}

/// Σ m_p of snow in f64.
fn snow_mass(particles: &Particles) -> f64 {
    particles.mass.iter().map(|&m| f64::from(m)).sum()
}

/// Mass-weighted centroid of the drift.
fn centroid(drift: &Drift) -> Vec3 {
    let weighted = drift
        .position
        .iter()
        .zip(&drift.mass)
        .fold(Vec3::ZERO, |sum, (x, &m)| sum + *x * m);
    weighted / drift.mass.iter().sum::<f32>()
}

/// Snow, drift and escaped mass of a state.
fn balance(particles: &Particles, drift: &Drift, escaped: &Escaped) -> f64 {
    snow_mass(particles) + drift.total_mass() + escaped.mass
}

/// Every snow and drift attribute, as sorted bits of each particle's own
/// record (the particles' order differs with the history of hand-overs).
fn sorted_records(particles: &Particles, drift: &Drift) -> Vec<Vec<u32>> {
    let bits = |values: &[f32]| values.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    let mut records: Vec<Vec<u32>> = (0..particles.len())
        .map(|p| {
            let mut record = bits(&particles.position[p].to_array());
            record.extend(bits(&particles.velocity[p].to_array()));
            record.extend(bits(&particles.elastic[p].to_cols_array()));
            record.extend(bits(&[particles.mass[p], particles.plastic_j[p]]));
            record
        })
        .collect();
    records.extend((0..drift.len()).map(|p| {
        let mut record = vec![u32::MAX];
        record.extend(bits(&drift.position[p].to_array()));
        record.extend(bits(&drift.velocity[p].to_array()));
        record.extend(bits(&[drift.mass[p], drift.volume[p]]));
        record
    }));
    records.sort_unstable();
    records
}

/// [`slab`] at rest without gravity in a wind without drag: nothing moves
/// in the first substep, so the CPU and the GPU hold the same bits when
/// they draw, and (the slab's windward face being fully exposed, its
/// inside fully sheltered) lift the same particles.
fn slab_at_rest() -> Scene {
    let mut scene = slab(8.0, 5.0);
    scene.solver.gravity = Vec3::ZERO;
    let wind = scene.wind.as_mut().unwrap();
    wind.drag = 0.0;
    wind.spindrift.as_mut().unwrap().rate = 1000.0;
    scene
}

/// The drift's positions as sorted bits.
fn sorted_positions(drift: &Drift) -> Vec<[u32; 3]> {
    let mut bits: Vec<[u32; 3]> = drift
        .position
        .iter()
        .map(|x| x.to_array().map(f32::to_bits))
        .collect();
    bits.sort_unstable();
    bits
}

#[test]
fn the_gpu_draws_the_numbers_the_cpu_draws() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = slab_at_rest();
    let dt = 5e-4;
    let mut cpu = Simulation::new(scene.clone()).unwrap();
    let mut gpu = GpuSnow::new(context, scene).unwrap();
    cpu.advance_to(dt).unwrap();
    gpu.advance_to(dt).unwrap();
    let state = gpu.snapshot().unwrap();
    let (on_cpu, on_gpu) = (
        sorted_positions(cpu.drift()),
        sorted_positions(&state.drift),
    );
    eprintln!(
        "one substep: {} lifted on the CPU, {} on the GPU",
        on_cpu.len(),
        on_gpu.len()
    );
    assert!(on_cpu.len() > 10, "only {} particles lifted", on_cpu.len());
    assert_eq!(on_cpu, on_gpu, "the backends lifted different particles");
}

#[test]
fn the_gpu_conserves_the_mass_of_the_scene_exactly() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = slab(8.0, 5.0);
    let mut gpu = GpuSnow::new(context, scene.clone()).unwrap();
    let start = gpu.snapshot().unwrap();
    let total = snow_mass(&start.particles);
    let count = start.particles.len();
    let mut lifted = false;
    for frame in 1..=5 {
        gpu.advance_to(f64::from(frame) * 0.02).unwrap();
        let state = gpu.snapshot().unwrap();
        assert_eq!(
            balance(&state.particles, &state.drift, &state.escaped),
            total,
            "t = {}: snow + drift + escaped mass differ from the start",
            gpu.time()
        );
        assert_eq!(
            state.particles.len() + state.drift.len() + state.escaped.count as usize,
            count
        );
        lifted |= !state.drift.is_empty() || state.escaped.count > 0;
    }
    assert!(lifted, "no snow lifted on the GPU");
}

#[test]
fn drift_on_the_gpu_follows_the_cpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = slab(8.0, 5.0);
    let h = scene.domain.cell_size;
    let mut cpu = Simulation::new(scene.clone()).unwrap();
    let mut gpu = GpuSnow::new(context, scene).unwrap();
    for frame in 1..=5 {
        let until = f64::from(frame) * 0.02;
        cpu.advance_to(until).unwrap();
        gpu.advance_to(until).unwrap();
        let state = gpu.snapshot().unwrap();
        let (on_cpu, on_gpu) = (cpu.drift(), &state.drift);
        let airborne = |drift: &Drift, escaped: &Escaped| drift.len() as f64 + escaped.count as f64;
        let (n_cpu, n_gpu) = (
            airborne(on_cpu, &cpu.escaped()),
            airborne(on_gpu, &state.escaped),
        );
        eprintln!(
            "t = {until}: drift {} CPU / {} GPU, escaped {} / {}, centroid {} / {}",
            on_cpu.len(),
            on_gpu.len(),
            cpu.escaped().count,
            state.escaped.count,
            centroid(on_cpu),
            centroid(on_gpu)
        );
        assert!(n_cpu > 20.0, "t = {until}: only {n_cpu} particles lifted");
        // Four standard deviations of the count a binomial draw gives.
        let spread = 4.0 * n_cpu.sqrt() + 4.0;
        assert!(
            (n_cpu - n_gpu).abs() <= spread,
            "t = {until}: {n_cpu} particles lifted on the CPU, {n_gpu} on the GPU"
        );
        let mass_cpu = on_cpu.total_mass() + cpu.escaped().mass;
        let mass_gpu = on_gpu.total_mass() + state.escaped.mass;
        assert!(
            (mass_cpu - mass_gpu).abs() <= spread / n_cpu * mass_cpu,
            "t = {until}: {mass_cpu} kg lifted on the CPU, {mass_gpu} kg on the GPU"
        );
        let shift = (centroid(on_cpu) - centroid(on_gpu)).abs().max_element();
        assert!(
            shift <= h,
            "t = {until}: the drift's centroids differ by {shift} m"
        );
    }
}

#[test]
fn a_wind_below_the_threshold_changes_no_bit() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let with = slab(8.0, 50.0);
    let mut without = with.clone();
    without.wind.as_mut().unwrap().spindrift = None;
    let run = |scene: Scene| {
        let mut gpu = GpuSnow::new(context.clone(), scene).unwrap();
        gpu.advance_to(0.04).unwrap();
        gpu.snapshot().unwrap()
    };
    let (calm, plain) = (run(with), run(without));
    assert!(calm.drift.is_empty() && calm.escaped.count == 0);
    assert_eq!(
        sorted_records(&calm.particles, &calm.drift),
        sorted_records(&plain.particles, &plain.drift)
    );
    assert_eq!(calm.particles.position, plain.particles.position);
}

#[test]
fn drift_moves_downwind() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let mut gpu = GpuSnow::new(context, slab(8.0, 5.0)).unwrap();
    let start = gpu.snapshot().unwrap();
    let slab_x =
        start.particles.position.iter().map(|x| x.x).sum::<f32>() / start.particles.len() as f32;
    gpu.advance_to(0.06).unwrap();
    let state = gpu.snapshot().unwrap();
    assert!(!state.drift.is_empty(), "no drift in the air");
    let drift_x = centroid(&state.drift).x;
    assert!(
        drift_x > slab_x + 0.05,
        "the drift's centroid is at x = {drift_x}, the slab's at {slab_x}"
    );
    // Drift that lifted in the last substep still has the snow's velocity;
    // the rest moves with the air plus the fall.
    let expected = Vec3::new(8.0, -0.5, 0.0);
    let carried = state
        .drift
        .velocity
        .iter()
        .filter(|velocity| (**velocity - expected).abs().max_element() < 1e-3)
        .count();
    assert!(
        carried * 10 >= state.drift.len() * 9,
        "only {carried} of {} drift particles move with the air and the fall",
        state.drift.len()
    );
}

#[test]
fn a_run_resumed_with_drift_in_the_air_continues_as_the_straight_run() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = slab(8.0, 5.0);
    // Both take the same frames, so their substeps are the same.
    let frames = [0.02, 0.04, 0.06];
    let mut straight = GpuSnow::new(context.clone(), scene.clone()).unwrap();
    for until in frames {
        straight.advance_to(until).unwrap();
    }
    let mut first = GpuSnow::new(context.clone(), scene.clone()).unwrap();
    for until in &frames[..2] {
        first.advance_to(*until).unwrap();
    }
    let middle = first.snapshot().unwrap();
    assert!(!middle.drift.is_empty(), "no drift to resume with");
    let mut resumed = GpuSnow::from_snapshot(context, scene, &middle).unwrap();
    resumed.advance_to(0.06).unwrap();
    let (a, b) = (straight.snapshot().unwrap(), resumed.snapshot().unwrap());
    assert_eq!(
        sorted_records(&a.particles, &a.drift),
        sorted_records(&b.particles, &b.drift)
    );
    assert_eq!(a.escaped.count, b.escaped.count);
}
