// The snow model of Stomakhin et al. 2013, as in firn_mpm::snow_model:
// fixed-corotated elasticity with hardening (thesis eq. 34-36) and
// plasticity by clamping the singular values of F_E (eq. 41-43), with the
// CPU's fast path for particles inside the yield surface.

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
    // rho0, kg/m^3 (spindrift's loose-snow test).
    density: f32,
    pad: f32,
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

// The leading principal minors (1x1, 2x2, 3x3) of C - s I, with C = F^T F
// given by its entries (xx, yy, zz) and (xy, yz, zx).
fn shifted_minors(diagonal: vec3<f32>, off: vec3<f32>, s: f32) -> vec3<f32> {
    let xx = diagonal.x - s;
    let yy = diagonal.y - s;
    let zz = diagonal.z - s;
    let xy = off.x;
    let yz = off.y;
    let zx = off.z;
    let minor2 = xx * yy - xy * xy;
    let det = xx * (yy * zz - yz * yz) - xy * (xy * zz - yz * zx) + zx * (xy * yz - yy * zx);
    return vec3<f32>(xx, minor2, det);
}

// Whether the plastic clamp leaves the trial F_E alone: det F_E > 0 and every
// singular value strictly inside (1 - theta_c, 1 + theta_s) (eq. 41-42) and
// inside Newton's band (polar.wgsl). The squared singular values are the
// eigenvalues of C = F^T F, so this asks whether C - lo^2 I is positive and
// C - hi^2 I negative definite by the signs of their leading minors
// (Sylvester's criterion): no square root, no SVD. As the CPU's
// MaterialLanes::within_yield_surface.
fn within_yield_surface(trial: mat3x3<f32>, material: Material) -> bool {
    let lower = max(material.min_stretch, NEWTON_MIN_STRETCH);
    let upper = min(material.max_stretch, NEWTON_MAX_STRETCH);
    let a = trial[0];
    let b = trial[1];
    let c = trial[2];
    let diagonal = vec3<f32>(dot(a, a), dot(b, b), dot(c, c));
    let off = vec3<f32>(dot(a, b), dot(b, c), dot(c, a));
    let low = shifted_minors(diagonal, off, lower * lower);
    let high = shifted_minors(diagonal, off, upper * upper);
    return determinant(trial) > 0.0 && all(low > vec3<f32>(0.0)) && high.x < 0.0 && high.y > 0.0
        && high.z < 0.0;
}

// Clamps the singular values of the trial F_E into [1 - theta_c, 1 + theta_s]
// (eq. 41-42), moves what was clamped into J_P (eq. 43) and computes
// V_p^0 tau_p with the hardened Lame parameters (eq. 35). A trial inside the
// yield surface keeps F_E and J_P and takes R_E from Newton's iteration;
// only the others need the SVD.
fn elastic_update(trial: mat3x3<f32>, plastic_j: f32, volume0: f32, material: Material) -> ElasticState {
    if within_yield_surface(trial, material) {
        let factor = exp(material.hardening * (1.0 - plastic_j));
        let rotation = newton_rotation(trial);
        let tau = kirchhoff_stress(trial, rotation, determinant(trial), material.mu0 * factor, material.lambda0 * factor);
        return ElasticState(trial, plastic_j, tau * volume0, factor);
    }
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
