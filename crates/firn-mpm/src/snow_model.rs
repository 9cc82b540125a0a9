//! The snow model of Stomakhin et al. 2013: fixed-corotated elasticity with
//! hardening (thesis eq. 34-36) and plasticity by clamping the singular
//! values of the elastic deformation gradient (eq. 41-43).
//!
//! Only particles whose trial F̂_E leaves the yield surface need its
//! singular values. The others (snow in flight, or resting below its
//! critical strains) keep F̂_E unchanged, and the fixed-corotated stress only
//! needs its rotation R_E, which a few Newton steps give far faster than an
//! SVD ([`firn_core::math::polar`]). Which way a particle goes depends on its
//! own F̂_E alone, never on the others in its SIMD batch.

use firn_core::Material;
use firn_core::math::exp::exp;
use firn_core::math::lanes::{F32s, Mat3s, U32s, Vec3s};
use firn_core::math::polar::{NEWTON_MAX_STRETCH, NEWTON_MIN_STRETCH, newton_rotation_lanes};
use firn_core::math::svd::{Svd3s, svd3_lanes};

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

    /// The constants of each of a scene's materials, in its order (particles
    /// index them by material).
    pub fn of_each(materials: &[Material]) -> Vec<MaterialConstants> {
        materials.iter().map(MaterialConstants::new).collect()
    }

    /// Hardening factor e^{ξ(1 − J_P)} (eq. 35).
    #[inline(always)]
    pub fn hardening_factor(&self, plastic_j: f32) -> f32 {
        hardening_factor(self.hardening, plastic_j)
    }
}

/// The largest squared elastic wave speed c² = (λ0 + 2μ0) / ρ0 · e^{ξ(1 − J_P)}
/// over particles of materials `material` (indices into `constants`) and
/// plastic volume changes `plastic_j`, as the gather reports it: what the
/// adaptive Δt starts from after the materials changed (both backends).
pub fn max_wave_speed_squared(
    constants: &[MaterialConstants],
    material: &[u16],
    plastic_j: &[f32],
) -> f32 {
    material
        .iter()
        .zip(plastic_j)
        .map(|(&m, &j)| {
            let constants = &constants[usize::from(m)];
            constants.wave_speed_squared * constants.hardening_factor(j)
        })
        .fold(0.0, f32::max)
}

/// e^{ξ(1 − J_P)} (eq. 35): how much compaction has stiffened the snow.
#[inline(always)]
fn hardening_factor(hardening: f32, plastic_j: f32) -> f32 {
    exp(hardening * (1.0 - plastic_j))
}

/// [`MaterialConstants`] of `N` particles, lane by lane.
#[derive(Clone, Copy, Debug)]
pub struct MaterialLanes<const N: usize> {
    /// μ0 per lane.
    pub mu0: F32s<N>,
    /// λ0 per lane.
    pub lambda0: F32s<N>,
    /// ξ per lane.
    pub hardening: F32s<N>,
    /// 1 − θc per lane.
    pub min_stretch: F32s<N>,
    /// 1 + θs per lane.
    pub max_stretch: F32s<N>,
    /// (λ0 + 2μ0) / ρ0 per lane.
    pub wave_speed_squared: F32s<N>,
}

impl<const N: usize> MaterialLanes<N> {
    /// The same material in every lane.
    pub fn splat(constants: &MaterialConstants) -> MaterialLanes<N> {
        MaterialLanes {
            mu0: F32s::splat(constants.mu0),
            lambda0: F32s::splat(constants.lambda0),
            hardening: F32s::splat(constants.hardening),
            min_stretch: F32s::splat(constants.min_stretch),
            max_stretch: F32s::splat(constants.max_stretch),
            wave_speed_squared: F32s::splat(constants.wave_speed_squared),
        }
    }

    /// Stores `constants` in lane `i`.
    #[inline(always)]
    pub fn set_lane(&mut self, i: usize, constants: &MaterialConstants) {
        self.mu0.0[i] = constants.mu0;
        self.lambda0.0[i] = constants.lambda0;
        self.hardening.0[i] = constants.hardening;
        self.min_stretch.0[i] = constants.min_stretch;
        self.max_stretch.0[i] = constants.max_stretch;
        self.wave_speed_squared.0[i] = constants.wave_speed_squared;
    }

    /// Hardening factor e^{ξ(1 − J_P)} (eq. 35), lane by lane.
    #[inline(always)]
    pub fn hardening_factor(&self, plastic_j: F32s<N>) -> F32s<N> {
        (self.hardening * (F32s::splat(1.0) - plastic_j)).exp()
    }

    /// Lanes whose trial F̂_E the plastic clamp leaves alone: det F̂_E > 0 and
    /// every singular value strictly inside (1 − θc, 1 + θs) (eq. 41-42), and
    /// inside the band where [`newton_rotation_lanes`] is exact.
    ///
    /// The squared singular values are the eigenvalues of C = F̂_Eᵀ F̂_E, so
    /// this asks whether C − lo² I is positive and C − hi² I negative
    /// definite, by the signs of their leading principal minors (Sylvester's
    /// criterion): no square root, no SVD. A singular value within rounding
    /// (about 1e-6) of a bound may be classed either way; both ways give the
    /// same state to that precision.
    #[inline(always)]
    pub fn within_yield_surface(&self, trial: &Mat3s<N>) -> U32s<N> {
        let lower = self.min_stretch.max(F32s::splat(NEWTON_MIN_STRETCH));
        let upper = self.max_stretch.min(F32s::splat(NEWTON_MAX_STRETCH));
        let gram = Gram::of(trial);
        let zero = F32s::splat(0.0);
        let [low1, low2, low3] = gram.leading_minors(lower * lower);
        let [high1, high2, high3] = gram.leading_minors(upper * upper);
        zero.lt(trial.determinant())
            .and(zero.lt(low1))
            .and(zero.lt(low2))
            .and(zero.lt(low3))
            .and(high1.lt(zero))
            .and(zero.lt(high2))
            .and(high3.lt(zero))
    }
}

/// C = Fᵀ F of `N` matrices: the symmetric Gram matrix of F's columns.
struct Gram<const N: usize> {
    xx: F32s<N>,
    yy: F32s<N>,
    zz: F32s<N>,
    xy: F32s<N>,
    yz: F32s<N>,
    zx: F32s<N>,
}

impl<const N: usize> Gram<N> {
    #[inline(always)]
    fn of(f: &Mat3s<N>) -> Gram<N> {
        let (a, b, c) = (f.x_axis, f.y_axis, f.z_axis);
        Gram {
            xx: a.dot(a),
            yy: b.dot(b),
            zz: c.dot(c),
            xy: a.dot(b),
            yz: b.dot(c),
            zx: c.dot(a),
        }
    }

    /// The leading principal minors of C − s I (1x1, 2x2, 3x3).
    #[inline(always)]
    fn leading_minors(&self, s: F32s<N>) -> [F32s<N>; 3] {
        let (xx, yy, zz) = (self.xx - s, self.yy - s, self.zz - s);
        let (xy, yz, zx) = (self.xy, self.yz, self.zx);
        let minor2 = xx * yy - xy * xy;
        let det = xx * (yy * zz - yz * yz) - xy * (xy * zz - yz * zx) + zx * (xy * yz - yy * zx);
        [xx, minor2, det]
    }
}

/// Result of the plasticity step for `N` particles.
#[derive(Clone, Copy, Debug)]
pub struct PlasticProjection<const N: usize> {
    /// SVD of the trial elastic gradient F̂_E = U Σ Vᵀ.
    pub trial: Svd3s<N>,
    /// Clamped singular values Σc.
    pub clamped: Vec3s<N>,
}

impl<const N: usize> PlasticProjection<N> {
    /// Clamps the singular values of the trial F̂_E = (I + Δt ∇v_p) F_E into
    /// [1 − θc, 1 + θs] (eq. 41-42).
    #[inline(always)]
    pub fn new(trial_elastic: &Mat3s<N>, materials: &MaterialLanes<N>) -> PlasticProjection<N> {
        let trial = svd3_lanes(trial_elastic);
        let clamp = |s: F32s<N>| s.max(materials.min_stretch).min(materials.max_stretch);
        let sigma = trial.sigma;
        let clamped = Vec3s::new(clamp(sigma.x), clamp(sigma.y), clamp(sigma.z));
        PlasticProjection { trial, clamped }
    }

    /// The new elastic gradient F_E = U Σc Vᵀ.
    #[inline(always)]
    pub fn elastic(&self) -> Mat3s<N> {
        let u = &self.trial.u;
        let scaled = Mat3s::from_cols(
            u.x_axis.scale(self.clamped.x),
            u.y_axis.scale(self.clamped.y),
            u.z_axis.scale(self.clamped.z),
        );
        scaled.mul_mat(&self.trial.v.transpose())
    }

    /// The rotation R_E = U Vᵀ of the polar decomposition of the new F_E.
    #[inline(always)]
    pub fn rotation(&self) -> Mat3s<N> {
        self.trial.u.mul_mat(&self.trial.v.transpose())
    }

    /// det F_P_new / det F_P_old = Π σ / Π σc: what the clamp moved into F_P.
    #[inline(always)]
    pub fn plastic_j_ratio(&self) -> F32s<N> {
        let (s, c) = (self.trial.sigma, self.clamped);
        (s.x / c.x) * (s.y / c.y) * (s.z / c.z)
    }

    /// J_E = Π σc, the volume ratio of the new F_E.
    #[inline(always)]
    pub fn elastic_j(&self) -> F32s<N> {
        let c = self.clamped;
        c.x * c.y * c.z
    }
}

/// Kirchhoff stress τ = ∂Ψ/∂F_E F_Eᵀ = 2μ (F_E − R_E) F_Eᵀ + λ (J_E − 1) J_E I
/// of the fixed-corotated energy with hardened μ, λ (eq. 34-36).
#[inline(always)]
pub fn kirchhoff_stress<const N: usize>(
    elastic: &Mat3s<N>,
    rotation: &Mat3s<N>,
    elastic_j: F32s<N>,
    mu: F32s<N>,
    lambda: F32s<N>,
) -> Mat3s<N> {
    let one = F32s::splat(1.0);
    let shear = elastic
        .sub(rotation)
        .mul_mat(&elastic.transpose())
        .scale(F32s::splat(2.0) * mu);
    let pressure = lambda * (elastic_j - one) * elastic_j;
    shear.add(&Mat3s::from_diagonal(Vec3s::new(
        pressure, pressure, pressure,
    )))
}

/// Plasticity and stress of `N` particles after the F_E update (steps 7 and
/// 9 of the algorithm; eq. 34-43).
#[derive(Clone, Copy, Debug)]
pub struct ElasticUpdate<const N: usize> {
    /// The new elastic gradient F_E.
    pub elastic: Mat3s<N>,
    /// The new J_P.
    pub plastic_j: F32s<N>,
    /// V_p^0 τ_p for the next scatter.
    pub stress: Mat3s<N>,
    /// e^{ξ(1 − J_P)} at the new J_P.
    pub hardening_factor: F32s<N>,
}

impl<const N: usize> ElasticUpdate<N> {
    /// Projects the trial F̂_E, moves the clamped part into J_P and computes
    /// V_p^0 τ_p with the hardened Lamé parameters. Lanes inside the yield
    /// surface ([`MaterialLanes::within_yield_surface`]) keep F̂_E and J_P
    /// exactly and take R_E from Newton's iteration; the SVD runs only when
    /// some lane needs the clamp.
    #[inline(always)]
    pub fn new(
        trial_elastic: &Mat3s<N>,
        plastic_j: F32s<N>,
        volume0: F32s<N>,
        materials: &MaterialLanes<N>,
    ) -> ElasticUpdate<N> {
        let inside = materials.within_yield_surface(trial_elastic);
        let state = if inside.all() {
            ElasticState::unclamped(trial_elastic, plastic_j)
        } else {
            let clamped = ElasticState::projected(trial_elastic, plastic_j, materials);
            if inside.any() {
                let unclamped = ElasticState::unclamped(trial_elastic, plastic_j);
                ElasticState::select(inside, &unclamped, &clamped)
            } else {
                clamped
            }
        };
        let (tau, factor) = state.hardened_stress(materials);
        ElasticUpdate {
            elastic: state.elastic,
            plastic_j: state.plastic_j,
            stress: tau.scale(volume0),
            hardening_factor: factor,
        }
    }
}

/// F_E after plasticity, with what the stress needs of it.
struct ElasticState<const N: usize> {
    elastic: Mat3s<N>,
    rotation: Mat3s<N>,
    elastic_j: F32s<N>,
    plastic_j: F32s<N>,
}

impl<const N: usize> ElasticState<N> {
    /// A trial F̂_E inside the yield surface: the clamp changes nothing.
    #[inline(always)]
    fn unclamped(trial_elastic: &Mat3s<N>, plastic_j: F32s<N>) -> ElasticState<N> {
        ElasticState {
            elastic: *trial_elastic,
            rotation: newton_rotation_lanes(trial_elastic),
            elastic_j: trial_elastic.determinant(),
            plastic_j,
        }
    }

    /// F̂_E clamped through its SVD, the clamped part moved into J_P (eq. 43).
    #[inline(always)]
    fn projected(
        trial_elastic: &Mat3s<N>,
        plastic_j: F32s<N>,
        materials: &MaterialLanes<N>,
    ) -> ElasticState<N> {
        let projection = PlasticProjection::new(trial_elastic, materials);
        ElasticState {
            elastic: projection.elastic(),
            rotation: projection.rotation(),
            elastic_j: projection.elastic_j(),
            plastic_j: plastic_j * projection.plastic_j_ratio(),
        }
    }

    /// The Kirchhoff stress τ with μ and λ hardened at this J_P (eq. 34-36),
    /// and the hardening factor.
    #[inline(always)]
    fn hardened_stress(&self, materials: &MaterialLanes<N>) -> (Mat3s<N>, F32s<N>) {
        let factor = materials.hardening_factor(self.plastic_j);
        let tau = kirchhoff_stress(
            &self.elastic,
            &self.rotation,
            self.elastic_j,
            materials.mu0 * factor,
            materials.lambda0 * factor,
        );
        (tau, factor)
    }

    /// Per lane: `yes` where `mask` holds, else `no`.
    #[inline(always)]
    fn select(mask: U32s<N>, yes: &ElasticState<N>, no: &ElasticState<N>) -> ElasticState<N> {
        ElasticState {
            elastic: Mat3s::select(mask, &yes.elastic, &no.elastic),
            rotation: Mat3s::select(mask, &yes.rotation, &no.rotation),
            elastic_j: F32s::select(mask, yes.elastic_j, no.elastic_j),
            plastic_j: F32s::select(mask, yes.plastic_j, no.plastic_j),
        }
    }
}

#[cfg(test)]
mod tests;
