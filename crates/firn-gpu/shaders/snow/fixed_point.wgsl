// 64-bit fixed-point sums from 32-bit integer atomics (see
// firn_gpu::snow::fixed_point): a value x becomes the integer round(x S)
// for the quantity's scale S, split into a signed high and an unsigned low
// word. The low word is added first; its carry goes into the high word.
// Integer addition is associative, so the sums do not depend on the order
// the GPU runs particles in.

const QUANTITY_MASS: u32 = 0u;
const QUANTITY_MOMENTUM_X: u32 = 1u;
const QUANTITY_MOMENTUM_Y: u32 = 2u;
const QUANTITY_MOMENTUM_Z: u32 = 3u;
const QUANTITY_FORCE_X: u32 = 4u;
const QUANTITY_FORCE_Y: u32 = 5u;
const QUANTITY_FORCE_Z: u32 = 6u;

const TWO_POW_32: f32 = 4294967296.0;

// round(x S) as (high, low) words of a 64-bit two's complement integer,
// exactly: the magnitude is split in f32 (a power-of-two division and the
// subtraction of a multiple of 2^32, both exact), then negated in integers.
fn to_fixed(scaled: f32) -> vec2<u32> {
    let magnitude = abs(round(scaled));
    let high = floor(magnitude / TWO_POW_32);
    let words = vec2<u32>(u32(high), u32(magnitude - high * TWO_POW_32));
    if scaled >= 0.0 {
        return words;
    }
    let low = ~words.y + 1u;
    return vec2<u32>(~words.x + select(0u, 1u, low == 0u), low);
}

fn from_fixed(high: u32, low: u32) -> f32 {
    return f32(bitcast<i32>(high)) * TWO_POW_32 + f32(low);
}

// Adds high into a high word; flags the quantity if the signed sum wrapped.
fn add_high(old: u32, added: u32, quantity: u32) {
    let before = bitcast<i32>(old);
    let step = bitcast<i32>(added);
    let after = before + step;
    if (step >= 0 && after < before) || (step < 0 && after > before) {
        atomicOr(&state.overflow, 1u << quantity);
    }
}

fn carry(old_low: u32, low: u32) -> u32 {
    return select(0u, 1u, old_low + low < old_low);
}

// Adds scaled (= x S) into node's sum of quantity.
fn add_to_grid(quantity: u32, node: u32, scaled: f32) {
    add_words_to_grid(quantity, node, to_fixed(scaled));
}

// Adds a 64-bit value given as (high, low) words into node's sum of quantity.
fn add_words_to_grid(quantity: u32, node: u32, words: vec2<u32>) {
    switch quantity {
        case QUANTITY_MASS: {
            let c = carry(atomicAdd(&mass_lo[node], words.y), words.y);
            add_high(atomicAdd(&mass_hi[node], words.x + c), words.x + c, quantity);
        }
        case QUANTITY_MOMENTUM_X: {
            let c = carry(atomicAdd(&px_lo[node], words.y), words.y);
            add_high(atomicAdd(&px_hi[node], words.x + c), words.x + c, quantity);
        }
        case QUANTITY_MOMENTUM_Y: {
            let c = carry(atomicAdd(&py_lo[node], words.y), words.y);
            add_high(atomicAdd(&py_hi[node], words.x + c), words.x + c, quantity);
        }
        case QUANTITY_MOMENTUM_Z: {
            let c = carry(atomicAdd(&pz_lo[node], words.y), words.y);
            add_high(atomicAdd(&pz_hi[node], words.x + c), words.x + c, quantity);
        }
        case QUANTITY_FORCE_X: {
            let c = carry(atomicAdd(&fx_lo[node], words.y), words.y);
            add_high(atomicAdd(&fx_hi[node], words.x + c), words.x + c, quantity);
        }
        case QUANTITY_FORCE_Y: {
            let c = carry(atomicAdd(&fy_lo[node], words.y), words.y);
            add_high(atomicAdd(&fy_hi[node], words.x + c), words.x + c, quantity);
        }
        default: {
            let c = carry(atomicAdd(&fz_lo[node], words.y), words.y);
            add_high(atomicAdd(&fz_hi[node], words.x + c), words.x + c, quantity);
        }
    }
}
