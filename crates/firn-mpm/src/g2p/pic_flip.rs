//! PIC/FLIP's read of the grid (step 8 with cubic B-splines): the blend
//! v_p = (1 − α) v_PIC + α v_FLIP and ∇v_p, one particle or two at once.

use firn_core::math::bspline::cubic_weights;
use firn_core::math::isa::{Isa, PairLanes, PortablePairs};
use glam::{Mat3, Vec3};

use super::Interpolation;
use crate::grid::{Grid, Node};
use crate::local_nodes::{CUBIC_SPAN, LocalNodes, at};

/// The PIC/FLIP blend with cubic B-splines, read from [`LocalNodes`].
pub(super) struct PicFlipInterpolation<'a> {
    pub(super) grid: &'a Grid,
    /// FLIP share α.
    pub(super) flip: f32,
}

impl Interpolation for PicFlipInterpolation<'_> {
    type LocalNode = Node;

    #[inline(always)]
    fn grid(&self) -> &Grid {
        self.grid
    }

    #[inline(always)]
    fn local_node(node: &Node) -> Node {
        *node
    }

    #[inline(always)]
    fn interpolate(
        &self,
        local: &LocalNodes<Node>,
        position: Vec3,
        velocity: Vec3,
    ) -> (Vec3, Mat3) {
        self.blend(PortablePairs, local, position, velocity)
    }

    #[inline(always)]
    fn interpolate_pair(
        &self,
        local: &LocalNodes<Node>,
        isa: Isa,
        particles: [(Vec3, Vec3); 2],
    ) -> [(Vec3, Mat3); 2] {
        let [(position_a, velocity_a), (position_b, velocity_b)] = particles;
        match isa.avx2() {
            #[cfg(target_arch = "x86_64")]
            Some(avx2) => [
                self.blend(avx2, local, position_a, velocity_a),
                self.blend(avx2, local, position_b, velocity_b),
            ],
            _ => [
                self.blend(PortablePairs, local, position_a, velocity_a),
                self.blend(PortablePairs, local, position_b, velocity_b),
            ],
        }
    }
}

impl PicFlipInterpolation<'_> {
    /// v_p = (1 − α) v_PIC + α (v_p + Δv_FLIP) (step 8) and ∇v_p (step 7)
    /// of a particle at `position` with the old `velocity`, from its
    /// stencil sums ([`PicFlipSums`]) in `lanes`.
    #[inline(always)]
    fn blend<P: PairLanes>(
        &self,
        lanes: P,
        local: &LocalNodes<Node>,
        position: Vec3,
        velocity: Vec3,
    ) -> (Vec3, Mat3) {
        let sums = PicFlipSums::of(lanes, local, self.grid, position);
        let flip = self.flip;
        let [old, new] = lanes.halves(sums.velocities);
        let pic = new.truncate();
        let change = (new - old).truncate();
        // The slopes are per cell: ∇w_ip is theirs over h.
        let inverse_h = 1.0 / self.grid.layout.cell_size;
        let column = |sums: P::Pair| (lanes.halves(sums)[1] * inverse_h).truncate();
        let gradient = Mat3::from_cols(
            column(sums.gradient[0]),
            column(sums.gradient[1]),
            column(sums.gradient[2]),
        );
        (pic * (1.0 - flip) + (velocity + change) * flip, gradient)
    }
}

/// One particle's sums over its 4x4x4 stencil (eq. 41 and the PIC/FLIP
/// blend), each over both node vectors (v_i, v_i^{n+1}) at once, as a
/// pair ([`Node::pair`]): Σ w_ip (v_i, v_i^{n+1}), whose halves give
/// v_PIC = Σ w_ip v_i^{n+1} and Δv_FLIP = Σ w_ip v_i^{n+1} − Σ w_ip v_i,
/// and per axis a the sums Σ (h ∂w_ip/∂x_a) (·, v_i^{n+1}), whose high
/// halves over h are the columns of ∇v_p = Σ v_i^{n+1} (∇w_ip)ᵀ. The
/// fourth lanes of each half carry nothing that is read.
pub(super) struct PicFlipSums<P: PairLanes> {
    velocities: P::Pair,
    gradient: [P::Pair; 3],
}

impl<P: PairLanes> PicFlipSums<P> {
    /// The sums of a particle at `position`, from the nodes around its
    /// block, by the tensor product of the weights w_ijk = w_i^x w_j^y w_k^z:
    /// along z per stencil row, the rows along y per slab, the slabs along
    /// x (the slopes take a weight's place on their axis). Every instruction
    /// set does these lane-wise operations in this order, so the same bits.
    #[inline(always)]
    fn of(lanes: P, local: &LocalNodes<Node>, grid: &Grid, position: Vec3) -> PicFlipSums<P> {
        let weights = cubic_weights(grid.layout.to_grid(position));
        let window = local.window::<4, CUBIC_SPAN>(weights.base);
        let ((wx, sx), (wy, sy), (wz, sz)) = (weights.along(0), weights.along(1), weights.along(2));
        let zero = lanes.splat(0.0);
        // Per slab i: Σ_jk w_j w_k, Σ_jk s_j w_k and Σ_jk w_j s_k of its nodes.
        let mut slabs = [zero; 4];
        let mut slabs_y = [zero; 4];
        let mut slabs_z = [zero; 4];
        for i in 0..4 {
            let mut rows = [zero; 4];
            let mut rows_z = [zero; 4];
            for j in 0..4 {
                let mut nodes = [zero; 4];
                for (k, node) in nodes.iter_mut().enumerate() {
                    *node = window[at(i, j, k)].pair(lanes);
                }
                rows[j] = weighted_sum(lanes, &nodes, &wz);
                rows_z[j] = weighted_sum(lanes, &nodes, &sz);
            }
            slabs[i] = weighted_sum(lanes, &rows, &wy);
            slabs_y[i] = weighted_sum(lanes, &rows, &sy);
            slabs_z[i] = weighted_sum(lanes, &rows_z, &wy);
        }
        PicFlipSums {
            velocities: weighted_sum(lanes, &slabs, &wx),
            gradient: [
                weighted_sum(lanes, &slabs, &sx),
                weighted_sum(lanes, &slabs_y, &wx),
                weighted_sum(lanes, &slabs_z, &wx),
            ],
        }
    }
}

/// Σ_n weights[n] terms[n], added in order n = 0, 1, 2, 3.
#[inline(always)]
fn weighted_sum<P: PairLanes>(lanes: P, terms: &[P::Pair; 4], weights: &[f32; 4]) -> P::Pair {
    let mut sum = terms[0] * lanes.splat(weights[0]);
    for n in 1..4 {
        sum = sum + terms[n] * lanes.splat(weights[n]);
    }
    sum
}
