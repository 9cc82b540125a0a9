//! Sphere obstacles (seed 002, eq. 2-3, in the form of Bridson et al. 2007,
//! section 3.2): near a sphere the potential loses its tangential part,
//!
//! ```text
//! ψ' = α ψ + (1 − α) n̂ (n̂ · ψ),   α = ramp(d / d0),
//! ramp(r) = 6r⁵ − 15r⁴ + 10r³ on [0, 1] (0 below, 1 above),
//! ```
//!
//! with d the distance to the sphere's surface, d0 its influence distance and
//! n̂ the unit vector from its centre. On the surface ψ' is normal, so the
//! velocity curl ψ' has no normal component there: the flow slides around.
//!
//! The analytic curl follows from the product rule, with ∇α = α' n̂ and
//! ∇n̂ = (I − n̂ n̂ᵀ) / r (r = |x − c|):
//!
//! ```text
//! curl ψ' = α curl ψ + (α' − (1 − α)/r) (n̂ × ψ) + (1 − α) (Jᵀ n̂) × n̂
//! ```
//!
//! where J = ∂ψ/∂x (rows are the gradients of ψ's components). With several
//! spheres, each point is modulated by the one whose ramp is smallest (the
//! least d / d0); the field is continuous wherever influence zones do not
//! overlap.

use crate::lanes::{Real, V3, add3, cross3, dot3, scale3, sub3};

/// ramp(r) = 6r⁵ − 15r⁴ + 10r³ clamped to [0, 1], and its derivative
/// 30 r² (1 − r)² (seed eq. 2). Both vanish to second order at 0 and 1, so α
/// and ψ' have continuous second derivatives.
#[inline(always)]
pub fn ramp<R: Real>(r: R) -> (R, R) {
    let r = r.max(R::splat(0.0)).min(R::splat(1.0));
    let r2 = r * r;
    let value = r2 * r * (R::splat(10.0) + r * (R::splat(6.0) * r - R::splat(15.0)));
    let one_minus = R::splat(1.0) - r;
    let slope = R::splat(30.0) * r2 * one_minus * one_minus;
    (value, slope)
}

/// A sphere obstacle in lane type `R`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sphere<R: Real> {
    pub center: V3<R>,
    pub radius: R,
    /// 1 / d0.
    pub inv_influence: R,
    /// The square of a distance from the centre a little beyond r + d0:
    /// a point nearer than this may feel the sphere, one beyond it does not.
    pub reach_squared: R,
}

/// How far beyond its influence distance (relative to r + d0) a sphere is
/// looked for: far more than the round-off of d / d0 in `f32`.
pub(crate) const REACH_MARGIN: f64 = 1e-4;

/// Per lane, whether some sphere may bend the field there (d / d0 < 1 can
/// only hold within `reach_squared`): a test without square roots.
#[inline(always)]
pub(crate) fn within_reach<R: Real>(spheres: &[Sphere<R>], x: V3<R>) -> R::Mask {
    let reach = |sphere: &Sphere<R>| {
        let rel = sub3(x, sphere.center);
        dot3(rel, rel).lt(sphere.reach_squared)
    };
    spheres[1..]
        .iter()
        .fold(reach(&spheres[0]), |mask, sphere| {
            R::or(mask, reach(sphere))
        })
}

/// Per lane, the sphere with the least d / d0 (the smallest ramp), and that
/// ratio: where it is 1 or more, α = 1 exactly and the sphere has no effect.
#[inline(always)]
pub(crate) fn most_influential<R: Real>(spheres: &[Sphere<R>], x: V3<R>) -> (Sphere<R>, R) {
    let mut best = spheres[0];
    let rel = sub3(x, best.center);
    let mut best_ratio = (dot3(rel, rel).sqrt() - best.radius) * best.inv_influence;
    for sphere in &spheres[1..] {
        let rel = sub3(x, sphere.center);
        let ratio = (dot3(rel, rel).sqrt() - sphere.radius) * sphere.inv_influence;
        let closer = ratio.lt(best_ratio);
        best_ratio = R::select(closer, ratio, best_ratio);
        best = Sphere {
            center: [
                R::select(closer, sphere.center[0], best.center[0]),
                R::select(closer, sphere.center[1], best.center[1]),
                R::select(closer, sphere.center[2], best.center[2]),
            ],
            radius: R::select(closer, sphere.radius, best.radius),
            inv_influence: R::select(closer, sphere.inv_influence, best.inv_influence),
            reach_squared: R::select(closer, sphere.reach_squared, best.reach_squared),
        };
    }
    (best, best_ratio)
}

/// Distance r from the centre (kept off zero), unit direction n̂, and the
/// ramp α with its derivative along n̂, α' = ramp'(d/d0) / d0.
#[inline(always)]
fn frame<R: Real>(sphere: &Sphere<R>, x: V3<R>) -> (R, V3<R>, R, R) {
    let rel = sub3(x, sphere.center);
    // At the very centre n̂ is undefined; any direction will do there.
    let r = dot3(rel, rel).sqrt().max(sphere.radius * R::splat(1e-6));
    let n = scale3(R::splat(1.0) / r, rel);
    let (alpha, slope) = ramp((r - sphere.radius) * sphere.inv_influence);
    (r, n, alpha, slope * sphere.inv_influence)
}

/// ψ' = α ψ + (1 − α) n̂ (n̂ · ψ).
#[inline(always)]
pub(crate) fn modulate_potential<R: Real>(sphere: &Sphere<R>, x: V3<R>, psi: V3<R>) -> V3<R> {
    let (_, n, alpha, _) = frame(sphere, x);
    let normal_part = scale3((R::splat(1.0) - alpha) * dot3(n, psi), n);
    add3(scale3(alpha, psi), normal_part)
}

/// curl ψ' from ψ (with the background about the sphere's centre), the
/// turbulence Jacobian (`jacobian[c]` = ∇ψ_c), the background's half strength
/// and direction (whose Jacobian ½ M [p]× adds ½ M (n̂ × p) to Jᵀ n̂), and
/// curl ψ.
#[inline(always)]
pub(crate) fn modulate_curl<R: Real>(
    sphere: &Sphere<R>,
    x: V3<R>,
    psi: V3<R>,
    jacobian: &[V3<R>; 3],
    half_background: R,
    direction: V3<R>,
    curl: V3<R>,
) -> V3<R> {
    let (r, n, alpha, alpha_slope) = frame(sphere, x);
    let beta = R::splat(1.0) - alpha;
    let n_cross_psi = cross3(n, psi);
    let jacobian_t_n = add3(
        [
            jacobian[0][0] * n[0] + jacobian[1][0] * n[1] + jacobian[2][0] * n[2],
            jacobian[0][1] * n[0] + jacobian[1][1] * n[1] + jacobian[2][1] * n[2],
            jacobian[0][2] * n[0] + jacobian[1][2] * n[1] + jacobian[2][2] * n[2],
        ],
        scale3(half_background, cross3(n, direction)),
    );
    let tangential = cross3(jacobian_t_n, n);
    add3(
        add3(
            scale3(alpha, curl),
            scale3(alpha_slope - beta / r, n_cross_psi),
        ),
        scale3(beta, tangential),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn within_reach_holds_wherever_a_sphere_bends_the_field() {
        // Points on rays through two spheres, stepping across the outer edge
        // of the influence shell by about an ulp of the distance at a time:
        // wherever d / d0 < 1 in f32 the cheap test must hold, and it must
        // fail a little further out.
        type S = crate::lanes::F32s<1>;
        let lanes = |v: [f32; 3]| v.map(|c| <S as Real>::splat(f64::from(c)));
        let sphere = |center: [f32; 3], radius: f32, influence: f32| {
            let reach = (f64::from(radius) + f64::from(influence)) * (1.0 + REACH_MARGIN);
            Sphere {
                center: lanes(center),
                radius: <S as Real>::splat(f64::from(radius)),
                inv_influence: <S as Real>::splat(1.0 / f64::from(influence)),
                reach_squared: <S as Real>::splat(reach * reach),
            }
        };
        let spheres = [
            sphere([50.0, 50.0, 50.0], 15.0, 10.0),
            sphere([-3.0, 7.5, 1000.25], 0.3, 2.7),
        ];
        let centres = [[50.0, 50.0, 50.0], [-3.0, 7.5, 1000.25]];
        let edges = [25.0f32, 3.0];
        let mut near = 0;
        for s in 0..2 {
            for ray in 0..100 {
                let a = ray as f32 * 0.731;
                let b = ray as f32 * 0.293;
                let direction = [a.cos() * b.sin(), a.sin() * b.sin(), b.cos()];
                let point = |distance: f32| {
                    lanes(std::array::from_fn(|i| {
                        centres[s][i] + distance * direction[i]
                    }))
                };
                for k in -1000..1000 {
                    let x = point(edges[s] * (1.0 + k as f32 * 1e-7));
                    let (_, ratio) = most_influential(&spheres, x);
                    if ratio.0[0] < 1.0 {
                        near += 1;
                        assert!(
                            <S as Real>::any(within_reach(&spheres, x)),
                            "sphere {s}, ray {ray}, {k}"
                        );
                    }
                }
                let far = point(edges[s] * 1.01);
                assert!(
                    !<S as Real>::any(within_reach(&spheres[s..=s], far)),
                    "sphere {s}, ray {ray}"
                );
            }
        }
        assert!(near > 150_000, "{near}");
    }

    #[test]
    fn ramp_is_smooth_and_clamped() {
        assert_eq!(ramp(-0.5f64), (0.0, 0.0));
        assert_eq!(ramp(1.5f64), (1.0, 0.0));
        assert_eq!(ramp(0.5f64).0, 0.5);
        for i in 1..100 {
            let r = i as f64 / 100.0;
            let h = 1e-6;
            let numeric = (ramp(r + h).0 - ramp(r - h).0) / (2.0 * h);
            assert!((numeric - ramp(r).1).abs() < 1e-8, "{r}");
        }
    }
}
