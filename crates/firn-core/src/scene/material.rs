//! Snow materials: the constitutive parameters of Stomakhin et al. 2013 and the
//! named presets a scene can start from.

use serde::{Deserialize, Serialize};

/// Parameters of the elasto-plastic snow model (thesis eq. 34-36, 41-43).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Name the scene refers to this material by.
    pub name: String,
    /// Young's modulus E0 in Pa.
    pub youngs_modulus: f32,
    /// Poisson's ratio ν, in (-1, 0.5).
    pub poisson_ratio: f32,
    /// Hardening coefficient ξ: how fast the material stiffens under compression.
    pub hardening: f32,
    /// Critical compression θc: singular values of F_E are clamped below at 1 − θc.
    pub critical_compression: f32,
    /// Critical stretch θs: singular values of F_E are clamped above at 1 + θs.
    pub critical_stretch: f32,
    /// Initial density ρ0 in kg/m³.
    pub density: f32,
}

/// Names of the built-in material presets, in the order `firn presets` lists them.
pub const PRESET_NAMES: [&str; 6] = ["snow", "thesis", "powder", "wet", "icy", "slush"];

impl Material {
    /// The preset a body without a material gets, and the one a
    /// `[materials.NAME]` table without `preset` starts from: `"snow"`.
    pub const DEFAULT_PRESET: &'static str = "snow";

    /// Lamé parameters (μ0, λ0) from E0 and ν (thesis eq. 36).
    pub fn lame(&self) -> (f32, f32) {
        let e = self.youngs_modulus;
        let nu = self.poisson_ratio;
        let mu = e / (2.0 * (1.0 + nu));
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        (mu, lambda)
    }

    /// Hardening factor e^{ξ(1 − J_P)} that scales μ and λ (thesis eq. 35).
    pub fn hardening_factor(&self, plastic_j: f32) -> f32 {
        crate::math::exp::exp(self.hardening * (1.0 - plastic_j))
    }

    /// Speed of elastic (P-) waves sqrt((λ + 2μ)/ρ) for a hardening factor,
    /// used by the adaptive time step.
    pub fn wave_speed(&self, hardening_factor: f32, density: f32) -> f32 {
        let (mu, lambda) = self.lame();
        ((lambda + 2.0 * mu) * hardening_factor / density).sqrt()
    }

    /// A named preset, or `None` if there is no preset of that name.
    ///
    /// - `snow`: Stomakhin et al. 2013, Table 2 (thesis Tabelle 2) with ρ0 = 400.
    /// - `thesis`: the thesis' test scene (§6.3): E = 1e6, ν = 0.3, ξ = 0.1 as printed.
    /// - `powder`: light dry snow, small critical compression and stretch (breaks apart).
    /// - `wet`: dense wet snow, larger θc and θs (deforms plastically and stays compact).
    /// - `icy`: high hardening and stiffness.
    /// - `slush`: low hardening and stiffness, heavy.
    pub fn preset(name: &str) -> Option<Material> {
        let (e, nu, xi, theta_c, theta_s, rho) = match name {
            "snow" => (1.4e5, 0.2, 10.0, 2.5e-2, 7.5e-3, 400.0),
            "thesis" => (1.0e6, 0.3, 0.1, 2.5e-2, 7.5e-3, 400.0),
            "powder" => (7.0e4, 0.2, 10.0, 1.9e-2, 5.0e-3, 200.0),
            "wet" => (1.4e5, 0.3, 5.0, 5.0e-2, 1.5e-2, 550.0),
            "icy" => (1.0e6, 0.25, 20.0, 1.5e-2, 4.0e-3, 750.0),
            "slush" => (4.0e4, 0.35, 2.0, 1.0e-1, 3.0e-2, 850.0),
            _ => return None,
        };
        Some(Material {
            name: name.to_string(),
            youngs_modulus: e,
            poisson_ratio: nu,
            hardening: xi,
            critical_compression: theta_c,
            critical_stretch: theta_s,
            density: rho,
        })
    }

    /// All presets, in [`PRESET_NAMES`] order.
    pub fn presets() -> Vec<Material> {
        PRESET_NAMES
            .iter()
            .filter_map(|name| Material::preset(name))
            .collect()
    }
}

impl Default for Material {
    /// The [`Material::DEFAULT_PRESET`] preset, `snow`: what a body of a
    /// scene file gets when it names no material.
    fn default() -> Material {
        Material::preset(Material::DEFAULT_PRESET).expect("the default preset exists")
    }
}
