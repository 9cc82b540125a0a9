// The rotation of the polar decomposition F = R S of a matrix close to a
// rotation by Newton's iteration X <- (X + X^-T) / 2, as
// firn_core::math::polar: from singular values in
// [NEWTON_MIN_STRETCH, NEWTON_MAX_STRETCH] three steps converge to f32
// round-off, far cheaper than the SVD's Jacobi sweeps.

const NEWTON_MIN_STRETCH: f32 = 0.9;
const NEWTON_MAX_STRETCH: f32 = 1.1;
const NEWTON_STEPS: u32 = 3u;

// R of F = R S for F with positive determinant and singular values inside
// the band. With columns a, b, c, X^-T has the columns b x c, c x a, a x b
// divided by det X = a . (b x c).
fn newton_rotation(f: mat3x3<f32>) -> mat3x3<f32> {
    var x = f;
    for (var step = 0u; step < NEWTON_STEPS; step++) {
        let a = x[0];
        let b = x[1];
        let c = x[2];
        let bc = cross(b, c);
        let ca = cross(c, a);
        let ab = cross(a, b);
        let half_inverse_det = 0.5 / dot(a, bc);
        x = mat3x3<f32>(
            a * 0.5 + bc * half_inverse_det,
            b * 0.5 + ca * half_inverse_det,
            c * 0.5 + ab * half_inverse_det,
        );
    }
    return x;
}
