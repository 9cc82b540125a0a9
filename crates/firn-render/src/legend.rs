//! Text and the colour-ramp legend, drawn onto finished images with the
//! public-domain 8x8 bitmap font of the `font8x8` crate.

use font8x8::legacy::BASIC_LEGACY;
use image::{Rgb, RgbImage};

use crate::film::encode_srgb;
use crate::ramp::{ValueRange, ramp};

/// Text colour.
const INK: Rgb<u8> = Rgb([235, 238, 242]);
/// Panel colour behind the legend.
const PANEL: Rgb<u8> = Rgb([24, 26, 32]);

/// A legend: what the colours mean.
#[derive(Clone, Debug, PartialEq)]
pub struct Legend {
    /// Name of the quantity, with its unit.
    pub title: String,
    /// The value range of the ramp.
    pub range: ValueRange,
}

/// Pixel scale of the 8x8 font for an image `height` pixels tall.
pub fn text_scale(height: u32) -> u32 {
    (height / 360).max(1)
}

/// Draws `text` with its top-left corner at (x, y), `scale` pixels per font pixel.
pub fn draw_text(image: &mut RgbImage, text: &str, x: u32, y: u32, scale: u32, color: Rgb<u8>) {
    for (column, character) in text.chars().enumerate() {
        let glyph = BASIC_LEGACY[(character as usize).min(127)];
        let left = x + column as u32 * 8 * scale;
        for (row, bits) in glyph.iter().enumerate() {
            for bit in 0..8 {
                if bits & (1 << bit) == 0 {
                    continue;
                }
                fill(
                    image,
                    left + bit * scale,
                    y + row as u32 * scale,
                    scale,
                    scale,
                    color,
                );
            }
        }
    }
}

/// Width in pixels of `text` at `scale`.
pub fn text_width(text: &str, scale: u32) -> u32 {
    text.chars().count() as u32 * 8 * scale
}

/// Draws the legend in the top-right corner: a vertical ramp from the low
/// value (bottom) to the high value (top), labelled, with the title above.
pub fn draw_legend(image: &mut RgbImage, legend: &Legend) {
    let scale = text_scale(image.height());
    let bar_height = image.height() / 3;
    let bar_width = 10 * scale;
    let high = format_value(legend.range.high);
    let low = format_value(legend.range.low);
    let label_width = text_width(&high, scale).max(text_width(&low, scale));
    let panel_width =
        (bar_width + 6 * scale + label_width).max(text_width(&legend.title, scale)) + 8 * scale;
    let panel_height = bar_height + 22 * scale;
    let margin = 8 * scale;
    let Some(left) = image.width().checked_sub(panel_width + margin) else {
        return;
    };
    let top = margin;
    fill(image, left, top, panel_width, panel_height, PANEL);
    draw_text(
        image,
        &legend.title,
        left + 4 * scale,
        top + 4 * scale,
        scale,
        INK,
    );
    let bar_left = left + 4 * scale;
    let bar_top = top + 16 * scale;
    for row in 0..bar_height {
        let t = 1.0 - row as f32 / (bar_height - 1).max(1) as f32;
        let color = Rgb(encode_srgb(ramp(t)));
        fill(image, bar_left, bar_top + row, bar_width, 1, color);
    }
    let label_left = bar_left + bar_width + 4 * scale;
    draw_text(image, &high, label_left, bar_top, scale, INK);
    draw_text(
        image,
        &low,
        label_left,
        bar_top + bar_height - 8 * scale,
        scale,
        INK,
    );
}

/// A short label for a legend value.
fn format_value(value: f32) -> String {
    let magnitude = value.abs();
    if magnitude != 0.0 && !(0.01..10_000.0).contains(&magnitude) {
        format!("{value:.1e}")
    } else if magnitude >= 100.0 {
        format!("{value:.0}")
    } else {
        format!("{value:.2}")
    }
}

/// Fills a rectangle, clipped to the image.
fn fill(image: &mut RgbImage, x: u32, y: u32, width: u32, height: u32, color: Rgb<u8>) {
    for row in y..(y + height).min(image.height()) {
        for column in x..(x + width).min(image.width()) {
            image.put_pixel(column, row, color);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_marks_pixels_only_where_it_is_written() {
        let mut image = RgbImage::new(64, 16);
        draw_text(&mut image, "8", 0, 0, 1, INK);
        let inked = image.pixels().filter(|p| **p == INK).count();
        assert!(inked > 10, "the glyph has ink");
        assert!(image.enumerate_pixels().all(|(x, _, p)| x < 8 || *p != INK));
    }

    #[test]
    fn legend_shows_the_ramp_in_the_top_right() {
        let mut image = RgbImage::new(640, 360);
        let legend = Legend {
            title: "density kg/m3".into(),
            range: ValueRange {
                low: 200.0,
                high: 600.0,
            },
        };
        draw_legend(&mut image, &legend);
        let top_right = image.get_pixel(636, 4);
        assert_eq!(*top_right, Rgb([0, 0, 0]), "the margin stays clear");
        let left_half_touched = image
            .enumerate_pixels()
            .any(|(x, _, p)| x < 320 && p.0 != [0; 3]);
        assert!(!left_half_touched);
        assert_eq!(format_value(0.0012), "1.2e-3");
        assert_eq!(format_value(450.0), "450");
    }
}
