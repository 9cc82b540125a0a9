// The snow model of Stomakhin et al. 2013, as in firn_mpm::constitutive:
// fixed-corotated elasticity with hardening (thesis eq. 34-36) and
// plasticity by clamping the singular values of F_E (eq. 41-43).

// A material's constants, precomputed on the host.
struct Material {
    mu0: f32,
    lambda0: f32,
    hardening: f32,
    // 1 - theta_c and 1 + theta_s.
    min_stretch: f32,
    max_stretch: f32,
    // (lambda0 + 2 mu0) / rho0.
    wave_speed_squared: f32,
    pad0: f32,
    pad1: f32,
}

// The particle's state after the plastic projection.
struct ElasticState {
    elastic: mat3x3<f32>,
    plastic_j: f32,
    // V_p^0 tau_p for the next scatter.
    stress: mat3x3<f32>,
    // e^{xi (1 - J_P)} at the new J_P.
    hardening_factor: f32,
}

// Kirchhoff stress tau = 2 mu (F_E - R_E) F_E^T + lambda (J_E - 1) J_E I
// (eq. 34-36).
fn kirchhoff_stress(elastic: mat3x3<f32>, rotation: mat3x3<f32>, elastic_j: f32, mu: f32, lambda: f32) -> mat3x3<f32> {
    let shear = ((elastic - rotation) * transpose(elastic)) * (2.0 * mu);
    let pressure = lambda * (elastic_j - 1.0) * elastic_j;
    return shear + mat3x3<f32>(vec3<f32>(pressure, 0.0, 0.0), vec3<f32>(0.0, pressure, 0.0), vec3<f32>(0.0, 0.0, pressure));
}

// Clamps the singular values of the trial F_E into [1 - theta_c, 1 + theta_s]
// (eq. 41-42), moves what was clamped into J_P (eq. 43) and computes
// V_p^0 tau_p with the hardened Lame parameters (eq. 35).
fn elastic_update(trial: mat3x3<f32>, plastic_j: f32, volume0: f32, material: Material) -> ElasticState {
    let svd = svd3(trial);
    let clamped = min(max(svd.sigma, vec3<f32>(material.min_stretch)), vec3<f32>(material.max_stretch));
    let scaled_u = mat3x3<f32>(svd.u[0] * clamped.x, svd.u[1] * clamped.y, svd.u[2] * clamped.z);
    let elastic = scaled_u * transpose(svd.v);
    let ratio = (svd.sigma.x / clamped.x) * (svd.sigma.y / clamped.y) * (svd.sigma.z / clamped.z);
    let new_plastic_j = plastic_j * ratio;
    let factor = exp(material.hardening * (1.0 - new_plastic_j));
    let rotation = svd.u * transpose(svd.v);
    let elastic_j = clamped.x * clamped.y * clamped.z;
    let tau = kirchhoff_stress(elastic, rotation, elastic_j, material.mu0 * factor, material.lambda0 * factor);
    return ElasticState(elastic, new_plastic_j, tau * volume0, factor);
}
