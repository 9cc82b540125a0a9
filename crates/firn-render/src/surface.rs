//! Style `surface`: the snow's reconstructed surface (a closed triangle
//! mesh) rasterised with a depth test and shaded like the colliders
//! (Blinn-Phong under the stage's light), with smooth normals.
//!
//! Vertex normals are the area-weighted sums of the triangles' normals.
//! Depth and normals are interpolated perspective-correctly (through 1/depth).
//! Triangles are binned by the film bands they touch; each band draws its
//! triangles in mesh order, so the picture does not depend on the thread
//! count.

use firn_mesh::TriangleMesh;
use glam::{Vec2, Vec3};

use crate::camera::CameraView;
use crate::film::Film;
use crate::stage::Stage;

/// Albedo of the snow's surface: a slightly blue white.
pub const SNOW_ALBEDO: Vec3 = Vec3::new(0.80, 0.84, 0.90);
/// Blinn-Phong exponent of the snow's surface: a broad, soft highlight.
pub const SNOW_SHININESS: f32 = 12.0;

/// A vertex projected onto the film.
#[derive(Clone, Copy)]
struct ScreenVertex {
    pixel: Vec2,
    inverse_depth: f32,
}

/// Draws `mesh` over `film`, shaded as the stage shades its solids.
pub fn draw_surface(film: &mut Film, camera: &CameraView, mesh: &TriangleMesh, stage: &Stage) {
    let normals = vertex_normals(mesh);
    let projected: Vec<Option<ScreenVertex>> = mesh
        .vertices
        .iter()
        .map(|&vertex| {
            camera.project(vertex).map(|p| ScreenVertex {
                pixel: p.pixel,
                inverse_depth: 1.0 / p.depth,
            })
        })
        .collect();
    let screen = |triangle: &[u32; 3]| -> Option<[ScreenVertex; 3]> {
        let [a, b, c] = triangle.map(|index| projected[index as usize]);
        Some([a?, b?, c?])
    };
    let bins = film.bin_discs(mesh.triangles.iter().map(|triangle| {
        screen(triangle).map_or((Vec2::NAN, 0.0), |corners| {
            let low = corners[0].pixel.min(corners[1].pixel).min(corners[2].pixel);
            let high = corners[0].pixel.max(corners[1].pixel).max(corners[2].pixel);
            (0.5 * (low + high), 0.5 * (high - low).length())
        })
    }));
    film.par_bands(|band_index, band| {
        let rows = band.rows();
        for &index in &bins[band_index] {
            let triangle = &mesh.triangles[index as usize];
            let Some(corners) = screen(triangle) else {
                continue;
            };
            let [p0, p1, p2] = corners.map(|corner| corner.pixel);
            let area = edge(p0, p1, p2);
            if area.abs() < 1e-12 {
                continue;
            }
            let low = p0.min(p1).min(p2);
            let high = p0.max(p1).max(p2);
            let x_range = sample_range(low.x, high.x, band.width);
            let ys = sample_range(low.y, high.y, rows.end);
            let y_range = ys.start.max(rows.start)..ys.end;
            let corner_normals = triangle.map(|vertex| normals[vertex as usize]);
            for y in y_range {
                for x in x_range.clone() {
                    let sample = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    let weights = [
                        edge(p1, p2, sample),
                        edge(p2, p0, sample),
                        edge(p0, p1, sample),
                    ]
                    .map(|w| w / area);
                    if weights.iter().any(|&w| w < 0.0) {
                        continue;
                    }
                    let perspective = [0, 1, 2].map(|i| weights[i] * corners[i].inverse_depth);
                    let depth = 1.0 / perspective.iter().sum::<f32>();
                    let at = band.index(x, y);
                    if depth >= band.depth[at] {
                        continue;
                    }
                    let normal = (0..3)
                        .map(|i| corner_normals[i] * perspective[i])
                        .sum::<Vec3>()
                        .normalize_or(Vec3::Y);
                    let direction = camera.ray(sample);
                    band.depth[at] = depth;
                    band.color[at] =
                        stage.shade_solid(normal, direction, SNOW_ALBEDO, SNOW_SHININESS);
                }
            }
        }
    });
}

/// The samples whose centres lie in [low, high], clamped to 0..limit.
fn sample_range(low: f32, high: f32, limit: u32) -> std::ops::Range<u32> {
    let first = (low - 0.5).ceil().max(0.0);
    let last = (high - 0.5).floor() + 1.0;
    let end = last.clamp(0.0, limit as f32) as u32;
    (first.min(limit as f32) as u32)..end
}

/// Twice the signed area of the triangle (a, b, c) on the film.
fn edge(a: Vec2, b: Vec2, c: Vec2) -> f32 {
    (b - a).perp_dot(c - a)
}

/// The unit normal at each vertex: the sum of its triangles' normals
/// weighted by their areas.
pub fn vertex_normals(mesh: &TriangleMesh) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; mesh.vertices.len()];
    for &[a, b, c] in &mesh.triangles {
        let [pa, pb, pc] = [a, b, c].map(|index| mesh.vertices[index as usize]);
        let face = (pb - pa).cross(pc - pa);
        for index in [a, b, c] {
            normals[index as usize] += face;
        }
    }
    normals
        .into_iter()
        .map(|normal| normal.normalize_or(Vec3::Y))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_ranges_hold_the_covered_centres() {
        assert_eq!(sample_range(0.2, 2.6, 10), 0..3);
        assert_eq!(sample_range(0.6, 1.4, 10), 1..1);
        assert_eq!(sample_range(-5.0, 20.0, 10), 0..10);
    }

    #[test]
    fn normals_of_a_tetrahedron_point_outwards() {
        let mesh = TriangleMesh {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        };
        let normals = vertex_normals(&mesh);
        let centre = Vec3::splat(0.25);
        for (vertex, normal) in mesh.vertices.iter().zip(&normals) {
            assert!((*vertex - centre).dot(*normal) > 0.0);
        }
    }
}
