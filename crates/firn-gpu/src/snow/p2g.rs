//! Particle to grid, the scatter (thesis §3.4 steps 1 and 3;
//! `shaders/snow/p2g.wgsl`), the GPU's counterpart of `firn_mpm::p2g`: mass
//! and momentum onto the grid, and the elastic force
//! f_i = −Σ_p V_p^0 τ_p ∇w_ip (eq. 31-33), for both transfer schemes:
//!
//! - PIC/FLIP with cubic B-splines: mass, momentum and the force impulse
//!   Δt f_i are summed apart (`scatter_pic_flip`);
//! - APIC with quadratic B-splines, in the MLS-MPM form: the sums
//!   w_ip (m_p v_p + (m_p C_p − Δt (4/h²) V_p^0 τ_p)(x_i − x_p)), the force
//!   impulse inside the momentum (`scatter_apic`).
//!
//! Step 2, the volumes V_p^0, runs once on the CPU before the particles come
//! to the GPU (`firn_mpm::Snapshot::initial`). The sums are 64-bit fixed
//! point ([`super::fixed_point`]), so both scatters ([`Scatter`]) give the
//! same bits in any order.

use firn_core::scene::Transfer;

use super::program::{Kernel, StepProgram};

/// How the scatter adds particle contributions into the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scatter {
    /// Every particle adds into the grid's sums with global atomics.
    Atomic,
    /// Particles are sorted by block each substep and each workgroup sums
    /// one block's chunk of particles in workgroup memory first.
    Binned,
}

/// Workgroup memory the binned scatter needs: the 7³ nodes' sums of seven
/// quantities in two words, and its header.
const BINNED_WORKGROUP_BYTES: u32 = 4802 * 4 + 16;

/// Whether an adapter with `limits` has the workgroup memory of the binned
/// scatter.
pub fn binned_fits(limits: &wgpu::Limits) -> bool {
    limits.max_compute_workgroup_storage_size >= BINNED_WORKGROUP_BYTES
}

/// The atomic scatter's kernel for one transfer scheme.
pub struct P2g {
    kernel: Kernel,
}

impl P2g {
    /// `scatter_apic` or `scatter_pic_flip`.
    pub fn new(program: &StepProgram, transfer: Transfer) -> P2g {
        let entry = match transfer {
            Transfer::Apic => "scatter_apic",
            Transfer::PicFlip => "scatter_pic_flip",
        };
        P2g {
            kernel: program.kernel(entry),
        }
    }

    /// Records the scatter, one invocation per particle.
    pub fn record(&self, pass: &mut wgpu::ComputePass, groups: (u32, u32, u32)) {
        self.kernel.dispatch(pass, groups);
    }
}

/// The binned scatter's kernel for one transfer scheme.
pub struct BinnedP2g {
    kernel: Kernel,
}

impl BinnedP2g {
    /// `scatter_binned_apic` or `scatter_binned_pic_flip`.
    pub fn new(program: &StepProgram, transfer: Transfer) -> BinnedP2g {
        let entry = match transfer {
            Transfer::Apic => "scatter_binned_apic",
            Transfer::PicFlip => "scatter_binned_pic_flip",
        };
        BinnedP2g {
            kernel: program.kernel(entry),
        }
    }

    /// Records the scatter, one workgroup per work item of the sort
    /// (`binning.rs`), as many as its `indirect` arguments say.
    pub fn record(&self, pass: &mut wgpu::ComputePass, indirect: &wgpu::Buffer) {
        self.kernel.dispatch_indirect(pass, indirect, 0);
    }
}
