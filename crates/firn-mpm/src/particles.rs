//! Particle state, structure of arrays (thesis Tabelle 3): each attribute is
//! one contiguous array so that every pass streams only what it reads.

use glam::{Mat3, Vec3};
use rayon::prelude::*;

/// All material points of a simulation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Particles {
    /// Positions x_p.
    pub position: Vec<Vec3>,
    /// Velocities v_p.
    pub velocity: Vec<Vec3>,
    /// Masses m_p.
    pub mass: Vec<f32>,
    /// Initial volumes V_p^0 = m_p / ρ_p^0 (step 2 of the algorithm).
    pub volume0: Vec<f32>,
    /// Elastic deformation gradients F_E.
    pub elastic: Vec<Mat3>,
    /// Plastic volume ratios J_P = det F_P.
    pub plastic_j: Vec<f32>,
    /// V_p^0 τ_p: initial volume times the Kirchhoff stress of the current F_E,
    /// kept from the end of the last step so the next scatter needs no SVD.
    pub stress: Vec<Mat3>,
    /// Velocity gradients ∇v_p from the last gather; with APIC these are the
    /// affine matrices C_p that the next scatter carries to the grid.
    pub velocity_gradient: Vec<Mat3>,
    /// Material index per particle, into the scene's materials.
    pub material: Vec<u16>,
}

impl Particles {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Current density m_p / (J V_p^0) of particle `p`, with J = J_E J_P.
    pub fn density(&self, p: usize) -> f32 {
        let j = self.elastic[p].determinant() * self.plastic_j[p];
        self.mass[p] / (j * self.volume0[p])
    }

    /// Appends an undeformed particle at rest in its own frame: F_E = I,
    /// J_P = 1, no stress and no velocity gradient, with initial volume
    /// `volume0` (snow that settles out of the air, [`crate::spindrift`]).
    pub fn push_undeformed(
        &mut self,
        position: Vec3,
        velocity: Vec3,
        mass: f32,
        volume0: f32,
        material: u16,
    ) {
        self.position.push(position);
        self.velocity.push(velocity);
        self.mass.push(mass);
        self.volume0.push(volume0);
        self.elastic.push(Mat3::IDENTITY);
        self.plastic_j.push(1.0);
        self.stress.push(Mat3::ZERO);
        self.velocity_gradient.push(Mat3::ZERO);
        self.material.push(material);
    }

    /// Appends every particle of `other`, in its order.
    pub fn append(&mut self, mut other: Particles) {
        self.position.append(&mut other.position);
        self.velocity.append(&mut other.velocity);
        self.mass.append(&mut other.mass);
        self.volume0.append(&mut other.volume0);
        self.elastic.append(&mut other.elastic);
        self.plastic_j.append(&mut other.plastic_j);
        self.stress.append(&mut other.stress);
        self.velocity_gradient.append(&mut other.velocity_gradient);
        self.material.append(&mut other.material);
    }

    /// Removes the particles at `sorted` (ascending indices), keeping the
    /// others in their order.
    pub fn remove_sorted(&mut self, sorted: &[usize]) {
        fn remove<T: Copy>(values: &mut Vec<T>, sorted: &[usize]) {
            let mut removed = sorted.iter().peekable();
            let mut index = 0;
            values.retain(|_| {
                let keep = removed.peek() != Some(&&index);
                if !keep {
                    removed.next();
                }
                index += 1;
                keep
            });
        }
        if sorted.is_empty() {
            return;
        }
        remove(&mut self.position, sorted);
        remove(&mut self.velocity, sorted);
        remove(&mut self.mass, sorted);
        remove(&mut self.volume0, sorted);
        remove(&mut self.elastic, sorted);
        remove(&mut self.plastic_j, sorted);
        remove(&mut self.stress, sorted);
        remove(&mut self.velocity_gradient, sorted);
        remove(&mut self.material, sorted);
    }

    /// Bytes held per particle (for memory estimates).
    pub fn bytes_per_particle() -> usize {
        let vectors = 2 * std::mem::size_of::<Vec3>();
        let scalars = 3 * std::mem::size_of::<f32>() + std::mem::size_of::<u16>();
        let matrices = 3 * std::mem::size_of::<Mat3>();
        // Plus the u32 bin order entry.
        vectors + scalars + matrices + std::mem::size_of::<u32>()
    }

    /// Reorders every attribute so that new index `i` holds old particle
    /// `order[i]`, through `buffers` (each attribute is gathered into the
    /// buffer of its type, which then takes the attribute's place).
    pub fn permute(&mut self, order: &[u32], buffers: &mut PermuteBuffers) {
        fn gather<T: Copy + Send + Sync>(values: &mut Vec<T>, order: &[u32], buffer: &mut Vec<T>) {
            buffer.clear();
            buffer.par_extend(order.par_iter().map(|&p| values[p as usize]));
            std::mem::swap(values, buffer);
        }
        let PermuteBuffers {
            vectors,
            scalars,
            matrices,
            materials,
        } = buffers;
        gather(&mut self.position, order, vectors);
        gather(&mut self.velocity, order, vectors);
        gather(&mut self.mass, order, scalars);
        gather(&mut self.volume0, order, scalars);
        gather(&mut self.elastic, order, matrices);
        gather(&mut self.plastic_j, order, scalars);
        gather(&mut self.stress, order, matrices);
        gather(&mut self.velocity_gradient, order, matrices);
        gather(&mut self.material, order, materials);
    }
}

/// Reusable space for [`Particles::permute`], one array per attribute type.
/// Kept between reorderings because a fresh allocation of this size comes
/// from the kernel as new pages, whose faults and zeroing cost more than the
/// copy itself (7 % of a single-threaded substep when each reordering
/// allocated its arrays anew).
#[derive(Clone, Debug, Default)]
pub struct PermuteBuffers {
    vectors: Vec<Vec3>,
    scalars: Vec<f32>,
    matrices: Vec<Mat3>,
    materials: Vec<u16>,
}

impl PermuteBuffers {
    /// Bytes held per particle once the particles have been reordered.
    pub const BYTES_PER_PARTICLE: usize = std::mem::size_of::<Vec3>()
        + std::mem::size_of::<f32>()
        + std::mem::size_of::<Mat3>()
        + std::mem::size_of::<u16>();

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.vectors.capacity() * std::mem::size_of::<Vec3>()
            + self.scalars.capacity() * std::mem::size_of::<f32>()
            + self.matrices.capacity() * std::mem::size_of::<Mat3>()
            + self.materials.capacity() * std::mem::size_of::<u16>()
    }
}
