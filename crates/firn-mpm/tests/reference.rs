//! The fast solver's stages against the plain reference solver
//! (`firn_mpm::reference`) on random states, for both transfer schemes.
//!
//! Tolerances, and why:
//! Every tolerance is relative to the largest |value| of the quantity (over
//! the grid or the particles), about ten times the worst difference seen
//! over the cases of a run (in brackets, measured on 2026-11-25 with 12
//! random states per stage and scheme, and again on 2026-11-26 once the
//! PIC/FLIP transfers summed their stencils as tensor products; each check
//! prints its worst, so
//! `cargo test -p firn-mpm --test reference -- --nocapture 2>&1 | grep worst`
//! shows them):
//! - P2G: every node sums up to 64 (cubic) or 27 (quadratic) terms per
//!   particle in another order (block-local copies added colour by colour,
//!   APIC's terms built in SIMD lanes with the affine map factored
//!   differently). Each f32 addition rounds by at most 2⁻²⁴ of the running
//!   sum, so the difference stays within some ulps of the largest node
//!   value: 1e-5 (mass 6.4e-7, momentum 4.9e-7, force 6.5e-7).
//! - Grid update: the same IEEE operations node by node, but from node
//!   sums that differ as above: 1e-6 (v_i 1.1e-7, v_i^{n+1} 2.6e-7).
//! - G2P: the velocity and ∇v_p sum over the stencil in another order:
//!   1e-5 (v_p 2.4e-7, ∇v_p 9.5e-7). The snow model differs more: the fast
//!   path keeps F̂_E unchanged inside the yield surface and takes R_E from
//!   Newton's polar iteration, uses its own exponential, and evaluates in
//!   lanes; the reference always goes through the SVD. F_E and J_P: 1e-5
//!   (9.5e-7, 7.8e-7); the stress V_p^0 τ_p, a difference of nearly equal
//!   matrices (F_E − R_E) scaled by 2μ, loses digits to cancellation: 1e-4
//!   (1.4e-5); positions 1e-6 (7.9e-8). Every instruction set the CPU has
//!   is checked (they give the same bits; tests/determinism.rs).
//! - Whole substeps: the differences above feed back through the stress;
//!   after ten substeps positions agree to 1e-5 of a cell.

use firn_core::Material;
use firn_core::math::lanes::Simd;
use firn_core::scene::{Scene, Shape, Transfer, Wind};
use firn_mpm::binning::Bins;
use firn_mpm::contact::{ColliderSet, Colliders, PlacedCollider};
use firn_mpm::coupling::BodyContacts;
use firn_mpm::g2p::{self, UpdateContext};
use firn_mpm::grid::{Grid, GridLayout};
use firn_mpm::grid_update::{self, GridForces, WindStep};
use firn_mpm::p2g;
use firn_mpm::reference::{self, ReferenceGrid, ReferenceStep};
use firn_mpm::snow_model::MaterialConstants;
use firn_mpm::wind::AirDrag;
use firn_mpm::{Particles, Simulation, Snapshot};
use glam::{Mat3, Vec3};
use proptest::prelude::*;

mod common;

const DT: f32 = 2e-4;
const FLIP: f32 = 0.95;
const PARTICLES: usize = 1500;

/// A small random number generator (SplitMix64), so a failing case is
/// reproduced from its seed alone.
struct Random(u64);

impl Random {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in [−1, 1].
    fn signed(&mut self) -> f32 {
        2.0 * self.next() - 1.0
    }

    fn vector(&mut self) -> Vec3 {
        Vec3::new(self.signed(), self.signed(), self.signed())
    }

    fn matrix(&mut self) -> Mat3 {
        Mat3::from_cols(self.vector(), self.vector(), self.vector())
    }
}

/// The scene the states live in: a unit box, h = 1/16, the snow preset.
fn scene(transfer: Transfer) -> Scene {
    let mut scene = common::scene_with(
        Shape::Sphere {
            center: Vec3::splat(0.5),
            radius: 0.2,
        },
        Vec3::ZERO,
        transfer,
        1.0 / 16.0,
    );
    scene.solver.flip_blend = FLIP;
    scene
}

/// Particles in the middle of the box with random velocities, C_p, F_E
/// (half near the identity, inside the yield surface; half stretched and
/// sheared by up to 5 %, beyond it), J_P and stress.
fn random_particles(seed: u64, material: &Material) -> Particles {
    let mut random = Random(seed);
    let h = 1.0 / 16.0;
    let mass = material.density * h * h * h / 4.0;
    let mut particles = Particles::default();
    for p in 0..PARTICLES {
        let spread = if p % 2 == 0 { 0.002 } else { 0.05 };
        particles
            .position
            .push(Vec3::splat(0.5) + 0.25 * random.vector());
        particles.velocity.push(2.0 * random.vector());
        particles.mass.push(mass * (1.0 + 0.2 * random.signed()));
        particles.volume0.push(mass / material.density);
        particles
            .elastic
            .push(Mat3::IDENTITY + spread * random.matrix());
        particles.plastic_j.push(1.0 + 0.1 * random.signed());
        particles.stress.push(1e-2 * random.matrix());
        particles.velocity_gradient.push(5.0 * random.matrix());
        particles.material.push(0);
    }
    particles
}

/// Everything both solvers need for one substep of `scene`.
struct Setup {
    scene: Scene,
    layout: GridLayout,
    constants: Vec<MaterialConstants>,
    colliders: Vec<PlacedCollider>,
    wind: Option<AirDrag>,
}

/// Simulated time at which the wind of [`Setup::windy`] is taken.
const WIND_TIME: f64 = 0.3;

impl Setup {
    fn new(transfer: Transfer) -> Setup {
        let scene = scene(transfer);
        let domain = &scene.domain;
        Setup {
            layout: GridLayout::new(domain.min, domain.max, domain.cell_size),
            constants: MaterialConstants::of_each(&scene.materials),
            colliders: ColliderSet::new(domain, &scene.colliders).placed_at(0.0),
            wind: None,
            scene,
        }
    }

    /// The same setup in a turbulent, drifting wind of a few m/s whose drag
    /// relaxes loose snow within a few substeps, and with gravity.
    fn windy(transfer: Transfer) -> Setup {
        let mut wind = Wind::uniform(Vec3::new(0.6, 0.0, 0.8), 3.0);
        wind.field.noise_share = 0.5;
        wind.field.length_scale = 0.3;
        wind.field.noise_strength = 0.2;
        wind.field.evolution_rate = 0.5;
        wind.drag = 2e4;
        let mut setup = Setup::new(transfer);
        setup.scene.solver.gravity = Vec3::new(0.0, -9.81, 0.0);
        setup.wind = Some(AirDrag::new(&wind, setup.layout.cell_size));
        setup
    }

    /// The wind of one substep, if the setup has one.
    fn wind_step(&self) -> Option<WindStep<'_>> {
        self.wind.as_ref().map(|drag| WindStep {
            drag,
            time: WIND_TIME,
        })
    }

    fn transfer(&self) -> Transfer {
        self.scene.solver.transfer
    }

    fn step(&self) -> ReferenceStep<'_> {
        ReferenceStep {
            dt: DT,
            transfer: self.transfer(),
            flip: FLIP,
            gravity: self.scene.solver.gravity,
            materials: &self.constants,
            colliders: &self.colliders,
            wind: self.wind_step(),
        }
    }

    /// The fast scatter of `particles` onto a fresh grid.
    fn fast_p2g(&self, particles: &Particles) -> (Grid, Bins) {
        let domain = &self.scene.domain;
        let mut grid = Grid::new(domain.min, domain.max, domain.cell_size);
        let mut bins = Bins::default();
        bins.rebuild(&self.layout, &particles.position);
        let simd = Simd::detect();
        match self.transfer() {
            Transfer::PicFlip => p2g::scatter_pic_flip(&mut grid, &bins, particles, simd, None),
            Transfer::Apic => p2g::scatter_apic(&mut grid, &bins, particles, DT, simd, None),
        };
        (grid, bins)
    }

    /// The fast grid update of `grid`.
    fn fast_grid_update(&self, grid: &mut Grid) {
        let forces = match self.transfer() {
            Transfer::PicFlip => GridForces::Separate,
            Transfer::Apic => GridForces::InMomentum,
        };
        let colliders = Colliders::new(&self.colliders);
        grid_update::update_grid(
            grid,
            forces,
            DT,
            self.scene.solver.gravity,
            &colliders,
            self.wind_step(),
            &BodyContacts::default(),
        );
    }
}

/// The fast grid's nodes copied into a dense reference grid.
fn dense_copy(grid: &Grid) -> ReferenceGrid {
    let mut dense = ReferenceGrid::new(grid.layout);
    for (block, nodes) in grid.blocks() {
        for (local, node) in nodes.iter().enumerate() {
            let index = dense.index(GridLayout::node_in_block(block, local));
            dense.mass[index] = node.mass();
            dense.velocity[index] = node.velocity();
            dense.velocity_new[index] = node.velocity_new();
        }
    }
    dense
}

/// The largest |value| over all entries.
fn largest<T: Copy>(values: &[T], size: impl Fn(T) -> f32) -> f32 {
    values.iter().map(|&v| size(v)).fold(0.0, f32::max)
}

/// Asserts that `fast` and `plain` agree entry by entry within `relative`
/// times the largest entry of `plain`; names the first entry that does not.
fn assert_close<T: Copy + std::fmt::Debug>(
    what: &str,
    fast: &[T],
    plain: &[T],
    relative: f32,
    difference: impl Fn(T, T) -> f32,
    size: impl Fn(T) -> f32,
) {
    assert_eq!(fast.len(), plain.len(), "{what}: lengths differ");
    let scale = largest(plain, &size).max(f32::MIN_POSITIVE);
    let tolerance = relative * scale;
    let worst = fast
        .iter()
        .zip(plain)
        .map(|(&a, &b)| difference(a, b))
        .fold(0.0f32, f32::max);
    eprintln!(
        "{what}: worst {:.1e} of the largest value (tolerance {relative:.0e})",
        worst / scale
    );
    for (index, (&a, &b)) in fast.iter().zip(plain).enumerate() {
        let off = difference(a, b);
        assert!(
            off <= tolerance,
            "{what} {index}: fast {a:?}, reference {b:?}, off by {off:e} > {tolerance:e}"
        );
    }
}

fn vectors(what: &str, fast: &[Vec3], plain: &[Vec3], relative: f32) {
    assert_close(
        what,
        fast,
        plain,
        relative,
        |a, b| (a - b).abs().max_element(),
        |v| v.abs().max_element(),
    );
}

fn matrices(what: &str, fast: &[Mat3], plain: &[Mat3], relative: f32) {
    let size = |m: Mat3| m.to_cols_array().iter().fold(0.0f32, |s, v| s.max(v.abs()));
    assert_close(what, fast, plain, relative, |a, b| size(a - b), size);
}

fn scalars(what: &str, fast: &[f32], plain: &[f32], relative: f32) {
    assert_close(what, fast, plain, relative, |a, b| (a - b).abs(), f32::abs);
}

/// Steps 1 and 3 on both sides from the same particles.
fn check_p2g(transfer: Transfer, seed: u64) {
    let setup = Setup::new(transfer);
    let particles = random_particles(seed, &setup.scene.materials[0]);
    let (grid, _) = setup.fast_p2g(&particles);
    let fast = dense_copy(&grid);
    let mut plain = ReferenceGrid::new(setup.layout);
    reference::particles_to_grid(&particles, &mut plain, &setup.step());
    scalars("node mass", &fast.mass, &plain.mass, 1e-5);
    vectors("node momentum", &fast.velocity, &plain.velocity, 1e-5);
    vectors("node force", &fast.velocity_new, &plain.velocity_new, 1e-5);
}

/// Steps 4 and 5 on both sides from the same scattered grid.
fn check_grid_update(transfer: Transfer, seed: u64) {
    check_grid_update_of(&Setup::new(transfer), seed);
}

/// Steps 4 and 5 of `setup` on both sides from the same scattered grid.
fn check_grid_update_of(setup: &Setup, seed: u64) {
    let particles = random_particles(seed, &setup.scene.materials[0]);
    let (mut grid, _) = setup.fast_p2g(&particles);
    let mut plain = dense_copy(&grid);
    setup.fast_grid_update(&mut grid);
    let fast = dense_copy(&grid);
    reference::update_grid_velocities(&mut plain, &setup.step());
    vectors("v_i", &fast.velocity, &plain.velocity, 1e-6);
    vectors("v_i^{n+1}", &fast.velocity_new, &plain.velocity_new, 1e-6);
}

/// Steps 7-10 on both sides from the same grid and particles.
fn check_g2p(transfer: Transfer, seed: u64) {
    let setup = Setup::new(transfer);
    let fast = random_particles(seed, &setup.scene.materials[0]);
    let (mut grid, bins) = setup.fast_p2g(&fast);
    setup.fast_grid_update(&mut grid);
    let dense = dense_copy(&grid);
    let mut plain = fast.clone();
    let colliders = Colliders::new(&setup.colliders);
    let margin = Vec3::splat(setup.layout.cell_size);
    let context = UpdateContext {
        dt: DT,
        materials: &setup.constants,
        colliders: &colliders,
        lower: setup.scene.domain.min - margin,
        upper: setup.scene.domain.max + margin,
        keys: None,
    };
    reference::grid_to_particles(&mut plain, &dense, &setup.step());
    let start = fast;
    for simd in [Simd::Portable, Simd::Avx2, Simd::Avx512] {
        if !simd.is_available() {
            continue;
        }
        let mut fast = start.clone();
        let stats = match transfer {
            Transfer::PicFlip => {
                g2p::gather_pic_flip(&grid, &bins, &mut fast, FLIP, &context, simd)
            }
            Transfer::Apic => g2p::gather_apic(&grid, &bins, &mut fast, &context, simd),
        };
        assert_eq!(stats.problem, None);
        check_particles(&fast, &plain);
    }
}

/// The particles after G2P, fast against plain, within the tolerances of
/// the module docs.
fn check_particles(fast: &Particles, plain: &Particles) {
    vectors("v_p", &fast.velocity, &plain.velocity, 1e-5);
    matrices(
        "∇v_p",
        &fast.velocity_gradient,
        &plain.velocity_gradient,
        1e-5,
    );
    matrices("F_E", &fast.elastic, &plain.elastic, 1e-5);
    scalars("J_P", &fast.plastic_j, &plain.plastic_j, 1e-5);
    matrices("V_p^0 τ_p", &fast.stress, &plain.stress, 1e-4);
    vectors("x_p", &fast.position, &plain.position, 1e-6);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    #[test]
    fn p2g_matches_the_reference(seed in any::<u64>()) {
        for transfer in common::TRANSFERS {
            check_p2g(transfer, seed);
        }
    }

    #[test]
    fn grid_update_matches_the_reference(seed in any::<u64>()) {
        for transfer in common::TRANSFERS {
            check_grid_update(transfer, seed);
        }
    }

    #[test]
    fn grid_update_in_a_wind_matches_the_reference(seed in any::<u64>()) {
        for transfer in common::TRANSFERS {
            check_grid_update_of(&Setup::windy(transfer), seed);
        }
    }

    #[test]
    fn g2p_matches_the_reference(seed in any::<u64>()) {
        for transfer in common::TRANSFERS {
            check_g2p(transfer, seed);
        }
    }
}

/// Ten whole substeps of the fast solver against ten of the reference, from
/// the same random state: positions agree to 1e-5 of a cell.
#[test]
fn whole_substeps_match_the_reference() {
    for transfer in common::TRANSFERS {
        let setup = Setup::new(transfer);
        let mut scene = setup.scene.clone();
        scene.time.step = firn_core::scene::TimeStep::Fixed { dt: DT };
        let particles = random_particles(11, &scene.materials[0]);
        let snapshot = Snapshot {
            time: 0.0,
            steps: 1,
            max_speed_squared: 0.0,
            max_wave_speed_squared: 0.0,
            particles: particles.clone(),
            drift: Default::default(),
            escaped: Default::default(),
            rigid: None,
        };
        let mut fast = Simulation::from_snapshot(scene, snapshot).unwrap();
        let mut plain = particles;
        let mut grid = ReferenceGrid::new(setup.layout);
        for _ in 0..10 {
            fast.step(f64::INFINITY).unwrap();
            reference::reference_step(&mut plain, &mut grid, &setup.step());
        }
        // With steps 1 to 10 the fast solver never reorders its particles
        // (it does every 16 substeps), so both keep the same order.
        let fast = fast.snapshot().particles;
        assert_eq!(
            fast.mass, plain.mass,
            "{transfer:?}: the particle order changed"
        );
        let cell = setup.layout.cell_size;
        for (p, (a, b)) in fast.position.iter().zip(&plain.position).enumerate() {
            let off = (*a - *b).abs().max_element();
            assert!(
                off <= 1e-5 * cell,
                "{transfer:?}: particle {p} at {a} fast, {b} reference, {off:e} m apart"
            );
        }
    }
}
