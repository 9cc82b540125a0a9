//! Per-triangle geometry: exact solid angles and closest points.

use glam::Vec3;

/// The signed solid angle of triangle `(a, b, c)`, given relative to the
/// viewpoint, by the formula of Van Oosterom and Strackee (1983):
/// tan(Ω/2) = a·(b×c) / (|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|).
/// Positive when the viewpoint sees the triangle's back (it is inside a
/// closed outward-facing mesh); zero, never NaN, for a degenerate triangle
/// or a viewpoint on a vertex.
pub(crate) fn solid_angle(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let det = a.dot(b.cross(c));
    let denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * det.atan2(denominator)
}

/// The point of a triangle closest to a query, and its barycentric
/// weights on the corners `(a, b, c)`: zero weights tell the feature it
/// lies on (none: the face; one: the edge between the other two corners;
/// two: a corner).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ClosestPoint {
    pub point: Vec3,
    pub weights: [f32; 3],
}

/// The point of triangle `(a, b, c)` closest to `p`, by the Voronoi-region
/// walk of Ericson ("Real-Time Collision Detection", 5.1.5). Zero-area
/// triangles fall back to the closest point on their three edges.
pub(crate) fn closest_point_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    closest_on_triangle(p, a, b, c).point
}

/// [`closest_point_on_triangle`] with the point's barycentric weights.
pub(crate) fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> ClosestPoint {
    let closest = if (b - a).cross(c - a) == Vec3::ZERO {
        None
    } else {
        closest_by_regions(p, a, b, c).filter(|q| q.point.is_finite())
    };
    closest.unwrap_or_else(|| closest_on_edges(p, a, b, c))
}

fn closest_by_regions(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Option<ClosestPoint> {
    let at = |point: Vec3, weights: [f32; 3]| Some(ClosestPoint { point, weights });
    let (ab, ac) = (b - a, c - a);
    let (d1, d2) = (ab.dot(p - a), ac.dot(p - a));
    if d1 <= 0.0 && d2 <= 0.0 {
        return at(a, [1.0, 0.0, 0.0]);
    }
    let (d3, d4) = (ab.dot(p - b), ac.dot(p - b));
    if d3 >= 0.0 && d4 <= d3 {
        return at(b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let s = d1 / (d1 - d3);
        return at(a + ab * s, [1.0 - s, s, 0.0]);
    }
    let (d5, d6) = (ab.dot(p - c), ac.dot(p - c));
    if d6 >= 0.0 && d5 <= d6 {
        return at(c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let s = d2 / (d2 - d6);
        return at(a + ac * s, [1.0 - s, 0.0, s]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let s = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return at(b + (c - b) * s, [0.0, 1.0 - s, s]);
    }
    let scale = 1.0 / (va + vb + vc);
    let (v, w) = (vb * scale, vc * scale);
    at(a + ab * v + ac * w, [1.0 - v - w, v, w])
}

fn closest_on_edges(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> ClosestPoint {
    let on_edge = |from: Vec3, to: Vec3, corners: [usize; 2]| {
        let (point, s) = closest_on_segment(p, from, to);
        let mut weights = [0.0; 3];
        weights[corners[0]] = 1.0 - s;
        weights[corners[1]] += s;
        ClosestPoint { point, weights }
    };
    [
        on_edge(a, b, [0, 1]),
        on_edge(b, c, [1, 2]),
        on_edge(c, a, [2, 0]),
    ]
    .into_iter()
    .min_by(|x, y| {
        x.point
            .distance_squared(p)
            .total_cmp(&y.point.distance_squared(p))
    })
    .unwrap_or(ClosestPoint {
        point: a,
        weights: [1.0, 0.0, 0.0],
    })
}

/// The point of segment `ab` closest to `p` and its parameter in [0, 1].
fn closest_on_segment(p: Vec3, a: Vec3, b: Vec3) -> (Vec3, f32) {
    let ab = b - a;
    let length_squared = ab.length_squared();
    if length_squared == 0.0 {
        return (a, 0.0);
    }
    let s = ((p - a).dot(ab) / length_squared).clamp(0.0, 1.0);
    (a + ab * s, s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solid_angle_of_an_octant_triangle_is_an_eighth_of_the_sphere() {
        let omega = solid_angle(Vec3::X, Vec3::Y, Vec3::Z);
        assert!((omega - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        assert!((solid_angle(Vec3::X, Vec3::Z, Vec3::Y) + omega).abs() < 1e-6);
        assert_eq!(solid_angle(Vec3::ZERO, Vec3::Y, Vec3::Z), 0.0);
    }

    #[test]
    fn closest_point_covers_every_region_and_degenerate_triangles() {
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        let cases = [
            (Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.2, 0.2, 0.0)),
            (Vec3::new(-1.0, -1.0, 0.0), a),
            (Vec3::new(2.0, -0.5, 0.0), b),
            (Vec3::new(-0.5, 2.0, 0.0), c),
            (Vec3::new(0.5, -1.0, 0.0), Vec3::new(0.5, 0.0, 0.0)),
            (Vec3::new(-1.0, 0.5, 0.0), Vec3::new(0.0, 0.5, 0.0)),
            (Vec3::new(1.0, 1.0, 3.0), Vec3::new(0.5, 0.5, 0.0)),
        ];
        for (p, expected) in cases {
            assert!(closest_point_on_triangle(p, a, b, c).distance(expected) < 1e-6);
        }
        let collinear = closest_point_on_triangle(Vec3::new(3.0, 1.0, 0.0), a, b, Vec3::X * 2.0);
        assert!(collinear.distance(Vec3::X * 2.0) < 1e-6);
        assert_eq!(closest_point_on_triangle(Vec3::ONE, a, a, a), a);
    }

    #[test]
    fn barycentric_weights_rebuild_the_closest_point_and_name_its_feature() {
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        let probes = [
            Vec3::new(0.2, 0.3, 1.0),
            Vec3::new(-1.0, -1.0, 0.5),
            Vec3::new(0.5, -1.0, 0.0),
            Vec3::new(1.0, 1.0, -2.0),
            Vec3::new(-0.5, 2.0, 0.0),
        ];
        for p in probes {
            let closest = closest_on_triangle(p, a, b, c);
            let [u, v, w] = closest.weights;
            assert!((u + v + w - 1.0).abs() < 1e-6);
            assert!((a * u + b * v + c * w).distance(closest.point) < 1e-6);
        }
        assert_eq!(
            closest_on_triangle(probes[1], a, b, c).weights,
            [1.0, 0.0, 0.0]
        );
        assert_eq!(closest_on_triangle(probes[2], a, b, c).weights[2], 0.0);
        assert!(
            closest_on_triangle(probes[0], a, b, c)
                .weights
                .iter()
                .all(|&x| x > 0.0)
        );
    }
}
