//! The supersampled frame buffer: linear colour and depth per sample,
//! processed in horizontal bands so that rayon can work on bands in parallel
//! while every pixel still sees its writes in one fixed order (deterministic
//! results for any thread count).

use glam::{Vec2, Vec3};
use image::RgbImage;
use rayon::prelude::*;

/// Rows per band. Small enough for load balance, large enough that a sprite
/// rarely spans more than two bands.
pub const BAND_ROWS: u32 = 16;

/// Linear-light colour and depth per sample.
pub struct Film {
    /// Width in samples.
    pub width: u32,
    /// Height in samples.
    pub height: u32,
    /// Linear RGB per sample, row-major from the top-left.
    pub color: Vec<Vec3>,
    /// Distance along the view direction of what covers each sample
    /// (`f32::INFINITY` for the background).
    pub depth: Vec<f32>,
}

/// A horizontal band of the film, lent to one worker.
pub struct Band<'a> {
    /// First row of the band.
    pub y0: u32,
    /// Width of the film in samples.
    pub width: u32,
    /// Colour of the band's samples, row-major.
    pub color: &'a mut [Vec3],
    /// Depth of the band's samples, row-major.
    pub depth: &'a mut [f32],
}

impl Band<'_> {
    /// Rows covered by the band, as a half-open range.
    pub fn rows(&self) -> std::ops::Range<u32> {
        self.y0..self.y0 + (self.color.len() as u32 / self.width)
    }

    /// Index into the band's slices of sample (x, y), y in film rows.
    pub fn index(&self, x: u32, y: u32) -> usize {
        ((y - self.y0) * self.width + x) as usize
    }

    /// Writes `color` at (x, y) if `depth` is nearer than what is there.
    pub fn depth_write(&mut self, x: u32, y: u32, depth: f32, color: Vec3) {
        let index = self.index(x, y);
        if depth < self.depth[index] {
            self.depth[index] = depth;
            self.color[index] = color;
        }
    }
}

impl Film {
    /// A film of `width` × `height` samples, all background at infinite depth.
    pub fn new(width: u32, height: u32) -> Film {
        let samples = (width * height) as usize;
        Film {
            width,
            height,
            color: vec![Vec3::ZERO; samples],
            depth: vec![f32::INFINITY; samples],
        }
    }

    /// Number of bands.
    pub fn band_count(&self) -> usize {
        self.height.div_ceil(BAND_ROWS) as usize
    }

    /// The band that holds row `y`.
    pub fn band_of(y: u32) -> usize {
        (y / BAND_ROWS) as usize
    }

    /// Runs `work` on every band in parallel, passing the band's index.
    pub fn par_bands(&mut self, work: impl Fn(usize, Band<'_>) + Sync) {
        let chunk = (BAND_ROWS * self.width) as usize;
        let width = self.width;
        self.color
            .par_chunks_mut(chunk)
            .zip(self.depth.par_chunks_mut(chunk))
            .enumerate()
            .for_each(|(index, (color, depth))| {
                let band = Band {
                    y0: index as u32 * BAND_ROWS,
                    width,
                    color,
                    depth,
                };
                work(index, band);
            });
    }

    /// For each band, the indices of the discs (centre and radius in
    /// samples) that touch it, in order. Discs off the film, or with a
    /// non-finite centre, are left out.
    pub fn bin_discs(&self, discs: impl Iterator<Item = (Vec2, f32)>) -> Vec<Vec<u32>> {
        let mut bins = vec![Vec::new(); self.band_count()];
        let (width, height) = (self.width as f32, self.height as f32);
        for (index, (center, radius)) in discs.enumerate() {
            let visible = center.is_finite()
                && center.x + radius >= 0.0
                && center.x - radius <= width
                && center.y + radius >= 0.0
                && center.y - radius <= height;
            if !visible {
                continue;
            }
            let top = (center.y - radius).max(0.0) as u32;
            let bottom = (center.y + radius).min(height - 1.0) as u32;
            for bin in &mut bins[Film::band_of(top)..=Film::band_of(bottom)] {
                bin.push(index as u32);
            }
        }
        bins
    }

    /// Averages `factor` × `factor` blocks of samples (a box filter, which is
    /// the anti-aliasing) and encodes the result as 8-bit sRGB.
    pub fn resolve(&self, factor: u32) -> RgbImage {
        let (width, height) = (self.width / factor, self.height / factor);
        let mut pixels = vec![0u8; (width * height * 3) as usize];
        let weight = 1.0 / (factor * factor) as f32;
        pixels
            .par_chunks_mut((width * 3) as usize)
            .enumerate()
            .for_each(|(y, row)| {
                for x in 0..width {
                    let mut sum = Vec3::ZERO;
                    for sy in 0..factor {
                        let line = ((y as u32 * factor + sy) * self.width) as usize;
                        for sx in 0..factor {
                            sum += self.color[line + (x * factor + sx) as usize];
                        }
                    }
                    let encoded = encode_srgb(sum * weight);
                    row[(x * 3) as usize..(x * 3 + 3) as usize].copy_from_slice(&encoded);
                }
            });
        RgbImage::from_raw(width, height, pixels).expect("the buffer matches the image size")
    }
}

/// A sample inside a disc: its film coordinates, its offset from the centre
/// in units of the radius, and the squared length of that offset (< 1).
#[derive(Clone, Copy, Debug)]
pub struct DiscSample {
    /// Column.
    pub x: u32,
    /// Row.
    pub y: u32,
    /// Horizontal offset from the centre / radius.
    pub dx: f32,
    /// Vertical offset from the centre / radius (positive downwards).
    pub dy: f32,
    /// dx² + dy².
    pub r2: f32,
}

/// The samples of rows `rows` (and columns below `width`) whose centres lie
/// inside the disc at `center` with `radius`, all in samples.
pub fn disc_samples(
    center: Vec2,
    radius: f32,
    rows: std::ops::Range<u32>,
    width: u32,
) -> impl Iterator<Item = DiscSample> {
    let y_start = (center.y - radius).floor().max(rows.start as f32) as u32;
    let y_end = (center.y + radius).ceil().min(rows.end as f32).max(0.0) as u32;
    let x_start = (center.x - radius).floor().max(0.0) as u32;
    let x_end = (center.x + radius).ceil().min(width as f32).max(0.0) as u32;
    let inverse_radius = 1.0 / radius;
    (y_start..y_end).flat_map(move |y| {
        let dy = (y as f32 + 0.5 - center.y) * inverse_radius;
        (x_start..x_end).filter_map(move |x| {
            let dx = (x as f32 + 0.5 - center.x) * inverse_radius;
            let r2 = dx * dx + dy * dy;
            (r2 < 1.0).then_some(DiscSample { x, y, dx, dy, r2 })
        })
    })
}

/// Linear light to 8-bit sRGB, clamped.
pub fn encode_srgb(linear: Vec3) -> [u8; 3] {
    linear.to_array().map(|channel| {
        let c = channel.clamp(0.0, 1.0);
        let srgb = if c <= 0.003_130_8 {
            12.92 * c
        } else {
            1.055 * c.powf(1.0 / 2.4) - 0.055
        };
        (srgb * 255.0 + 0.5) as u8
    })
}

/// 8-bit sRGB to linear light.
pub fn decode_srgb(srgb: [u8; 3]) -> Vec3 {
    Vec3::from_array(srgb.map(|channel| {
        let c = channel as f32 / 255.0;
        if c <= 0.040_45 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips() {
        for value in [0u8, 1, 17, 128, 200, 255] {
            let rgb = [value, value / 2, 255 - value];
            assert_eq!(encode_srgb(decode_srgb(rgb)), rgb);
        }
    }

    #[test]
    fn bands_cover_the_film_once() {
        let mut film = Film::new(7, 40);
        film.par_bands(|_, band| {
            for y in band.rows() {
                for x in 0..band.width {
                    let index = band.index(x, y);
                    band.color[index] += Vec3::ONE;
                }
            }
        });
        assert!(film.color.iter().all(|&c| c == Vec3::ONE));
        assert_eq!(film.band_count(), 3);
    }

    #[test]
    fn resolve_averages_blocks() {
        let mut film = Film::new(4, 2);
        film.color[0] = Vec3::ONE;
        film.color[1] = Vec3::ONE;
        let image = film.resolve(2);
        assert_eq!(image.dimensions(), (2, 1));
        assert_eq!(image.get_pixel(0, 0).0, encode_srgb(Vec3::splat(0.5)));
        assert_eq!(image.get_pixel(1, 0).0, [0, 0, 0]);
    }
}
