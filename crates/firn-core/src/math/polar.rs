//! The rotation of the polar decomposition F = R S of a matrix close to a
//! rotation, by Newton's iteration X ← (X + X⁻ᵀ) / 2 (Higham 1986,
//! "Computing the polar decomposition, with applications").
//!
//! One step maps each singular value σ of X to (σ + 1/σ) / 2 and keeps the
//! singular vectors, so X converges to R = U Vᵀ quadratically: the distance
//! from 1 goes from e to e² / (2 (1 + e)). From any σ in
//! [[`NEWTON_MIN_STRETCH`], [`NEWTON_MAX_STRETCH`]] three steps land within
//! 1.2e-10 of 1, far below `f32` rounding, so within that band the result is
//! as accurate as R = U Vᵀ from [`crate::math::svd`]. A step costs one
//! division and a few dozen multiplications and no square root: three steps
//! take a small fraction of the time of the SVD's twelve dependent Jacobi
//! rotations. The snow model uses it for particles whose trial F_E needs no
//! plastic clamp and so no singular values.

use crate::math::lanes::{F32s, Mat3s};

/// Smallest singular value from which [`NEWTON_STEPS`] steps converge to
/// `f32` round-off.
pub const NEWTON_MIN_STRETCH: f32 = 0.9;

/// Largest singular value from which [`NEWTON_STEPS`] steps converge to
/// `f32` round-off.
pub const NEWTON_MAX_STRETCH: f32 = 1.1;

/// Newton steps taken: σ = 0.9 goes to 1 + 5.6e-3, 1.5e-5, 1.2e-10.
pub const NEWTON_STEPS: usize = 3;

/// R of F = R S for `N` matrices whose singular values all lie in
/// [[`NEWTON_MIN_STRETCH`], [`NEWTON_MAX_STRETCH`]] and whose determinant is
/// positive. Outside that band the result is not yet converged (it stays
/// finite for any invertible F).
///
/// With columns a, b, c, X⁻ᵀ has the columns b × c, c × a, a × b divided by
/// det X = a · (b × c).
#[inline(always)]
pub fn newton_rotation_lanes<const N: usize>(f: &Mat3s<N>) -> Mat3s<N> {
    let half = F32s::splat(0.5);
    let mut x = *f;
    for _ in 0..NEWTON_STEPS {
        let (a, b, c) = (x.x_axis, x.y_axis, x.z_axis);
        let (bc, ca, ab) = (b.cross(c), c.cross(a), a.cross(b));
        let half_inverse_det = half / a.dot(bc);
        x = Mat3s::from_cols(
            a.scale(half) + bc.scale(half_inverse_det),
            b.scale(half) + ca.scale(half_inverse_det),
            c.scale(half) + ab.scale(half_inverse_det),
        );
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::svd::svd3;
    use glam::{Mat3, Quat, Vec3};
    use proptest::prelude::*;

    fn newton_rotation(f: Mat3) -> Mat3 {
        newton_rotation_lanes(&Mat3s::<1>::splat(f)).lane(0)
    }

    fn rotation(axis: [f32; 3], angle: f32) -> Mat3 {
        let axis = Vec3::from(axis);
        let axis = if axis.length() > 1e-3 {
            axis.normalize()
        } else {
            Vec3::X
        };
        Mat3::from_quat(Quat::from_axis_angle(axis, angle))
    }

    proptest! {
        /// Inside the band the result is a rotation and equals U Vᵀ of the
        /// SVD to round-off, including at the band's edges.
        #[test]
        fn matches_the_svd_rotation_inside_the_band(
            left in proptest::array::uniform3(-1.0f32..1.0), left_angle in -3.1f32..3.1,
            right in proptest::array::uniform3(-1.0f32..1.0), right_angle in -3.1f32..3.1,
            stretches in proptest::array::uniform3(NEWTON_MIN_STRETCH..=NEWTON_MAX_STRETCH),
        ) {
            let (u, v) = (rotation(left, left_angle), rotation(right, right_angle));
            let f = u * Mat3::from_diagonal(Vec3::from(stretches)) * v.transpose();
            let newton = newton_rotation(f);
            let svd = svd3(f);
            let expected = svd.u * svd.v.transpose();
            prop_assert!(newton.abs_diff_eq(expected, 1e-6), "{newton} vs {expected} for {f}");
            prop_assert!((newton.transpose() * newton).abs_diff_eq(Mat3::IDENTITY, 6e-7));
            prop_assert!((newton.determinant() - 1.0).abs() < 6e-7);
        }
    }

    #[test]
    fn a_rotation_is_its_own_polar_factor() {
        let r = rotation([1.0, 2.0, -0.5], 0.7);
        assert!(newton_rotation(r).abs_diff_eq(r, 3e-7));
        assert_eq!(newton_rotation(Mat3::IDENTITY), Mat3::IDENTITY);
    }

    /// Outside the band three steps are not enough: the band is what makes
    /// the result exact, not a safety margin.
    #[test]
    fn three_steps_do_not_converge_far_outside_the_band() {
        let f = Mat3::from_diagonal(Vec3::new(0.3, 1.0, 1.0));
        assert!(!newton_rotation(f).abs_diff_eq(Mat3::IDENTITY, 1e-4));
    }
}
