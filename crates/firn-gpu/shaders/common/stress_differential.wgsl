// The linearised stress of the semi-implicit solve, as
// firn_mpm::implicit::StressDifferential: with P = 2 mu (F - R) +
// lambda (J - 1) cof F, the differential in a direction dF is
//
//   dP = 2 mu (dF - dR) + lambda ((cof F : dF) cof F + (J - 1) d(cof F)),
//
// with dR = U Y V^T, Y skew, Y_ij = (M_ij - M_ji) / (sigma_i + sigma_j) and
// M = U^T dF V for the SVD F = U diag(sigma) V^T. Everything but dF is
// computed once per particle and substep (stress_differential) and kept for
// every product with the Hessian (apply_stress_differential). The
// semi-implicit stage of the GPU step is to build on these two functions;
// today the parity program runs them against the CPU.

struct StressDifferential {
    elastic: mat3x3<f32>,
    cofactor: mat3x3<f32>,
    u: mat3x3<f32>,
    v: mat3x3<f32>,
    // 1 / (sigma_j + sigma_k) for the skew entries (1, 2), (0, 2) and (0, 1).
    inverse_sums: vec3<f32>,
    // 2 mu V_p^0 (hardened).
    shear: f32,
    // lambda V_p^0 (hardened).
    bulk: f32,
    // J_E - 1.
    volume_change: f32,
}

// cof F = J F^-T: columns f1 x f2, f2 x f0, f0 x f1.
fn cofactor_of(f: mat3x3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(cross(f[1], f[2]), cross(f[2], f[0]), cross(f[0], f[1]));
}

// The differential of cofactor_of at F in the direction d (product rule).
fn cofactor_differential(f: mat3x3<f32>, d: mat3x3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(
        cross(d[1], f[2]) + cross(f[1], d[2]),
        cross(d[2], f[0]) + cross(f[2], d[0]),
        cross(d[0], f[1]) + cross(f[0], d[1]),
    );
}

// Linearises V_p^0 P at elastic = F_E with hardened mu, lambda; F_E must have
// positive singular values (the plasticity clamp ensures it).
fn stress_differential(elastic: mat3x3<f32>, mu: f32, lambda: f32, volume0: f32) -> StressDifferential {
    let svd = svd3(elastic);
    let s = svd.sigma;
    return StressDifferential(
        elastic,
        cofactor_of(elastic),
        svd.u,
        svd.v,
        vec3<f32>(1.0 / (s.y + s.z), 1.0 / (s.x + s.z), 1.0 / (s.x + s.y)),
        2.0 * mu * volume0,
        lambda * volume0,
        s.x * s.y * s.z - 1.0,
    );
}

// V_p^0 dP for a change delta = dF_E.
fn apply_stress_differential(d: StressDifferential, delta: mat3x3<f32>) -> mat3x3<f32> {
    let c = d.cofactor;
    let volume_rate = dot(c[0], delta[0]) + dot(c[1], delta[1]) + dot(c[2], delta[2]);
    let cofactor_change = cofactor_differential(d.elastic, delta);
    // Column-major: m[j][i] is M_ij.
    let m = transpose(d.u) * delta * d.v;
    let y01 = (m[1].x - m[0].y) * d.inverse_sums.z;
    let y02 = (m[2].x - m[0].z) * d.inverse_sums.y;
    let y12 = (m[2].y - m[1].z) * d.inverse_sums.x;
    let y = mat3x3<f32>(
        vec3<f32>(0.0, -y01, -y02),
        vec3<f32>(y01, 0.0, -y12),
        vec3<f32>(y02, y12, 0.0),
    );
    let rotation_change = d.u * y * transpose(d.v);
    return (delta - rotation_change) * d.shear
        + (c * volume_rate + cofactor_change * d.volume_change) * d.bulk;
}
