//! Colours for particles: the bluish ramp the thesis borrows from Meyer
//! (thesis figure 7), and the colour-by-position mapping of seed 002.

use glam::Vec3;

use crate::film::decode_srgb;

/// Stops of the bluish ramp, from low to high values, in sRGB: deep blue
/// through sky blue to white.
const RAMP_STOPS: [[u8; 3]; 5] = [
    [28, 40, 92],
    [52, 94, 168],
    [110, 162, 220],
    [186, 216, 242],
    [248, 251, 255],
];

/// The ramp colour (linear RGB) at `t` in [0, 1] (clamped).
pub fn ramp(t: f32) -> Vec3 {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let scaled = t * (RAMP_STOPS.len() - 1) as f32;
    let index = (scaled.floor() as usize).min(RAMP_STOPS.len() - 2);
    let s = scaled - index as f32;
    decode_srgb(RAMP_STOPS[index]).lerp(decode_srgb(RAMP_STOPS[index + 1]), s)
}

/// A value range mapped onto the ramp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValueRange {
    /// Value at the low end of the ramp.
    pub low: f32,
    /// Value at the high end of the ramp.
    pub high: f32,
}

impl ValueRange {
    /// Position of `value` on the ramp, in [0, 1].
    pub fn normalize(&self, value: f32) -> f32 {
        let span = self.high - self.low;
        if span.abs() < f32::EPSILON {
            0.5
        } else {
            ((value - self.low) / span).clamp(0.0, 1.0)
        }
    }
}

/// How particles get their colour.
#[derive(Clone, Copy, Debug)]
pub enum Coloring<'a> {
    /// One value per particle through the bluish ramp.
    Ramp {
        /// The values, one per particle.
        values: &'a [f32],
        /// The range spanning the ramp.
        range: ValueRange,
    },
    /// |x|, |y|, |z| relative to the box as red, green, blue (seed 002).
    Position {
        /// Lower corner of the box.
        min: Vec3,
        /// Upper corner of the box.
        max: Vec3,
    },
    /// The same colour (linear RGB) for every particle.
    Uniform(Vec3),
}

impl Coloring<'_> {
    /// Linear colour of particle `index` at `position`.
    pub fn color(&self, index: usize, position: Vec3) -> Vec3 {
        match *self {
            Coloring::Ramp { values, range } => ramp(range.normalize(values[index])),
            Coloring::Position { min, max } => position_color(position, min, max),
            Coloring::Uniform(color) => color,
        }
    }
}

/// Seed 002's colour by position: each coordinate's distance from the box
/// centre, relative to the half extent, as a channel; lifted so no particle
/// is black.
pub fn position_color(position: Vec3, min: Vec3, max: Vec3) -> Vec3 {
    let center = 0.5 * (min + max);
    let half = (0.5 * (max - min)).max(Vec3::splat(1e-12));
    let t = ((position - center).abs() / half).clamp(Vec3::ZERO, Vec3::ONE);
    Vec3::splat(0.08) + t * 0.92
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_runs_from_blue_to_white() {
        let low = ramp(0.0);
        let high = ramp(1.0);
        assert!(low.z > low.x * 2.0, "low end is blue: {low}");
        assert!(high.min_element() > 0.9, "high end is white: {high}");
        // Brightness grows along the ramp.
        let mut previous = -1.0;
        for step in 0..=20 {
            let luminance = ramp(step as f32 / 20.0).dot(Vec3::new(0.2126, 0.7152, 0.0722));
            assert!(luminance > previous);
            previous = luminance;
        }
    }

    #[test]
    fn range_clamps_and_handles_empty_spans() {
        let range = ValueRange {
            low: 100.0,
            high: 300.0,
        };
        assert_eq!(range.normalize(200.0), 0.5);
        assert_eq!(range.normalize(1e9), 1.0);
        let flat = ValueRange {
            low: 1.0,
            high: 1.0,
        };
        assert_eq!(flat.normalize(7.0), 0.5);
    }

    #[test]
    fn position_colour_grows_away_from_the_centre() {
        let (min, max) = (Vec3::ZERO, Vec3::splat(2.0));
        assert_eq!(position_color(Vec3::ONE, min, max), Vec3::splat(0.08));
        assert_eq!(position_color(Vec3::new(2.0, 1.0, 0.0), min, max).x, 1.0);
    }
}
