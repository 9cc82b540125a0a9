//! Spindrift (`[wind.spindrift]`, `firn_mpm::spindrift`): loose surface snow
//! lifts into the wind and packed snow does not, mass is conserved exactly
//! across the hand-over, the drift moves with the air, a wind below the
//! threshold changes no bit, and runs are the same bits for any thread
//! count and instruction set.

mod common;

use firn_core::Material;
use firn_core::math::lanes::Simd;
use firn_core::scene::{Scene, Shape, Spindrift, Transfer, Wind};
use firn_mpm::{Drift, Particles, Simulation};
use glam::Vec3;

/// A slab of snow of `density` kg/m³ lying on the floor of the unit box, in
/// a steady wind of `speed` m/s along +x with spindrift.
fn slab(density: f32, speed: f32, spindrift: Spindrift) -> Scene {
    let mut scene = common::scene_with(
        Shape::Box {
            center: Vec3::new(0.4, 0.06, 0.5),
            size: Vec3::new(0.4, 0.12, 0.4),
        },
        Vec3::ZERO,
        Transfer::Apic,
        0.04,
    );
    scene.materials = vec![Material {
        density,
        ..Material::preset("snow").unwrap()
    }];
    scene.wind = Some(Wind {
        spindrift: Some(spindrift),
        ..Wind::uniform(Vec3::X, speed)
    });
    scene
}

/// Fast detachment, so that short runs lift plenty.
fn eager() -> Spindrift {
    Spindrift {
        rate: 40.0,
        ..Spindrift::default()
    }
}

fn run(scene: Scene, until: f64) -> Simulation {
    let mut simulation = Simulation::new(scene).unwrap();
    simulation.advance_to(until).unwrap();
    simulation
}

/// Every snow particle attribute as bits.
fn snow_bits(particles: &Particles) -> Vec<u32> {
    let vectors = particles.position.iter().chain(&particles.velocity);
    let floats = vectors
        .flat_map(|v| v.to_array())
        .chain(particles.mass.iter().copied());
    let matrices = particles.elastic.iter().chain(&particles.velocity_gradient);
    floats
        .chain(matrices.flat_map(|m| m.to_cols_array()))
        .chain(particles.plastic_j.iter().copied())
        .map(f32::to_bits)
        .collect()
}

/// Every drift attribute as bits.
fn drift_bits(drift: &Drift) -> Vec<u32> {
    let vectors = drift.position.iter().chain(&drift.velocity);
    vectors
        .flat_map(|v| v.to_array())
        .chain(drift.mass.iter().copied())
        .chain(drift.volume.iter().copied())
        .map(f32::to_bits)
        .collect()
}

/// The masses of the snow and the drift, as sorted bits.
fn mass_multiset(snow: &Particles, drift: &Drift) -> Vec<u32> {
    let mut masses: Vec<u32> = snow
        .mass
        .iter()
        .chain(&drift.mass)
        .map(|m| m.to_bits())
        .collect();
    masses.sort_unstable();
    masses
}

#[test]
fn loose_powder_lifts_and_packed_snow_does_not() {
    let powder = run(slab(100.0, 8.0, eager()), 0.05);
    let packed = run(slab(350.0, 8.0, eager()), 0.05);
    let initial = Simulation::new(slab(100.0, 8.0, eager())).unwrap();
    println!(
        "after 0.05 s: powder {} of {} particles in the air, packed {}",
        powder.drift().len(),
        initial.particles().len(),
        packed.drift().len()
    );
    assert!(
        powder.drift().len() > 20,
        "only {} powder particles lifted",
        powder.drift().len()
    );
    assert_eq!(packed.drift().len(), 0, "packed snow (350 kg/m³) lifted");
}

#[test]
fn only_the_surface_lifts() {
    let scene = slab(100.0, 8.0, eager());
    let start = Simulation::new(scene.clone()).unwrap();
    let top = start
        .particles()
        .position
        .iter()
        .map(|x| x.y)
        .fold(f32::MIN, f32::max);
    let mut simulation = Simulation::new(scene).unwrap();
    // One substep: the drift is where the snow it was lay.
    simulation.step(1.0).unwrap();
    let drift = simulation.drift();
    assert!(!drift.is_empty(), "nothing lifted in the first substep");
    let h = 0.04;
    let windward = 0.2 + h;
    for x in &drift.position {
        assert!(
            x.y > top - 1.5 * h || x.x < windward || x.z < 0.3 + h || x.z > 0.7 - h,
            "a particle at {x} lifted from inside the slab (top at y = {top})"
        );
    }
}

#[test]
fn mass_is_conserved_exactly_across_the_hand_over() {
    let scene = slab(100.0, 8.0, eager());
    let start = Simulation::new(scene.clone()).unwrap();
    let mut simulation = Simulation::new(scene).unwrap();
    let initial = mass_multiset(start.particles(), start.drift());
    let total: f64 = start.particles().mass.iter().map(|&m| f64::from(m)).sum();
    for frame in 1..=6 {
        simulation.advance_to(f64::from(frame) * 0.02).unwrap();
        let snow: f64 = simulation
            .particles()
            .mass
            .iter()
            .map(|&m| f64::from(m))
            .sum();
        let escaped = simulation.escaped();
        assert_eq!(
            snow + simulation.drift().total_mass() + escaped.mass,
            total,
            "t = {}: snow + drift + escaped mass differ from the start",
            simulation.time()
        );
        assert_eq!(
            simulation.particles().len() + simulation.drift().len() + escaped.count as usize,
            start.particles().len()
        );
        if escaped.count == 0 {
            assert_eq!(
                mass_multiset(simulation.particles(), simulation.drift()),
                initial
            );
        }
    }
    assert!(!simulation.drift().is_empty());
}

#[test]
fn drift_moves_with_the_air_and_falls() {
    let spindrift = eager();
    let mut simulation = Simulation::new(slab(100.0, 8.0, spindrift)).unwrap();
    simulation.advance_to(0.02).unwrap();
    let before = simulation.drift().clone();
    let dt = simulation.step(1.0).unwrap();
    let after = simulation.drift();
    // Particles keep their place in the drift arrays (new ones come last).
    let mut moved = 0;
    for p in 0..before.len().min(after.len()) {
        if after.mass[p] != before.mass[p] || after.volume[p] != before.volume[p] {
            break;
        }
        let velocity = after.velocity[p];
        let expected = Vec3::new(8.0, -spindrift.fall_speed, 0.0);
        assert!(
            (velocity - expected).abs().max_element() < 1e-3,
            "drift particle {p} moves at {velocity}, the air plus the fall at {expected}"
        );
        let step = after.position[p] - before.position[p];
        assert!((step - expected * dt).abs().max_element() < 1e-5);
        moved += 1;
    }
    assert!(moved > 0, "no drift particle was followed");
}

#[test]
fn drift_lands_and_settles_back_into_snow() {
    // A slow wind just over the threshold and a fast fall: the drift comes
    // down within the box.
    let settling = Spindrift {
        threshold_speed: 1.0,
        fall_speed: 3.0,
        ..eager()
    };
    let resting = Spindrift {
        settle: false,
        ..settling
    };
    let settled = run(slab(100.0, 2.0, settling), 0.1);
    let rested = run(slab(100.0, 2.0, resting), 0.1);
    let at_rest = rested
        .drift()
        .velocity
        .iter()
        .filter(|v| **v == Vec3::ZERO)
        .count();
    println!(
        "after 0.1 s: settle: {} snow, {} drift; rest: {} snow, {} drift ({at_rest} at rest)",
        settled.particles().len(),
        settled.drift().len(),
        rested.particles().len(),
        rested.drift().len()
    );
    assert!(at_rest > 0, "no drift landed");
    assert!(
        settled.particles().len() > rested.particles().len(),
        "drift that lands does not become snow again"
    );
    for x in &rested.drift().position {
        assert!(x.y >= 0.0, "drift at {x} went through the floor");
    }
}

#[test]
fn a_wind_below_the_threshold_changes_no_bit() {
    let calm = Spindrift {
        threshold_speed: 50.0,
        ..eager()
    };
    let with = run(slab(100.0, 8.0, calm), 0.03);
    let mut scene = slab(100.0, 8.0, calm);
    scene.wind.as_mut().unwrap().spindrift = None;
    let without = run(scene, 0.03);
    assert!(with.drift().is_empty());
    assert!(snow_bits(with.particles()) == snow_bits(without.particles()));
}

#[test]
fn spindrift_runs_are_the_same_bits_for_any_thread_count_and_instruction_set() {
    let run_on = |threads: usize, simd: Simd| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut scene = slab(120.0, 8.0, eager());
            let wind = scene.wind.as_mut().unwrap();
            wind.field.noise_share = 0.5;
            wind.field.length_scale = 0.3;
            wind.field.noise_strength = 0.3;
            wind.field.evolution_rate = 1.0;
            let mut simulation = Simulation::new(scene).unwrap();
            simulation.set_simd(simd);
            simulation.advance_to(0.04).unwrap();
            (
                snow_bits(simulation.particles()),
                drift_bits(simulation.drift()),
                simulation.escaped().mass.to_bits(),
            )
        })
    };
    let one = run_on(1, Simd::Portable);
    assert!(!one.1.is_empty(), "nothing lifted");
    for simd in [Simd::Portable, Simd::Avx2, Simd::Avx512] {
        if simd.is_available() {
            assert!(run_on(2, simd) == one, "{simd:?} on 2 threads differs");
        }
    }
}

#[test]
fn a_snapshot_continues_with_the_same_drift() {
    let scene = slab(100.0, 8.0, eager());
    let mut straight = Simulation::new(scene.clone()).unwrap();
    straight.advance_to(0.02).unwrap();
    straight.advance_to(0.04).unwrap();
    let mut first = Simulation::new(scene.clone()).unwrap();
    first.advance_to(0.02).unwrap();
    assert!(!first.drift().is_empty());
    let mut resumed = Simulation::from_snapshot(scene, first.snapshot()).unwrap();
    resumed.advance_to(0.04).unwrap();
    assert!(resumed.snapshot() == straight.snapshot());
}
