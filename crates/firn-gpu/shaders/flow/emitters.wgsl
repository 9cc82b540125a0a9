// Births as in firn_flow::emitters: a uniformly random point of the
// emitter's region and a lifetime, drawn from (seed, particle id,
// generation), and the fading birth velocity u₀ exp(−age / τ).

const EMITTER_BOX: u32 = 0u;
const EMITTER_SPHERE: u32 = 1u;
const STREAM_POSITION: u32 = 0u;
const STREAM_LIFETIME: u32 = 3u;
const TAU: f32 = 6.2831855;

fn birth_unit(id: u32, generation: u32, stream: u32) -> f32 {
    return random_unit(field_constants.random_key, id, generation, stream);
}

// (cos, sin) of 2π u for u in [0, 1), with the argument kept in [−π, π)
// where GPUs bound the error of their sine and cosine.
fn turn(u: f32) -> vec2<f32> {
    let angle = TAU * (u - select(0.0, 1.0, u >= 0.5));
    return vec2<f32>(cos(angle), sin(angle));
}

// ∛u for u in [0, 1): pow, refined by one Newton step.
fn cube_root(u: f32) -> f32 {
    let guess = pow(u, 1.0 / 3.0);
    if guess <= 0.0 {
        return 0.0;
    }
    return guess - (guess * guess * guess - u) / (3.0 * guess * guess);
}

// The birth point of life `generation` of particle `id` of emitter e.
fn birth_position(e: Emitter, id: u32, generation: u32) -> vec3<f32> {
    let u = vec3<f32>(
        birth_unit(id, generation, STREAM_POSITION),
        birth_unit(id, generation, STREAM_POSITION + 1u),
        birth_unit(id, generation, STREAM_POSITION + 2u),
    );
    let center = e.center.xyz;
    if e.shape == EMITTER_BOX {
        return center + (u - 0.5) * e.size.xyz;
    }
    if e.shape == EMITTER_SPHERE {
        // Uniform in the ball: z uniform, radius ∝ ∛u.
        let z = 2.0 * u.x - 1.0;
        let around = turn(u.y);
        let ring = sqrt(max(1.0 - z * z, 0.0));
        let direction = vec3<f32>(ring * around.x, ring * around.y, z);
        return center + direction * e.center.w * cube_root(u.z);
    }
    // A disc, uniform over its area: radius ∝ √u.
    let around = turn(u.x);
    let r = e.center.w * sqrt(u.y);
    return center + (e.tangent.xyz * around.x + e.bitangent.xyz * around.y) * r;
}

// The length of life `generation` of particle `id`: +∞ (the emitter's
// `lifetime`, set by the host) for emitters without a lifetime.
fn birth_lifetime(e: Emitter, id: u32, generation: u32) -> f32 {
    if e.has_lifetime == 0u {
        return e.lifetime;
    }
    let u = birth_unit(id, generation, STREAM_LIFETIME);
    return e.lifetime * (1.0 + e.lifetime_spread * (2.0 * u - 1.0));
}

fn has_kick(e: Emitter) -> bool {
    return any(e.velocity.xyz != vec3<f32>(0.0));
}

// The birth velocity's displacement over (age, age + dt).
fn kick(e: Emitter, age: f32, dt: f32) -> vec3<f32> {
    if !has_kick(e) {
        return vec3<f32>(0.0);
    }
    let tau = e.velocity.w;
    let faded = exp(-age / tau) - exp(-(age + dt) / tau);
    return e.velocity.xyz * (tau * faded);
}

// The birth velocity left at `age`.
fn kick_velocity(e: Emitter, age: f32) -> vec3<f32> {
    if !has_kick(e) {
        return vec3<f32>(0.0);
    }
    return e.velocity.xyz * exp(-age / e.velocity.w);
}
