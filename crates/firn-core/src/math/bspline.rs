//! B-spline interpolation kernels of the Material Point Method.
//!
//! A particle at grid coordinate `X = (x − origin) / h` interacts with the
//! nodes of a small stencil; the weight of node `i` is the dyadic product
//! `w_i = N(X_x − i_x) N(X_y − i_y) N(X_z − i_z)` (thesis eq. 37-38) and its
//! gradient is the product rule applied per axis (eq. 39-40).

use glam::{IVec3, Vec3, Vec3A};

use crate::math::lanes::F32s;

/// The 1D cubic B-spline N(x) of the thesis (eq. 37), support |x| < 2.
pub fn cubic(x: f32) -> f32 {
    let a = x.abs();
    if a < 1.0 {
        0.5 * a * a * a - a * a + 2.0 / 3.0
    } else if a < 2.0 {
        let b = 2.0 - a;
        b * b * b / 6.0
    } else {
        0.0
    }
}

/// Derivative N'(x) of the cubic B-spline (eq. 39).
pub fn cubic_derivative(x: f32) -> f32 {
    let a = x.abs();
    let slope = if a < 1.0 {
        1.5 * a * a - 2.0 * a
    } else if a < 2.0 {
        let b = 2.0 - a;
        -0.5 * b * b
    } else {
        0.0
    };
    slope * x.signum()
}

/// The 1D quadratic B-spline, support |x| < 1.5 (used with APIC).
pub fn quadratic(x: f32) -> f32 {
    let a = x.abs();
    if a < 0.5 {
        0.75 - a * a
    } else if a < 1.5 {
        let b = 1.5 - a;
        0.5 * b * b
    } else {
        0.0
    }
}

/// Derivative of the quadratic B-spline.
pub fn quadratic_derivative(x: f32) -> f32 {
    let a = x.abs();
    let slope = if a < 0.5 {
        -2.0 * a
    } else if a < 1.5 {
        a - 1.5
    } else {
        0.0
    };
    slope * x.signum()
}

/// Per-axis weights of one particle over an `N`-node-wide stencil.
///
/// `values[k]` holds, per axis, the 1D weight of the node `base + k` along that
/// axis; `slopes[k]` its derivative with respect to the grid coordinate (divide
/// by h for a spatial gradient).
#[derive(Clone, Copy, Debug)]
pub struct StencilWeights<const N: usize> {
    /// Grid index of the stencil's first node on each axis.
    pub base: IVec3,
    /// Offset of the particle from the base node, in cells.
    pub offset: Vec3,
    /// 1D weights per stencil node and axis.
    pub values: [Vec3; N],
    /// 1D weight derivatives per stencil node and axis (per cell).
    pub slopes: [Vec3; N],
}

impl<const N: usize> StencilWeights<N> {
    /// Weight w_ip of stencil node (i, j, k).
    #[inline(always)]
    pub fn weight(&self, i: usize, j: usize, k: usize) -> f32 {
        self.values[i].x * self.values[j].y * self.values[k].z
    }

    /// Gradient ∇w_ip of stencil node (i, j, k) per cell (eq. 40); divide by h.
    #[inline(always)]
    pub fn gradient(&self, i: usize, j: usize, k: usize) -> Vec3 {
        let (wx, wy, wz) = (self.values[i].x, self.values[j].y, self.values[k].z);
        Vec3::new(
            self.slopes[i].x * wy * wz,
            wx * self.slopes[j].y * wz,
            wx * wy * self.slopes[k].z,
        )
    }

    /// The 1D weights and slopes of the stencil's nodes along `axis` (0, 1
    /// or 2 for x, y, z), for sums that take the weights' tensor product
    /// axis by axis.
    #[inline(always)]
    pub fn along(&self, axis: usize) -> ([f32; N], [f32; N]) {
        let mut values = [0.0; N];
        let mut slopes = [0.0; N];
        for n in 0..N {
            values[n] = self.values[n][axis];
            slopes[n] = self.slopes[n][axis];
        }
        (values, slopes)
    }

    /// Vector from the particle to stencil node (i, j, k), in cells.
    #[inline(always)]
    pub fn node_offset(&self, i: usize, j: usize, k: usize) -> Vec3 {
        Vec3::new(i as f32, j as f32, k as f32) - self.offset
    }
}

/// ⌊x⌋ per component, as a number and as a grid index, without a libm call
/// (plain x86-64 lacks SSE4.1's rounding instruction): truncate, then step
/// down where truncation rounded up. Exact for |x| < 2³¹, far beyond any grid.
#[inline(always)]
pub fn floor(x: Vec3) -> (Vec3, IVec3) {
    let (below, index) = floor_lanes(Vec3A::from(x));
    (below.into(), index)
}

/// [`floor`] on the three lanes of one SSE register: one truncating
/// conversion for all three axes (`cvttps2dq` on x86-64, where Rust's
/// saturating `as i32` takes several instructions per lane), the same bits.
#[inline(always)]
fn floor_lanes(x: Vec3A) -> (Vec3A, IVec3) {
    #[cfg(target_arch = "x86_64")]
    {
        crate::math::isa::floor_sse2(x)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let floor = |v: f32| {
            let truncated = v as i32;
            if truncated as f32 > v {
                truncated - 1
            } else {
                truncated
            }
        };
        let index = IVec3::new(floor(x.x), floor(x.y), floor(x.z));
        (index.as_vec3a(), index)
    }
}

/// Cubic B-spline weights over the 4x4x4 stencil of a particle at grid
/// coordinate `x` (nodes ⌊x⌋−1 … ⌊x⌋+2 per axis).
#[inline(always)]
pub fn cubic_weights(x: Vec3) -> StencilWeights<4> {
    let (cell, cell_index) = floor(x);
    let base_node = cell - Vec3::ONE;
    let offset = x - base_node;
    let mut values = [Vec3::ZERO; 4];
    let mut slopes = [Vec3::ZERO; 4];
    for (k, (value, slope)) in values.iter_mut().zip(slopes.iter_mut()).enumerate() {
        let d = offset - Vec3::splat(k as f32);
        *value = Vec3::new(cubic(d.x), cubic(d.y), cubic(d.z));
        // d = x − x_i; dN(x − x_i)/dx = N'(d).
        *slope = Vec3::new(
            cubic_derivative(d.x),
            cubic_derivative(d.y),
            cubic_derivative(d.z),
        );
    }
    StencilWeights {
        base: cell_index - IVec3::ONE,
        offset,
        values,
        slopes,
    }
}

/// Quadratic B-spline weights over the 3x3x3 stencil of a particle at grid
/// coordinate `x` (nodes ⌊x − ½⌋ … ⌊x − ½⌋+2 per axis).
#[inline(always)]
pub fn quadratic_weights(x: Vec3) -> StencilWeights<3> {
    let (base_node, base) = floor(x - Vec3::splat(0.5));
    let offset = x - base_node;
    let mut values = [Vec3::ZERO; 3];
    let mut slopes = [Vec3::ZERO; 3];
    for (k, (value, slope)) in values.iter_mut().zip(slopes.iter_mut()).enumerate() {
        let d = offset - Vec3::splat(k as f32);
        *value = Vec3::new(quadratic(d.x), quadratic(d.y), quadratic(d.z));
        *slope = Vec3::new(
            quadratic_derivative(d.x),
            quadratic_derivative(d.y),
            quadratic_derivative(d.z),
        );
    }
    StencilWeights {
        base,
        offset,
        values,
        slopes,
    }
}

/// Per-axis weights of one particle over its stencil, without derivatives
/// (APIC needs none): see [`StencilWeights`].
#[derive(Clone, Copy, Debug)]
pub struct StencilValues<const N: usize> {
    /// Grid index of the stencil's first node on each axis.
    pub base: IVec3,
    /// Offset of the particle from the base node, in cells.
    pub offset: Vec3,
    /// 1D weights per stencil node and axis.
    pub values: [Vec3; N],
}

/// [`quadratic_weights`]' values alone, without branches: the offset from
/// the base node lies in [½, 3/2], so each node's piece of the spline is
/// known, and each is evaluated with the same operations as [`quadratic`],
/// giving the same bits.
#[inline(always)]
pub fn quadratic_values(x: Vec3) -> StencilValues<3> {
    // In the lanes of one SSE register: the same operations per axis as
    // three scalar ones, so the same bits, in a third of the instructions.
    let x = Vec3A::from(x);
    let (base_node, base) = floor_lanes(x - Vec3A::splat(0.5));
    let offset = x - base_node;
    let half = Vec3A::splat(0.5);
    let three_halves = Vec3A::splat(1.5);
    let near = three_halves - offset;
    let middle = offset - Vec3A::ONE;
    let far = three_halves - (offset - Vec3A::splat(2.0)).abs();
    StencilValues {
        base,
        offset: offset.into(),
        values: [
            (half * near * near).into(),
            (Vec3A::splat(0.75) - middle * middle).into(),
            (half * far * far).into(),
        ],
    }
}

/// [`quadratic_values`] along one axis for `N` particles at once, from
/// their positions in cells: the same operations lane by lane, so the same
/// bits (the stencil's first node comes as an exact float).
#[derive(Clone, Copy, Debug)]
pub struct QuadraticLanes<const N: usize> {
    /// The stencil's first node ⌊x − ½⌋ per lane.
    pub first_node: F32s<N>,
    /// x minus the first node, in [½, 3/2).
    pub offset: F32s<N>,
    /// The weights of the stencil's three nodes.
    pub values: [F32s<N>; 3],
}

impl<const N: usize> QuadraticLanes<N> {
    /// The weights at positions `x` (in cells).
    #[inline(always)]
    pub fn at(x: F32s<N>) -> QuadraticLanes<N> {
        let splat = F32s::<N>::splat;
        let first_node = (x - splat(0.5)).floor();
        let offset = x - first_node;
        let near = splat(1.5) - offset;
        let middle = offset - splat(1.0);
        let far = splat(1.5) - (offset - splat(2.0)).abs();
        QuadraticLanes {
            first_node,
            offset,
            values: [
                splat(0.5) * near * near,
                splat(0.75) - middle * middle,
                splat(0.5) * far * far,
            ],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check_partition<const N: usize>(weights: StencilWeights<N>) {
        let mut sum = 0.0f64;
        let mut gradient_sum = [0.0f64; 3];
        let mut first_moment = [0.0f64; 3];
        for i in 0..N {
            for j in 0..N {
                for k in 0..N {
                    let w = weights.weight(i, j, k) as f64;
                    sum += w;
                    let g = weights.gradient(i, j, k);
                    let d = weights.node_offset(i, j, k);
                    for axis in 0..3 {
                        gradient_sum[axis] += g[axis] as f64;
                        first_moment[axis] += w * d[axis] as f64;
                    }
                }
            }
        }
        assert!((sum - 1.0).abs() < 1e-5, "weights sum to {sum}");
        for axis in 0..3 {
            assert!(
                gradient_sum[axis].abs() < 1e-5,
                "gradients sum to {gradient_sum:?}"
            );
            // Linear precision: Σ w_i (x_i − x_p) = 0.
            assert!(
                first_moment[axis].abs() < 1e-5,
                "first moment {first_moment:?}"
            );
        }
    }

    /// The pieces' edges: offsets of exactly ½ and just below 3/2.
    #[test]
    fn quadratic_values_match_at_the_pieces_edges() {
        for k in 0..800 {
            let x = k as f32 * 0.25;
            for v in [
                x,
                f32::from_bits(x.to_bits() + 1),
                f32::from_bits(x.to_bits().max(1) - 1),
            ] {
                let v = Vec3::splat(v);
                let (fast, full) = (quadratic_values(v), quadratic_weights(v));
                assert_eq!(fast.base, full.base, "{v}");
                for k in 0..3 {
                    assert_eq!(
                        fast.values[k].to_array().map(f32::to_bits),
                        full.values[k].to_array().map(f32::to_bits),
                        "node {k} at {v}"
                    );
                }
            }
        }
    }

    proptest! {
        #[test]
        fn cubic_is_a_partition_of_unity(x in 0.0f32..50.0, y in 0.0f32..50.0, z in 0.0f32..50.0) {
            check_partition(cubic_weights(Vec3::new(x, y, z)));
        }

        #[test]
        fn quadratic_is_a_partition_of_unity(x in 0.0f32..50.0, y in 0.0f32..50.0, z in 0.0f32..50.0) {
            check_partition(quadratic_weights(Vec3::new(x, y, z)));
        }

        #[test]
        fn quadratic_values_are_the_quadratic_weights_bits(x in -10.0f32..1100.0, y in 0.0f32..3.0, z in 0.0f32..1e5) {
            let v = Vec3::new(x, y, z);
            let (fast, full) = (quadratic_values(v), quadratic_weights(v));
            prop_assert_eq!(fast.base, full.base);
            prop_assert_eq!(fast.offset, full.offset);
            for k in 0..3 {
                prop_assert_eq!(fast.values[k].to_array().map(f32::to_bits), full.values[k].to_array().map(f32::to_bits), "node {}", k);
            }
        }

        #[test]
        fn quadratic_lanes_are_the_quadratic_values_bits(x in proptest::array::uniform8(-10.0f32..1100.0)) {
            let lanes = QuadraticLanes::at(F32s(x));
            for (lane, &x) in x.iter().enumerate() {
                let one = quadratic_values(Vec3::splat(x));
                prop_assert_eq!(lanes.first_node.0[lane] as i32, one.base.x);
                prop_assert_eq!(lanes.offset.0[lane].to_bits(), one.offset.x.to_bits());
                for k in 0..3 {
                    prop_assert_eq!(lanes.values[k].0[lane].to_bits(), one.values[k].x.to_bits(), "node {}", k);
                }
            }
        }

        #[test]
        fn floor_matches_the_library_floor(x in -1e6f32..1e6, y in -3.0f32..3.0, z in -1.0f32..1.0) {
            let v = Vec3::new(x, y, z);
            prop_assert_eq!(floor(v), (v.floor(), v.floor().as_ivec3()));
        }

        #[test]
        fn derivatives_match_finite_differences(x in -2.5f32..2.5) {
            let h = 1e-3;
            let fd_cubic = (cubic(x + h) - cubic(x - h)) / (2.0 * h);
            prop_assert!((fd_cubic - cubic_derivative(x)).abs() < 2e-3);
            let fd_quadratic = (quadratic(x + h) - quadratic(x - h)) / (2.0 * h);
            // The quadratic spline's derivative jumps at |x| = 0.5 only in its second derivative.
            prop_assert!((fd_quadratic - quadratic_derivative(x)).abs() < 2e-3);
        }
    }

    #[test]
    fn cubic_matches_the_thesis_values() {
        assert!((cubic(0.0) - 2.0 / 3.0).abs() < 1e-7);
        assert!((cubic(1.0) - 1.0 / 6.0).abs() < 1e-7);
        assert_eq!(cubic(2.0), 0.0);
        assert_eq!(cubic(-3.0), 0.0);
        assert!((cubic_derivative(1.0) + 0.5).abs() < 1e-7);
    }

    #[test]
    fn stencils_cover_the_support() {
        let w = cubic_weights(Vec3::new(5.3, 7.0, 0.99));
        assert_eq!(w.base, IVec3::new(4, 6, -1));
        let q = quadratic_weights(Vec3::new(5.3, 7.0, 0.49));
        assert_eq!(q.base, IVec3::new(4, 6, -1));
        for x in [-2.0, -1.5, -0.0, 0.0, 3.0, 1e-8, -1e-8] {
            let expected = Vec3::splat(x).floor();
            assert_eq!(
                floor(Vec3::splat(x)),
                (expected, expected.as_ivec3()),
                "{x}"
            );
        }
    }
}
