//! The differential of the snow's stress, δ(V_p^0 ∂Ψ/∂F_E), that the
//! Hessian product applies per particle (fixed-corotated energy, eq. 34-36).

use firn_core::math::svd::svd3;
use glam::{Mat3, Vec3};

/// The differential of V_p^0 ∂Ψ/∂F_E for one particle, at its current F_E.
///
/// With the fixed-corotated energy of eq. 34 written without inverses,
/// P = ∂Ψ/∂F_E = 2μ (F_E − R_E) + λ (J_E − 1) cof F_E (cof F = J F⁻ᵀ, eq. 36), so
///
/// ```text
/// δP = 2μ (δF − δR) + λ ((cof F : δF) cof F + (J − 1) δ(cof F)).
/// ```
///
/// δR follows from F = R S (Stomakhin et al. 2013, technical report): RᵀδR is
/// skew and solves (RᵀδR) S + S (RᵀδR) = Rᵀ δF − δFᵀ R, a 3x3 system for its
/// three entries. In the frame of the SVD F = U Σ Vᵀ (R = U Vᵀ, S = V Σ Vᵀ) the
/// system is diagonal: δR = U Y Vᵀ with Y skew,
/// Y_ij = (M_ij − M_ji) / (σ_i + σ_j) and M = Uᵀ δF V.
#[derive(Clone, Copy, Debug)]
pub struct StressDifferential {
    elastic: Mat3,
    /// cof F_E.
    cofactor: Mat3,
    u: Mat3,
    v: Mat3,
    /// 1 / (σ_j + σ_k) for the skew entries (1, 2), (0, 2) and (0, 1).
    inverse_sums: Vec3,
    /// 2 μ V_p^0 (hardened).
    shear: f32,
    /// λ V_p^0 (hardened).
    bulk: f32,
    /// J_E − 1.
    volume_change: f32,
}

impl StressDifferential {
    /// Linearises the stress at `elastic` = F_E with hardened Lamé parameters
    /// `mu`, `lambda` (eq. 35) and initial volume `volume0`. F_E must have
    /// positive singular values, as the plasticity clamp (eq. 42) ensures.
    pub fn new(elastic: Mat3, mu: f32, lambda: f32, volume0: f32) -> StressDifferential {
        let svd = svd3(elastic);
        let s = svd.sigma;
        StressDifferential {
            elastic,
            cofactor: cofactor(elastic),
            u: svd.u,
            v: svd.v,
            inverse_sums: Vec3::new(1.0 / (s.y + s.z), 1.0 / (s.x + s.z), 1.0 / (s.x + s.y)),
            shear: 2.0 * mu * volume0,
            bulk: lambda * volume0,
            volume_change: s.x * s.y * s.z - 1.0,
        }
    }

    /// The particle's F_E.
    #[inline(always)]
    pub fn elastic(&self) -> Mat3 {
        self.elastic
    }

    /// V_p^0 δP for a change `delta` = δF_E.
    #[inline(always)]
    pub fn apply(&self, delta: Mat3) -> Mat3 {
        let cofactor = self.cofactor;
        let volume_rate = cofactor.x_axis.dot(delta.x_axis)
            + cofactor.y_axis.dot(delta.y_axis)
            + cofactor.z_axis.dot(delta.z_axis);
        let cofactor_change = cofactor_differential(self.elastic, delta);
        (delta - self.rotation_differential(delta)) * self.shear
            + (cofactor * volume_rate + cofactor_change * self.volume_change) * self.bulk
    }

    /// δR = U Y Vᵀ with Y_ij = (M_ij − M_ji) / (σ_i + σ_j), M = Uᵀ δF V.
    #[inline(always)]
    pub(super) fn rotation_differential(&self, delta: Mat3) -> Mat3 {
        let m = self.u.transpose() * delta * self.v;
        // glam is column-major: M_ij is column j, row i.
        let y01 = (m.y_axis.x - m.x_axis.y) * self.inverse_sums.z;
        let y02 = (m.z_axis.x - m.x_axis.z) * self.inverse_sums.y;
        let y12 = (m.z_axis.y - m.y_axis.z) * self.inverse_sums.x;
        let y = Mat3::from_cols(
            Vec3::new(0.0, -y01, -y02),
            Vec3::new(y01, 0.0, -y12),
            Vec3::new(y02, y12, 0.0),
        );
        self.u * y * self.v.transpose()
    }
}

/// cof F = J F⁻ᵀ: its columns are f1 × f2, f2 × f0, f0 × f1 for the columns f of F.
#[inline(always)]
pub(super) fn cofactor(f: Mat3) -> Mat3 {
    Mat3::from_cols(
        f.y_axis.cross(f.z_axis),
        f.z_axis.cross(f.x_axis),
        f.x_axis.cross(f.y_axis),
    )
}

/// The differential of [`cofactor`] at F in the direction δF (product rule).
#[inline(always)]
pub(super) fn cofactor_differential(f: Mat3, d: Mat3) -> Mat3 {
    Mat3::from_cols(
        d.y_axis.cross(f.z_axis) + f.y_axis.cross(d.z_axis),
        d.z_axis.cross(f.x_axis) + f.z_axis.cross(d.x_axis),
        d.x_axis.cross(f.y_axis) + f.x_axis.cross(d.y_axis),
    )
}
