//! The snow model of Stomakhin et al. 2013: fixed-corotated elasticity with
//! hardening (thesis eq. 34-36) and plasticity by clamping the singular
//! values of the elastic deformation gradient (eq. 41-43).

use firn_core::Material;
use firn_core::math::svd::{Svd3, svd3};
use glam::{Mat3, Vec3};

/// Per-material constants the hot loops need, precomputed once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialConstants {
    /// Shear modulus μ0.
    pub mu0: f32,
    /// Lamé's first parameter λ0.
    pub lambda0: f32,
    /// Hardening coefficient ξ.
    pub hardening: f32,
    /// Lower clamp 1 − θc of the singular values of F_E.
    pub min_stretch: f32,
    /// Upper clamp 1 + θs of the singular values of F_E.
    pub max_stretch: f32,
    /// (λ0 + 2μ0) / ρ0: the squared P-wave speed before hardening.
    pub wave_speed_squared: f32,
}

impl MaterialConstants {
    /// Constants of a scene material.
    pub fn new(material: &Material) -> MaterialConstants {
        let (mu0, lambda0) = material.lame();
        MaterialConstants {
            mu0,
            lambda0,
            hardening: material.hardening,
            min_stretch: 1.0 - material.critical_compression,
            max_stretch: 1.0 + material.critical_stretch,
            wave_speed_squared: (lambda0 + 2.0 * mu0) / material.density,
        }
    }

    /// Hardening factor e^{ξ(1 − J_P)} (eq. 35).
    #[inline(always)]
    pub fn hardening_factor(&self, plastic_j: f32) -> f32 {
        (self.hardening * (1.0 - plastic_j)).exp()
    }
}

/// Result of the plasticity step for one particle.
#[derive(Clone, Copy, Debug)]
pub struct PlasticProjection {
    /// SVD of the trial elastic gradient F̂_E = U Σ Vᵀ.
    pub trial: Svd3,
    /// Clamped singular values Σc.
    pub clamped: Vec3,
}

impl PlasticProjection {
    /// Clamps the singular values of the trial F̂_E = (I + Δt ∇v_p) F_E into
    /// [1 − θc, 1 + θs] (eq. 41-42).
    #[inline(always)]
    pub fn new(trial_elastic: Mat3, constants: &MaterialConstants) -> PlasticProjection {
        let trial = svd3(trial_elastic);
        let clamped = trial.sigma.clamp(
            Vec3::splat(constants.min_stretch),
            Vec3::splat(constants.max_stretch),
        );
        PlasticProjection { trial, clamped }
    }

    /// The new elastic gradient F_E = U Σc Vᵀ.
    #[inline(always)]
    pub fn elastic(&self) -> Mat3 {
        self.trial.u * Mat3::from_diagonal(self.clamped) * self.trial.v.transpose()
    }

    /// The rotation R_E = U Vᵀ of the polar decomposition of the new F_E.
    #[inline(always)]
    pub fn rotation(&self) -> Mat3 {
        self.trial.u * self.trial.v.transpose()
    }

    /// det F_P_new / det F_P_old = Π σ / Π σc: what the clamp moved into F_P.
    #[inline(always)]
    pub fn plastic_j_ratio(&self) -> f32 {
        let s = self.trial.sigma;
        let c = self.clamped;
        (s.x / c.x) * (s.y / c.y) * (s.z / c.z)
    }

    /// The factor that multiplies F_P: F_P_new = V Σc⁻¹ Σ Vᵀ F_P_old (eq. 43),
    /// so that F_E_new F_P_new = F̂_E F_P_old.
    pub fn plastic_increment(&self) -> Mat3 {
        let ratio = self.trial.sigma / self.clamped;
        self.trial.v * Mat3::from_diagonal(ratio) * self.trial.v.transpose()
    }
}

/// Kirchhoff stress τ = ∂Ψ/∂F_E F_Eᵀ = 2μ (F_E − R_E) F_Eᵀ + λ (J_E − 1) J_E I
/// of the fixed-corotated energy with hardened μ, λ (eq. 34-36).
#[inline(always)]
pub fn kirchhoff_stress(
    elastic: Mat3,
    rotation: Mat3,
    elastic_j: f32,
    mu: f32,
    lambda: f32,
) -> Mat3 {
    (elastic - rotation) * elastic.transpose() * (2.0 * mu)
        + Mat3::from_diagonal(Vec3::splat(lambda * (elastic_j - 1.0) * elastic_j))
}

/// V_p^0 τ_p for a particle after its plasticity step.
#[inline(always)]
pub fn scaled_stress(
    projection: &PlasticProjection,
    elastic: Mat3,
    plastic_j: f32,
    volume0: f32,
    constants: &MaterialConstants,
) -> Mat3 {
    let factor = constants.hardening_factor(plastic_j);
    let c = projection.clamped;
    let elastic_j = c.x * c.y * c.z;
    let tau = kirchhoff_stress(
        elastic,
        projection.rotation(),
        elastic_j,
        constants.mu0 * factor,
        constants.lambda0 * factor,
    );
    tau * volume0
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn thesis_constants() -> MaterialConstants {
        MaterialConstants::new(&Material::preset("thesis").unwrap())
    }

    fn matrix(values: [f32; 9]) -> Mat3 {
        Mat3::from_cols_array(&values)
    }

    proptest! {
        #[test]
        fn plasticity_clamps_and_preserves_the_total_gradient(
            noise in proptest::array::uniform9(-0.2f32..0.2),
            plastic_noise in proptest::array::uniform9(-0.05f32..0.05),
        ) {
            let constants = thesis_constants();
            let trial = Mat3::IDENTITY + matrix(noise);
            let plastic_old = Mat3::IDENTITY + matrix(plastic_noise);
            let projection = PlasticProjection::new(trial, &constants);
            let elastic = projection.elastic();
            let sigma = svd3(elastic).sigma;
            for s in sigma.to_array() {
                prop_assert!(s >= constants.min_stretch - 1e-5 && s <= constants.max_stretch + 1e-5,
                    "singular value {s} outside [{}, {}]", constants.min_stretch, constants.max_stretch);
            }
            let plastic_new = projection.plastic_increment() * plastic_old;
            let total_before = trial * plastic_old;
            let total_after = elastic * plastic_new;
            prop_assert!((total_after - total_before).abs().to_cols_array().iter().all(|e| *e < 2e-5),
                "F_E F_P changed: {total_before} vs {total_after}");
            let expected_j = plastic_new.determinant() / plastic_old.determinant();
            prop_assert!((projection.plastic_j_ratio() - expected_j).abs() < 1e-4 * expected_j.abs().max(1.0));
        }
    }

    #[test]
    fn undeformed_snow_has_no_stress() {
        let constants = thesis_constants();
        let projection = PlasticProjection::new(Mat3::IDENTITY, &constants);
        let stress = scaled_stress(&projection, projection.elastic(), 1.0, 1.0, &constants);
        assert!(stress.abs().to_cols_array().iter().all(|e| *e < 1e-3));
    }

    #[test]
    fn compression_gives_pressure_and_hardening_stiffens() {
        let constants = thesis_constants();
        let squeeze = Mat3::from_diagonal(Vec3::splat(0.99));
        let projection = PlasticProjection::new(squeeze, &constants);
        let soft = scaled_stress(&projection, projection.elastic(), 1.0, 1.0, &constants);
        let hard = scaled_stress(&projection, projection.elastic(), 0.5, 1.0, &constants);
        // Compressed: negative normal stress, no shear.
        assert!(soft.x_axis.x < 0.0);
        assert!(soft.y_axis.x.abs() < 1e-2 * soft.x_axis.x.abs());
        // Hardening by e^{ξ(1 − J_P)} with J_P = 0.5.
        let factor = (constants.hardening * 0.5).exp();
        assert!((hard.x_axis.x / soft.x_axis.x - factor).abs() < 1e-4);
    }
}
