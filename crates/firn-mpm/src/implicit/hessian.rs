//! The product of the elastic energy's Hessian H with a grid vector, never
//! assembled: per particle through its weight gradients ([`ForceKernel`]),
//! scattered through the block colouring so it is deterministic.

use firn_core::math::bspline::{StencilWeights, cubic_weights, quadratic_weights};
use glam::{Mat3, Mat3A, Vec3, Vec3A};
use rayon::prelude::*;

use crate::binning::Bins;
use crate::disjoint::scatter_by_colour;
use crate::grid::{PageTable, StencilIndex};

use super::StressDifferential;

/// The weight gradients ∇w_ip through which a transfer scheme's grid forces
/// act; the Hessian must use the same ones to be the derivative of the forces.
///
/// A solve computes each particle's weights and stencil nodes once
/// ([`ForceKernel::prepare`]) and keeps them for all its products with H.
pub trait ForceKernel: Copy + Send + Sync {
    /// What the kernel keeps per particle for one solve: its 1D weights and
    /// where its stencil's nodes lie in [`Grid::nodes`].
    type Prepared: Copy + Send + Sync;

    /// The per-particle data of a particle at `position`, its stencil found
    /// through `table`.
    fn prepare(self, table: PageTable<'_>, position: Vec3) -> Self::Prepared;

    /// Calls `visit(node, ∇w_ip)` for every node of the stencil of a
    /// particle, `node` an index into [`Grid::nodes`], on a grid of cell
    /// size `cell_size`.
    fn visit(self, prepared: &Self::Prepared, cell_size: f32, visit: impl FnMut(usize, Vec3));

    /// The solver's buffer of this kernel's per-particle data.
    fn buffer(buffers: &mut PreparedStencils) -> &mut Vec<Self::Prepared>;
}

/// One particle's 1D weights and stencil nodes, kept for a solve.
#[derive(Clone, Copy, Debug)]
pub struct PreparedStencil<const N: usize> {
    pub(super) weights: StencilWeights<N>,
    pub(super) index: StencilIndex,
}

impl<const N: usize> PreparedStencil<N> {
    /// The stencil of `weights` (computed at the particle) on `table`'s grid.
    #[inline(always)]
    pub(super) fn new(table: PageTable<'_>, weights: StencilWeights<N>) -> PreparedStencil<N> {
        PreparedStencil {
            weights,
            index: table.stencil(weights.base),
        }
    }
}

/// The per-particle stencils of the last solve, one buffer per kernel, kept
/// to reuse their allocations.
#[derive(Clone, Debug, Default)]
pub struct PreparedStencils {
    pub(super) cubic: Vec<PreparedStencil<4>>,
    pub(super) quadratic: Vec<PreparedStencil<3>>,
}

/// PIC/FLIP: the cubic B-spline gradients of eq. 39-40 over a 4³ stencil.
#[derive(Clone, Copy, Debug)]
pub struct CubicGradient;

impl ForceKernel for CubicGradient {
    type Prepared = PreparedStencil<4>;

    #[inline(always)]
    fn prepare(self, table: PageTable<'_>, position: Vec3) -> PreparedStencil<4> {
        PreparedStencil::new(table, cubic_weights(table.layout.to_grid(position)))
    }

    #[inline(always)]
    fn visit(
        self,
        prepared: &PreparedStencil<4>,
        cell_size: f32,
        mut visit: impl FnMut(usize, Vec3),
    ) {
        let inverse_h = 1.0 / cell_size;
        let weights = &prepared.weights;
        prepared.index.for_each_index::<4>(|i, j, k, node| {
            visit(node, weights.gradient(i, j, k) * inverse_h);
        });
    }

    fn buffer(buffers: &mut PreparedStencils) -> &mut Vec<PreparedStencil<4>> {
        &mut buffers.cubic
    }
}

/// APIC in the MLS form: ∇w_ip ≈ (4/h²) w_ip (x_i − x_p) over a 3³ quadratic
/// stencil, the gradient the APIC scatter's force term uses.
#[derive(Clone, Copy, Debug)]
pub struct MlsGradient;

impl ForceKernel for MlsGradient {
    type Prepared = PreparedStencil<3>;

    #[inline(always)]
    fn prepare(self, table: PageTable<'_>, position: Vec3) -> PreparedStencil<3> {
        PreparedStencil::new(table, quadratic_weights(table.layout.to_grid(position)))
    }

    #[inline(always)]
    fn visit(
        self,
        prepared: &PreparedStencil<3>,
        cell_size: f32,
        mut visit: impl FnMut(usize, Vec3),
    ) {
        // (4/h²) times the offset in world units (cells · h).
        let scale = 4.0 / cell_size;
        let weights = &prepared.weights;
        prepared.index.for_each_index::<3>(|i, j, k, node| {
            let gradient = weights.node_offset(i, j, k) * (weights.weight(i, j, k) * scale);
            visit(node, gradient);
        });
    }

    fn buffer(buffers: &mut PreparedStencils) -> &mut Vec<PreparedStencil<3>> {
        &mut buffers.quadratic
    }
}

/// One particle's stencil as indices into the grid's node pool (which the
/// solver's node vectors share), with its gradients: scratch space that a
/// product refills for each particle.
pub(super) struct Stencil {
    pub(super) len: usize,
    pub(super) nodes: [u32; 64],
    pub(super) gradients: [Vec3; 64],
}

impl Stencil {
    pub(super) fn empty() -> Stencil {
        Stencil {
            len: 0,
            nodes: [0; 64],
            gradients: [Vec3::ZERO; 64],
        }
    }

    /// Overwrites the stencil with that of a prepared particle.
    #[inline(always)]
    pub(super) fn fill<K: ForceKernel>(
        &mut self,
        kernel: K,
        prepared: &K::Prepared,
        cell_size: f32,
    ) {
        self.len = 0;
        kernel.visit(prepared, cell_size, |node, gradient| {
            self.nodes[self.len] = node as u32;
            self.gradients[self.len] = gradient;
            self.len += 1;
        });
    }

    /// Σ_i v_i (∇w_ip)ᵀ for node vector `velocities` (eq. 32's sum), with
    /// SIMD columns.
    #[inline(always)]
    pub(super) fn velocity_gradient(&self, velocities: &[Vec3A]) -> Mat3 {
        let mut columns = [Vec3A::ZERO; 3];
        for (node, gradient) in self.iter() {
            let velocity = velocities[node];
            columns[0] += velocity * gradient.x;
            columns[1] += velocity * gradient.y;
            columns[2] += velocity * gradient.z;
        }
        Mat3::from_cols(columns[0].into(), columns[1].into(), columns[2].into())
    }

    #[inline(always)]
    pub(super) fn iter(&self) -> impl Iterator<Item = (usize, Vec3)> + '_ {
        self.nodes[..self.len]
            .iter()
            .zip(&self.gradients[..self.len])
            .map(|(&node, &gradient)| (node as usize, gradient))
    }
}

/// Everything the matrix-free product with β Δt² H needs.
pub(super) struct HessianOperator<'a, K: ForceKernel> {
    pub(super) kernel: K,
    pub(super) cell_size: f32,
    pub(super) bins: &'a Bins,
    pub(super) stencils: &'a [K::Prepared],
    pub(super) linearized: &'a [StressDifferential],
    /// β Δt².
    pub(super) scale: f32,
}

impl<K: ForceKernel> HessianOperator<'_, K> {
    /// output = β Δt² H input, over node vectors: per particle,
    /// δF_E = β Δt² (Σ_i input_i (∇w_ip)ᵀ) F_E, then output_i += A_p F_Eᵀ ∇w_ip
    /// with A_p = V_p^0 δP(δF_E).
    pub(super) fn apply(&self, input: &[Vec3A], output: &mut [Vec3A]) {
        output
            .par_iter_mut()
            .with_min_len(4096)
            .for_each(|o| *o = Vec3A::ZERO);
        scatter_by_colour(output, self.bins, |block, writer| {
            let mut stencil = Stencil::empty();
            for &p in block {
                let p = p as usize;
                stencil.fill(self.kernel, &self.stencils[p], self.cell_size);
                let linearized = &self.linearized[p];
                let elastic = linearized.elastic();
                let delta = stencil.velocity_gradient(input) * elastic * self.scale;
                let stress = Mat3A::from(linearized.apply(delta) * elastic.transpose());
                for (node, gradient) in stencil.iter() {
                    let force = stress * Vec3A::from(gradient);
                    writer.update(node, |o| *o += force);
                }
            }
        });
    }
}
