//! Helpers shared by the GPU tests: deforming box sequences (one OBJ file
//! per mesh frame) and the comparison of two particle sets as
//! distributions.

#![allow(dead_code)]

use std::path::Path;

use glam::Vec3;

/// One mesh frame of a box sequence: the box from `low` to `high`, its
/// bottom four corners moved by `shear`.
pub struct BoxFrame {
    /// The lowest corner before the shear.
    pub low: Vec3,
    /// The highest corner.
    pub high: Vec3,
    /// How far the bottom corners move.
    pub shear: Vec3,
}

/// Writes `frames` into `folder` as `box_0001.obj`, `box_0002.obj`, ...:
/// boxes of twelve outward triangles, their corners in one order so that
/// every frame has the same topology. Returns the pattern.
pub fn write_box_sequence(folder: &Path, frames: &[BoxFrame]) -> String {
    for (k, frame) in frames.iter().enumerate() {
        let mut text = String::new();
        for i in 0..8 {
            let pick = |bit: u32, a: f32, b: f32| if i & bit == 0 { a } else { b };
            let mut corner = Vec3::new(
                pick(1, frame.low.x, frame.high.x),
                pick(2, frame.low.y, frame.high.y),
                pick(4, frame.low.z, frame.high.z),
            );
            if i & 2 == 0 {
                corner += frame.shear;
            }
            text += &format!("v {} {} {}\n", corner.x, corner.y, corner.z);
        }
        for [a, b, c, d] in [
            [1, 3, 4, 2],
            [5, 6, 8, 7],
            [1, 2, 6, 5],
            [3, 7, 8, 4],
            [1, 5, 7, 3],
            [2, 4, 8, 6],
        ] {
            text += &format!("f {a} {b} {c}\nf {a} {c} {d}\n");
        }
        std::fs::write(folder.join(format!("box_{:04}.obj", k + 1)), text).unwrap();
    }
    "box_####.obj".into()
}

/// The largest difference between the sorted values of each axis of `a`
/// and of `b`: the marginals' quantiles. The CPU reorders its particles,
/// so the two backends' sets are compared as distributions.
pub fn quantile_gap(a: &[Vec3], b: &[Vec3]) -> f32 {
    (0..3)
        .map(|axis| {
            let sorted = |values: &[Vec3]| {
                let mut sorted: Vec<f32> = values.iter().map(|v| v[axis]).collect();
                sorted.sort_by(f32::total_cmp);
                sorted
            };
            sorted(a)
                .iter()
                .zip(&sorted(b))
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f32::max)
        })
        .fold(0.0, f32::max)
}
