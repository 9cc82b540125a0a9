// Counter-based random numbers of firn_flow::random: every draw is a 64-bit
// hash of (seed, particle id, generation, stream), so a particle reborn on
// the GPU gets the same birth place and lifetime as on the CPU. WGSL has no
// 64-bit integers; a u64 is vec2<u32>(low word, high word).

const RANDOM_MIX_1: vec2<u32> = vec2<u32>(0x1CE4E5B9u, 0xBF58476Du);
const RANDOM_MIX_2: vec2<u32> = vec2<u32>(0x133111EBu, 0x94D049BBu);
const RANDOM_ID: vec2<u32> = vec2<u32>(0x6659FD93u, 0xD6E8FEB8u);
const RANDOM_GENERATION: vec2<u32> = vec2<u32>(0x78BD642Fu, 0xA0761D64u);
const RANDOM_STREAM: vec2<u32> = vec2<u32>(0xA0B428DBu, 0xE7037ED1u);

// The full 64-bit product of two 32-bit words, from 16-bit halves.
fn wide_product(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xFFFFu;
    let a1 = a >> 16u;
    let b0 = b & 0xFFFFu;
    let b1 = b >> 16u;
    let low_low = a0 * b0;
    let low_high = a0 * b1;
    let high_low = a1 * b0;
    let middle = (low_low >> 16u) + (low_high & 0xFFFFu) + (high_low & 0xFFFFu);
    let low = (middle << 16u) | (low_low & 0xFFFFu);
    let high = a1 * b1 + (low_high >> 16u) + (high_low >> 16u) + (middle >> 16u);
    return vec2<u32>(low, high);
}

// a · b modulo 2⁶⁴.
fn wrapping_mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let low = wide_product(a.x, b.x);
    return vec2<u32>(low.x, low.y + a.x * b.y + a.y * b.x);
}

// a >> bits for 0 < bits < 32.
fn shift_right64(a: vec2<u32>, bits: u32) -> vec2<u32> {
    return vec2<u32>((a.x >> bits) | (a.y << (32u - bits)), a.y >> bits);
}

// The SplitMix64 finaliser (firn_flow::random::mix64).
fn mix64(input: vec2<u32>) -> vec2<u32> {
    var z = input;
    z = wrapping_mul64(z ^ shift_right64(z, 30u), RANDOM_MIX_1);
    z = wrapping_mul64(z ^ shift_right64(z, 27u), RANDOM_MIX_2);
    return z ^ shift_right64(z, 31u);
}

// 64 random bits for draw `stream` of life `generation` of particle `id`;
// `key` is mix64(seed ^ 0x9E3779B97F4A7C15), formed on the host.
fn random_bits(key: vec2<u32>, id: u32, generation: u32, stream: u32) -> vec2<u32> {
    var h = mix64(key ^ wrapping_mul64(vec2<u32>(id, 0u), RANDOM_ID));
    h = mix64(h ^ wrapping_mul64(vec2<u32>(generation, 0u), RANDOM_GENERATION));
    return mix64(h ^ wrapping_mul64(vec2<u32>(stream, 0u), RANDOM_STREAM));
}

// A uniform number in [0, 1) from the top 24 bits (exact in f32).
fn random_unit(key: vec2<u32>, id: u32, generation: u32, stream: u32) -> f32 {
    return f32(random_bits(key, id, generation, stream).y >> 8u) * (1.0 / 16777216.0);
}
