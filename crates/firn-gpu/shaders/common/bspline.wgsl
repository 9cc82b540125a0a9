// B-spline interpolation weights of the Material Point Method (thesis
// eq. 37-40), as in firn_core::math::bspline. A particle at grid coordinate
// x = (x_p - origin) / h reaches the nodes base .. base + N - 1 per axis;
// values[k] holds the 1D weight of node base + k on each axis, slopes[k]
// its derivative per cell.

struct QuadraticWeights {
    base: vec3<i32>,
    offset: vec3<f32>,
    values: array<vec3<f32>, 3>,
    slopes: array<vec3<f32>, 3>,
}

struct CubicWeights {
    base: vec3<i32>,
    offset: vec3<f32>,
    values: array<vec3<f32>, 4>,
    slopes: array<vec3<f32>, 4>,
}

// Quadratic B-spline, support |x| < 1.5 (APIC).
fn quadratic(x: f32) -> f32 {
    let a = abs(x);
    if a < 0.5 {
        return 0.75 - a * a;
    }
    if a < 1.5 {
        let b = 1.5 - a;
        return 0.5 * b * b;
    }
    return 0.0;
}

fn quadratic_slope(x: f32) -> f32 {
    let a = abs(x);
    var slope = 0.0;
    if a < 0.5 {
        slope = -2.0 * a;
    } else if a < 1.5 {
        slope = a - 1.5;
    }
    return slope * sign(x);
}

// Cubic B-spline of the thesis (eq. 37), support |x| < 2 (PIC/FLIP).
fn cubic(x: f32) -> f32 {
    let a = abs(x);
    if a < 1.0 {
        return 0.5 * a * a * a - a * a + 2.0 / 3.0;
    }
    if a < 2.0 {
        let b = 2.0 - a;
        return b * b * b / 6.0;
    }
    return 0.0;
}

// Derivative of the cubic B-spline (eq. 39).
fn cubic_slope(x: f32) -> f32 {
    let a = abs(x);
    var slope = 0.0;
    if a < 1.0 {
        slope = 1.5 * a * a - 2.0 * a;
    } else if a < 2.0 {
        let b = 2.0 - a;
        slope = -0.5 * b * b;
    }
    return slope * sign(x);
}

fn quadratic_weights(x: vec3<f32>) -> QuadraticWeights {
    let base = floor(x - vec3<f32>(0.5));
    var weights: QuadraticWeights;
    weights.base = vec3<i32>(base);
    weights.offset = x - base;
    for (var k = 0; k < 3; k++) {
        let d = weights.offset - vec3<f32>(f32(k));
        weights.values[k] = vec3<f32>(quadratic(d.x), quadratic(d.y), quadratic(d.z));
        weights.slopes[k] = vec3<f32>(quadratic_slope(d.x), quadratic_slope(d.y), quadratic_slope(d.z));
    }
    return weights;
}

fn cubic_weights(x: vec3<f32>) -> CubicWeights {
    let base = floor(x) - vec3<f32>(1.0);
    var weights: CubicWeights;
    weights.base = vec3<i32>(base);
    weights.offset = x - base;
    for (var k = 0; k < 4; k++) {
        let d = weights.offset - vec3<f32>(f32(k));
        weights.values[k] = vec3<f32>(cubic(d.x), cubic(d.y), cubic(d.z));
        weights.slopes[k] = vec3<f32>(cubic_slope(d.x), cubic_slope(d.y), cubic_slope(d.z));
    }
    return weights;
}

// Gradient of the weight of stencil node (i, j, k) per cell (eq. 40):
// the product rule applied per axis.
fn weight_gradient(values_i: vec3<f32>, values_j: vec3<f32>, values_k: vec3<f32>,
                   slopes_i: vec3<f32>, slopes_j: vec3<f32>, slopes_k: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        slopes_i.x * values_j.y * values_k.z,
        values_i.x * slopes_j.y * values_k.z,
        values_i.x * values_j.y * slopes_k.z,
    );
}
