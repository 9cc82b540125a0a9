//! The per-particle values pictures are coloured by, for every renderer
//! (the offscreen one, and the viewer's).

use firn_core::scene::ColorBy;

use crate::Simulation;

impl Simulation {
    /// Per-particle values of `color_by` (none for colourings that need no
    /// values): density m_p / V_p, plastic J_P or speed |v_p|.
    pub fn color_values(&self, color_by: ColorBy) -> Option<Vec<f32>> {
        let particles = self.particles();
        match color_by {
            ColorBy::Density => Some(self.densities()),
            ColorBy::PlasticJ => Some(particles.plastic_j.clone()),
            ColorBy::Speed => Some(particles.velocity.iter().map(|v| v.length()).collect()),
            ColorBy::Position | ColorBy::Uniform => None,
        }
    }
}
