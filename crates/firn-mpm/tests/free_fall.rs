//! A body in free fall follows x0 + v0 t + g t²/2 until it touches anything.

mod common;

use firn_mpm::Simulation;
use glam::Vec3;

#[test]
fn free_fall_matches_the_analytic_trajectory() {
    for transfer in common::TRANSFERS {
        let v0 = Vec3::new(0.4, 1.0, -0.3);
        let scene = common::snowball(Vec3::new(0.4, 0.6, 0.5), v0, transfer);
        let dt = 5e-4f64;
        let mut simulation = Simulation::new(scene).unwrap();
        let start = simulation.diagnostics().center_of_mass;
        let t = 0.2;
        simulation.advance_to(t).unwrap();
        let end = simulation.diagnostics().center_of_mass;
        let g = -9.81f64;
        // Symplectic Euler (velocity first, then position) adds g t Δt / 2.
        let expected = [
            start[0] + v0.x as f64 * t,
            start[1] + v0.y as f64 * t + 0.5 * g * (t * t + t * dt),
            start[2] + v0.z as f64 * t,
        ];
        for axis in 0..3 {
            let error = (end[axis] - expected[axis]).abs();
            assert!(
                error < 2e-4,
                "{transfer:?} axis {axis}: {} vs {} (error {error})",
                end[axis],
                expected[axis]
            );
        }
        // No deformation in free fall: J_P stays 1 and the body keeps its shape.
        let plastic = &simulation.particles().plastic_j;
        assert!(
            plastic.iter().all(|j| (j - 1.0).abs() < 1e-4),
            "{transfer:?} deformed in free fall"
        );
    }
}
