//! The solve's per-node data and Krylov vectors, and the vector operations
//! of the conjugate residuals on them (dot products summed in f64, block
//! by block in a fixed order).

use glam::Vec3A;
use rayon::prelude::*;

use crate::contact::{Constraint, PlacedCollider, collide_all_constrained};
use crate::grid::{BLOCK_NODES, Grid, GridLayout};

/// Per-node data and Krylov vectors of the solve, numbered like the grid's
/// node pool. The vectors are `Vec3A`, so the product loads and adds a node
/// in one SIMD operation (the same IEEE operations as on `Vec3`).
#[derive(Clone, Debug, Default)]
pub(super) struct NodeVectors {
    pub(super) mass: Vec<f32>,
    /// 1 / m_i, the preconditioner (0 for nodes without mass).
    pub(super) inverse_mass: Vec<f32>,
    pub(super) constraint: Vec<Constraint>,
    /// The iterate, v^{n+1} at the end.
    pub(super) x: Vec<Vec3A>,
    /// Residual P (M v* − S x), S = M + β Δt² H.
    pub(super) r: Vec<Vec3A>,
    /// Preconditioned residual P M⁻¹ r.
    pub(super) z: Vec<Vec3A>,
    /// Search direction.
    pub(super) p: Vec<Vec3A>,
    /// S p.
    pub(super) sp: Vec<Vec3A>,
    /// Operator output scratch: β Δt² H y, then S y.
    pub(super) product: Vec<Vec3A>,
}

/// Splits a node vector into blocks for the parallel passes.
pub(super) fn blocks<T: Sync>(values: &[T]) -> rayon::slice::Chunks<'_, T> {
    values.par_chunks(BLOCK_NODES)
}

/// Splits a node vector into mutable blocks for the parallel passes.
pub(super) fn blocks_mut<T: Send>(values: &mut [T]) -> rayon::slice::ChunksMut<'_, T> {
    values.par_chunks_mut(BLOCK_NODES)
}

/// Sums per-block partial sums in block order: the same bits for any thread count.
pub(super) fn ordered_sum(partials: Vec<f64>) -> f64 {
    partials.iter().sum()
}

impl NodeVectors {
    /// Sizes every vector for `len` nodes and zeroes it.
    pub(super) fn reset(&mut self, len: usize) {
        fn zeroed<T: Clone + Default>(values: &mut Vec<T>, len: usize) {
            values.clear();
            values.resize(len, T::default());
        }
        zeroed(&mut self.mass, len);
        zeroed(&mut self.inverse_mass, len);
        zeroed(&mut self.constraint, len);
        for vector in [
            &mut self.x,
            &mut self.r,
            &mut self.z,
            &mut self.p,
            &mut self.sp,
            &mut self.product,
        ] {
            zeroed(vector, len);
        }
    }

    /// Reads m_i and v_i* from the grid, applies the collisions (step 5) while
    /// recording which components they fix, and returns ‖M v*‖²_{M⁻¹} =
    /// Σ m_i |v_i*|², a reference for the relative residual.
    pub(super) fn load(&mut self, grid: &Grid, colliders: &[PlacedCollider]) -> f64 {
        let layout = grid.layout;
        let partials = (
            blocks_mut(&mut self.mass),
            blocks_mut(&mut self.inverse_mass),
            blocks_mut(&mut self.constraint),
            blocks_mut(&mut self.x),
            blocks(&grid.nodes),
            grid.resident_blocks().par_iter(),
        )
            .into_par_iter()
            .map(|(mass, inverse_mass, constraint, x, nodes, &block)| {
                let coord = layout.block_coord(block as usize);
                let mut sum = 0.0;
                for (local, node) in nodes.iter().enumerate() {
                    mass[local] = node.mass();
                    if node.mass() <= 0.0 {
                        constraint[local] = Constraint::Fixed;
                        continue;
                    }
                    inverse_mass[local] = 1.0 / node.mass();
                    let position = layout.node_position(GridLayout::node_in_block(coord, local));
                    let (velocity, fixed) =
                        collide_all_constrained(colliders, position, node.velocity_new());
                    x[local] = velocity.into();
                    constraint[local] = fixed;
                    sum += f64::from(node.mass() * velocity.length_squared());
                }
                sum
            })
            .collect();
        ordered_sum(partials)
    }

    /// From `product` = β Δt² H x at x = v*: r = P (M v* − S v*) = −P product,
    /// z = P M⁻¹ r; returns r · z = ‖r‖²_{M⁻¹}.
    pub(super) fn initial_residual(&mut self) -> f64 {
        let partials = (
            blocks_mut(&mut self.r),
            blocks_mut(&mut self.z),
            blocks(&self.product),
            blocks(&self.constraint),
            blocks(&self.inverse_mass),
        )
            .into_par_iter()
            .map(|(r, z, product, constraint, inverse_mass)| {
                let mut sum = 0.0;
                for i in 0..r.len() {
                    r[i] = (-constraint[i].project(product[i].into())).into();
                    z[i] = r[i] * inverse_mass[i];
                    sum += r[i].dot(z[i]) as f64;
                }
                sum
            })
            .collect();
        ordered_sum(partials)
    }

    /// Completes `product` = β Δt² H z into S z = P (M z + β Δt² H z) and
    /// returns z · S z.
    pub(super) fn finish_product(&mut self) -> f64 {
        let partials = (
            blocks_mut(&mut self.product),
            blocks(&self.z),
            blocks(&self.mass),
            blocks(&self.constraint),
        )
            .into_par_iter()
            .map(|(product, z, mass, constraint)| {
                let mut sum = 0.0;
                for i in 0..product.len() {
                    product[i] = constraint[i]
                        .project((z[i] * mass[i] + product[i]).into())
                        .into();
                    sum += z[i].dot(product[i]) as f64;
                }
                sum
            })
            .collect();
        ordered_sum(partials)
    }

    /// p = z + γ p and S p = S z + γ S p (S z in `product`); returns
    /// S p · M⁻¹ S p.
    pub(super) fn next_direction(&mut self, gamma: f32) -> f64 {
        let partials = (
            blocks_mut(&mut self.p),
            blocks_mut(&mut self.sp),
            blocks(&self.z),
            blocks(&self.product),
            blocks(&self.inverse_mass),
        )
            .into_par_iter()
            .map(|(p, sp, z, product, inverse_mass)| {
                let mut sum = 0.0;
                for i in 0..p.len() {
                    p[i] = z[i] + p[i] * gamma;
                    sp[i] = product[i] + sp[i] * gamma;
                    sum += f64::from(sp[i].length_squared() * inverse_mass[i]);
                }
                sum
            })
            .collect();
        ordered_sum(partials)
    }

    /// x += α p, r −= α S p, z = M⁻¹ r; returns r · z = ‖r‖²_{M⁻¹}.
    pub(super) fn advance(&mut self, alpha: f32) -> f64 {
        let partials = (
            blocks_mut(&mut self.x),
            blocks_mut(&mut self.r),
            blocks_mut(&mut self.z),
            blocks(&self.p),
            blocks(&self.sp),
            blocks(&self.inverse_mass),
        )
            .into_par_iter()
            .map(|(x, r, z, p, sp, inverse_mass)| {
                let mut sum = 0.0;
                for i in 0..x.len() {
                    x[i] += p[i] * alpha;
                    r[i] -= sp[i] * alpha;
                    z[i] = r[i] * inverse_mass[i];
                    sum += r[i].dot(z[i]) as f64;
                }
                sum
            })
            .collect();
        ordered_sum(partials)
    }
}
