//! `firn bench --mesh-field`: what one mesh frame of a deforming collider
//! costs to sample, the narrow-band signed distance field that the solver
//! rebuilds each time the run reaches a new mesh file: a 20,000-triangle
//! UV sphere of radius 0.25 m (about a boot's size) at 1 cm, exact within
//! 6 cm of its surface (the band of a 2 cm grid).

use std::path::Path;
use std::time::Instant;

use firn_mesh::{NarrowBandField, TriangleMesh};
use glam::Vec3;
use serde::Serialize;

use crate::Failure;
use crate::bench::write_json;

/// Rings and segments of the sphere: 2 · 100 · 100 = 20,000 triangles.
const RINGS: u32 = 101;
const SEGMENTS: u32 = 100;
const RADIUS: f32 = 0.25;
const SPACING: f32 = 0.01;
const BAND: f32 = 0.06;

/// One measured field.
#[derive(Debug, Serialize)]
struct FieldRecord {
    triangles: usize,
    spacing_m: f32,
    band_m: f32,
    samples: u64,
    mib: f64,
    repeats: u32,
    ms_min: f64,
    ms_median: f64,
    threads: usize,
}

/// Builds the field `repeats` times, prints the figures and writes the
/// JSON record to `json`.
pub fn bench_mesh_field(repeats: u32, json: &Path) -> Result<(), Failure> {
    let sphere = uv_sphere();
    let footprint = NarrowBandField::footprint(&sphere, SPACING, BAND);
    let mut times: Vec<f64> = (0..repeats.max(1))
        .map(|_| {
            let started = Instant::now();
            let field = NarrowBandField::build(&sphere, SPACING, BAND);
            std::hint::black_box(&field);
            started.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    let record = FieldRecord {
        triangles: sphere.triangles.len(),
        spacing_m: SPACING,
        band_m: BAND,
        samples: footprint.samples(),
        mib: footprint.bytes() as f64 / (1024.0 * 1024.0),
        repeats: times.len() as u32,
        ms_min: times[0],
        ms_median: times[times.len() / 2],
        threads: rayon::current_num_threads(),
    };
    outln!(
        "firn mesh-field triangles={} spacing={} band={} samples={} mib={:.1} ms_min={:.1} ms_median={:.1} repeats={} threads={}",
        record.triangles,
        record.spacing_m,
        record.band_m,
        record.samples,
        record.mib,
        record.ms_min,
        record.ms_median,
        record.repeats,
        record.threads
    );
    write_json(json, &[record])
}

/// A closed UV sphere of [`RINGS`] × [`SEGMENTS`], triangles facing out.
fn uv_sphere() -> TriangleMesh {
    let mut vertices = vec![Vec3::new(0.0, RADIUS, 0.0)];
    for ring in 1..RINGS {
        let polar = std::f32::consts::PI * ring as f32 / RINGS as f32;
        for segment in 0..SEGMENTS {
            let azimuth = std::f32::consts::TAU * segment as f32 / SEGMENTS as f32;
            vertices.push(
                RADIUS
                    * Vec3::new(
                        polar.sin() * azimuth.cos(),
                        polar.cos(),
                        -polar.sin() * azimuth.sin(),
                    ),
            );
        }
    }
    let bottom = vertices.len() as u32;
    vertices.push(Vec3::new(0.0, -RADIUS, 0.0));
    let at = |ring: u32, segment: u32| 1 + (ring - 1) * SEGMENTS + segment % SEGMENTS;
    let mut triangles = Vec::new();
    for segment in 0..SEGMENTS {
        triangles.push([0, at(1, segment), at(1, segment + 1)]);
        triangles.push([bottom, at(RINGS - 1, segment + 1), at(RINGS - 1, segment)]);
    }
    for ring in 1..RINGS - 1 {
        for segment in 0..SEGMENTS {
            let (a, b) = (at(ring, segment), at(ring, segment + 1));
            let (c, d) = (at(ring + 1, segment), at(ring + 1, segment + 1));
            triangles.push([a, c, d]);
            triangles.push([a, d, b]);
        }
    }
    TriangleMesh {
        vertices,
        triangles,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sphere_has_twenty_thousand_outward_triangles_and_its_volume() {
        let sphere = uv_sphere();
        assert_eq!(sphere.triangles.len(), 20_000);
        let exact = 4.0 / 3.0 * std::f64::consts::PI * f64::from(RADIUS).powi(3);
        let volume = sphere.signed_volume();
        assert!(
            volume > 0.0 && (volume - exact).abs() < 0.01 * exact,
            "{volume} vs {exact}"
        );
    }
}
