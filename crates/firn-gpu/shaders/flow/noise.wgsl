// 3D simplex noise with its analytic gradient: the noise n of seed 002,
// eq. 1, exactly as firn_flow::noise computes it (same skew, kernel radius
// r² = 1/2, arithmetic lattice hash and twelve cube-edge gradients), so the
// values agree with the CPU to f32 round-off. Corner c at offset d adds
//
//   n_c = t⁴ (g_c · d),  ∇n_c = t⁴ g_c − 8 t³ (g_c · d) d,  t = max(0, r² − |d|²).

const SIMPLEX_SKEW: f32 = 1.0 / 3.0;
const SIMPLEX_UNSKEW: f32 = 1.0 / 6.0;
const SIMPLEX_RADIUS_SQUARED: f32 = 0.5;
const SIMPLEX_SCALE: f32 = 76.0;
// Lattice coordinates are clamped to ±2³⁰ before the integer conversion.
const SIMPLEX_FLOOR_LIMIT: f32 = 1073741824.0;
// Odd multipliers of the lattice coordinates in the hash.
const HASH_MULTIPLIERS: vec3<u32> = vec3<u32>(0x8DA6B343u, 0xD8163841u, 0xCB1AB31Fu);

struct NoiseSample {
    value: f32,
    gradient: vec3<f32>,
}

// The xorshift-multiply-xorshift finaliser of the lattice hash (one multiply).
fn mix_hash(input: u32) -> u32 {
    var h = input;
    h = h ^ (h >> 15u);
    h = h * 0x7FEB352Du;
    return h ^ (h >> 13u);
}

// One of the twelve cube-edge midpoints: the zero axis from the low 16 bits,
// the signs from bits 16 and 17.
fn lattice_gradient(hash: u32) -> vec3<f32> {
    let low = hash & 0xFFFFu;
    let zero_axis = (low + (low << 1u)) >> 16u;
    let first_sign = select(-1.0, 1.0, (hash & 0x10000u) == 0u);
    let second_sign = select(-1.0, 1.0, (hash & 0x20000u) == 0u);
    return vec3<f32>(
        select(first_sign, 0.0, zero_axis == 0u),
        select(select(second_sign, 0.0, zero_axis == 1u), first_sign, zero_axis == 0u),
        select(second_sign, 0.0, zero_axis == 2u),
    );
}

// The contribution of one corner at offset d with lattice hash `hash`.
fn simplex_corner(d: vec3<f32>, hash: u32) -> NoiseSample {
    let g = lattice_gradient(hash);
    let t = max(SIMPLEX_RADIUS_SQUARED - (d.x * d.x + d.y * d.y + d.z * d.z), 0.0);
    let t2 = t * t;
    let t4 = t2 * t2;
    let g_dot_d = g.x * d.x + g.y * d.y + g.z * d.z;
    let falloff = 8.0 * t2 * t * g_dot_d;
    return NoiseSample(t4 * g_dot_d, t4 * g - falloff * d);
}

// Hash of the corner that steps one lattice cell along the axes in `steps`.
fn corner_hash(base: vec3<u32>, next: vec3<u32>, steps: vec3<bool>) -> u32 {
    let products = select(base, next, steps);
    return mix_hash(products.x ^ products.y ^ products.z);
}

// Simplex noise n(p) in about [−1, 1] and its exact gradient ∇n(p).
fn simplex3(p: vec3<f32>) -> NoiseSample {
    let skew = (p.x + p.y + p.z) * SIMPLEX_SKEW;
    let cell = floor(clamp(p + skew, vec3<f32>(-SIMPLEX_FLOOR_LIMIT), vec3<f32>(SIMPLEX_FLOOR_LIMIT)));
    let unskew = (cell.x + cell.y + cell.z) * SIMPLEX_UNSKEW;
    let d0 = p - (cell - unskew);

    // Which of the cell's six simplices: axes from the largest offset down.
    let x_ge_y = d0.y <= d0.x;
    let x_ge_z = d0.z <= d0.x;
    let y_ge_z = d0.z <= d0.y;
    let first_step = vec3<bool>(x_ge_y && x_ge_z, !x_ge_y && y_ge_z, !x_ge_z && !y_ge_z);
    let second_step = vec3<bool>(x_ge_y || x_ge_z, !x_ge_y || y_ge_z, !x_ge_z || !y_ge_z);
    let d1 = d0 - vec3<f32>(first_step) + SIMPLEX_UNSKEW;
    let d2 = d0 - vec3<f32>(second_step) + 2.0 * SIMPLEX_UNSKEW;
    let d3 = d0 + (3.0 * SIMPLEX_UNSKEW - 1.0);

    let base = bitcast<vec3<u32>>(vec3<i32>(cell)) * HASH_MULTIPLIERS;
    let next = base + HASH_MULTIPLIERS;
    let c0 = simplex_corner(d0, mix_hash(base.x ^ base.y ^ base.z));
    let c1 = simplex_corner(d1, corner_hash(base, next, first_step));
    let c2 = simplex_corner(d2, corner_hash(base, next, second_step));
    let c3 = simplex_corner(d3, mix_hash(next.x ^ next.y ^ next.z));
    let value = ((c0.value + c1.value) + c2.value) + c3.value;
    let gradient = ((c0.gradient + c1.gradient) + c2.gradient) + c3.gradient;
    return NoiseSample(value * SIMPLEX_SCALE, gradient * SIMPLEX_SCALE);
}
