//! APIC's read of the grid (step 8 with quadratic B-splines): v_p and
//! C_p = (4/h²) Σ w_ip v_i (x_i − x_p)ᵀ from sums over the stencil's slabs,
//! rows and columns, one particle or two at once.

use firn_core::math::bspline::{StencilValues, quadratic_values};
#[cfg(target_arch = "x86_64")]
use firn_core::math::isa::Vec4Pair;
use firn_core::math::isa::{Avx2, Isa};
use glam::{Mat3, Vec3, Vec4};

use super::Interpolation;
use crate::grid::{Grid, Node};
use crate::local_nodes::{LocalNodes, QUADRATIC_SPAN, at};

/// APIC with quadratic B-splines, read from [`LocalNodes`].
pub(super) struct ApicInterpolation<'a> {
    pub(super) grid: &'a Grid,
}

impl Interpolation for ApicInterpolation<'_> {
    type LocalNode = Vec4;

    #[inline(always)]
    fn grid(&self) -> &Grid {
        self.grid
    }

    #[inline(always)]
    fn local_node(node: &Node) -> Vec4 {
        node.velocity_new
    }

    #[inline(always)]
    fn interpolate(&self, local: &LocalNodes<Vec4>, position: Vec3, _: Vec3) -> (Vec3, Mat3) {
        let weights = quadratic_values(self.grid.layout.to_grid(position));
        let sums = StencilSums::of(local, &weights);
        sums.velocity_and_affine(weights.offset, self.inverse_inertia_h())
    }

    #[inline(always)]
    fn interpolate_pair(
        &self,
        local: &LocalNodes<Vec4>,
        isa: Isa,
        particles: [(Vec3, Vec3); 2],
    ) -> [(Vec3, Mat3); 2] {
        // Arrays spelled out, not `map`ped: `array::map` can be compiled as
        // a function of its own, outside the caller's instruction set.
        let weights_at =
            |(position, _): (Vec3, Vec3)| quadratic_values(self.grid.layout.to_grid(position));
        let weights = [weights_at(particles[0]), weights_at(particles[1])];
        let sums = match isa.avx2() {
            #[cfg(target_arch = "x86_64")]
            Some(avx2) => StencilSums::of_pair(avx2, local, [&weights[0], &weights[1]]),
            _ => [
                StencilSums::of(local, &weights[0]),
                StencilSums::of(local, &weights[1]),
            ],
        };
        let result =
            |n: usize| sums[n].velocity_and_affine(weights[n].offset, self.inverse_inertia_h());
        [result(0), result(1)]
    }
}

impl ApicInterpolation<'_> {
    /// 4/h: C_p = (4/h²) Σ w_ip v_i (x_i − x_p)ᵀ from the moment in cells
    /// (the offset in world units is cells · h).
    #[inline(always)]
    fn inverse_inertia_h(&self) -> f32 {
        4.0 / self.grid.layout.cell_size
    }
}

/// Weighted velocities w_ip v_i summed per x-slab, y-row and z-column of a
/// particle's 3x3x3 stencil: their totals give v_p, their first moments
/// C_p ([`StencilSums::velocity_and_affine`]).
#[derive(Clone, Copy)]
pub(super) struct StencilSums {
    slabs: [Vec4; 3],
    rows: [Vec4; 3],
    columns: [Vec4; 3],
}

impl StencilSums {
    /// The sums of one particle with stencil `weights`, from the nodes
    /// around its block.
    #[inline(always)]
    fn of(local: &LocalNodes<Vec4>, weights: &StencilValues<3>) -> StencilSums {
        let window = local.window::<3, QUADRATIC_SPAN>(weights.base);
        let mut sums = StencilSums {
            slabs: [Vec4::ZERO; 3],
            rows: [Vec4::ZERO; 3],
            columns: [Vec4::ZERO; 3],
        };
        for (i, slab) in sums.slabs.iter_mut().enumerate() {
            for (j, row) in sums.rows.iter_mut().enumerate() {
                let wxy = weights.values[i].x * weights.values[j].y;
                for (k, column) in sums.columns.iter_mut().enumerate() {
                    let weighted = window[at(i, j, k)] * (wxy * weights.values[k].z);
                    *slab += weighted;
                    *row += weighted;
                    *column += weighted;
                }
            }
        }
        sums
    }

    /// [`StencilSums::of`] for two particles at once, one per 128-bit half
    /// of each 256-bit register: lane by lane the same operations, so the
    /// same bits.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn of_pair(
        avx2: Avx2,
        local: &LocalNodes<Vec4>,
        weights: [&StencilValues<3>; 2],
    ) -> [StencilSums; 2] {
        let [a, b] = weights;
        let splats = |x: f32, y: f32| avx2.pair(Vec4::splat(x), Vec4::splat(y));
        // No `array::map` here: it can be compiled as a function of its own,
        // without AVX2.
        let windows = [
            local.window::<3, QUADRATIC_SPAN>(a.base),
            local.window::<3, QUADRATIC_SPAN>(b.base),
        ];
        let z_weight = |k: usize| splats(a.values[k].z, b.values[k].z);
        let z_weights = [z_weight(0), z_weight(1), z_weight(2)];
        let mut slabs = [avx2.zero_pair(); 3];
        let mut rows = [avx2.zero_pair(); 3];
        let mut columns = [avx2.zero_pair(); 3];
        for (i, slab) in slabs.iter_mut().enumerate() {
            for (j, row) in rows.iter_mut().enumerate() {
                let wxy = splats(a.values[i].x * a.values[j].y, b.values[i].x * b.values[j].y);
                for (k, column) in columns.iter_mut().enumerate() {
                    let nodes = avx2.pair(windows[0][at(i, j, k)], windows[1][at(i, j, k)]);
                    let weighted = nodes * (wxy * z_weights[k]);
                    *slab = *slab + weighted;
                    *row = *row + weighted;
                    *column = *column + weighted;
                }
            }
        }
        let halves = |pairs: [Vec4Pair; 3]| {
            let [p0, p1, p2] = [pairs[0].halves(), pairs[1].halves(), pairs[2].halves()];
            [[p0[0], p1[0], p2[0]], [p0[1], p1[1], p2[1]]]
        };
        let ([slabs_a, slabs_b], [rows_a, rows_b], [columns_a, columns_b]) =
            (halves(slabs), halves(rows), halves(columns));
        [
            StencilSums {
                slabs: slabs_a,
                rows: rows_a,
                columns: columns_a,
            },
            StencilSums {
                slabs: slabs_b,
                rows: rows_b,
                columns: columns_b,
            },
        ]
    }

    /// v_p = Σ w_ip v_i and `scale` Σ w_ip v_i (x_i − x_p)ᵀ in cells, for a
    /// particle `offset` cells from its stencil's first node.
    #[inline(always)]
    fn velocity_and_affine(&self, offset: Vec3, scale: f32) -> (Vec3, Mat3) {
        let slabs = self.slabs;
        let velocity = slabs[0] + slabs[1] + slabs[2];
        // Σ w v (n − offset) along one axis, from the sums at n = 0, 1, 2,
        // scaled in the SIMD lanes (the bits of glam's `Mat3 * f32`).
        let moment = |sums: [Vec4; 3], offset: f32| {
            ((sums[1] + sums[2] * 2.0 - velocity * offset) * scale).truncate()
        };
        let affine = Mat3::from_cols(
            moment(self.slabs, offset.x),
            moment(self.rows, offset.y),
            moment(self.columns, offset.z),
        );
        (velocity.truncate(), affine)
    }
}
