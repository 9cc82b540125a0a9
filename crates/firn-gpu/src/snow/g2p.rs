//! Grid to particle, the gather (thesis §3.4 steps 7 to 10;
//! `shaders/snow/g2p.wgsl`), the GPU's counterpart of `firn_mpm::g2p`: each
//! particle reads its new velocity and ∇v_p from the grid (step 8: the
//! PIC/FLIP blend v_p = (1 − α) v_PIC + α v_FLIP with cubic B-splines, or
//! APIC's v_p and C_p with quadratic ones), then its deformation update
//! F̂_E = (I + Δt ∇v_p) F_E, plasticity and stress (step 7, eq. 34-43, the
//! snow model of `shaders/common/snow_model.wgsl` with its SVD), the
//! particle collisions (step 9) and the advection x_p += Δt v_p (step 10).
//! It also checks every particle (finite, inside the domain) and reduces
//! the largest |v_p|² and wave speed, per workgroup and then by atomics,
//! for the next Δt (`begin_step.rs`).

use firn_core::scene::Transfer;

use super::program::{Kernel, StepProgram};

/// The gather's kernel for one transfer scheme.
pub struct G2p {
    kernel: Kernel,
}

impl G2p {
    /// `gather_apic` or `gather_pic_flip`.
    pub fn new(program: &StepProgram, transfer: Transfer) -> G2p {
        let entry = match transfer {
            Transfer::Apic => "gather_apic",
            Transfer::PicFlip => "gather_pic_flip",
        };
        G2p {
            kernel: program.kernel(entry),
        }
    }

    /// Records the gather, one invocation per particle.
    pub fn record(&self, pass: &mut wgpu::ComputePass, groups: (u32, u32, u32)) {
        self.kernel.dispatch(pass, groups);
    }
}
