//! The wind's drag on the grid (`[wind]`, `shaders/snow/wind.wgsl`), as
//! `firn_mpm::wind` computes it: the curl-noise air field of the flow
//! kernels (`shaders/flow/field.wgsl`, with the same constants the flow
//! backend forms) evaluated at each node in the grid update, and the drag
//! rate from the node's and its upwind neighbours' masses. The CPU solver is
//! the reference; the GPU follows it within the parity tolerances (its
//! noise offsets are formed in f32 on the device, its exponential is WGSL's).

use bytemuck::{Pod, Zeroable};
use firn_core::Scene;

use crate::buffers::uniform_buffer;
use crate::context::GpuContext;
use crate::flow::layout::{FieldConstants, NoiseDomains, ObstacleData, obstacles};

/// Spheres a wind may flow around on the GPU (a uniform array).
pub const MAX_WIND_OBSTACLES: usize = 8;

/// `WindParams` of `wind.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct WindParams {
    offsets: [[f32; 4]; 3],
    drift: [[f32; 4]; 3],
    node_drag: f32,
    packed_mass: f32,
    pad: [u32; 2],
}

/// The wind's three uniform buffers (zeroes without wind).
pub struct WindBuffers {
    /// The air field's constants (`FieldConstants`).
    pub field_constants: wgpu::Buffer,
    /// Its obstacles (`array<Obstacle, 8>`).
    pub obstacles: wgpu::Buffer,
    /// The drag and the noise domains (`WindParams`).
    pub params: wgpu::Buffer,
}

impl WindBuffers {
    /// The buffers of `scene`'s wind, or of none.
    pub fn upload(context: &GpuContext, scene: &Scene) -> WindBuffers {
        let (constants, spheres, params) = wind_data(scene);
        WindBuffers {
            field_constants: uniform_buffer(context, "wind field", &constants),
            obstacles: uniform_buffer(context, "wind obstacles", &spheres),
            params: uniform_buffer(context, "wind", &params),
        }
    }

    /// Rewrites the buffers with `scene`'s wind, from the next substep on.
    pub fn write(&self, context: &GpuContext, scene: &Scene) {
        let (constants, spheres, params) = wind_data(scene);
        let queue = &context.queue;
        queue.write_buffer(&self.field_constants, 0, bytemuck::bytes_of(&constants));
        queue.write_buffer(&self.obstacles, 0, bytemuck::bytes_of(&spheres));
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
    }
}

/// The obstacles of a wind as the uniform array holds them.
type Spheres = [ObstacleData; MAX_WIND_OBSTACLES];

/// What the three buffers hold for `scene`'s wind (zeroes without one).
fn wind_data(scene: &Scene) -> (FieldConstants, Spheres, WindParams) {
    let mut constants = FieldConstants::zeroed();
    let mut spheres = [ObstacleData::zeroed(); MAX_WIND_OBSTACLES];
    let mut params = WindParams::zeroed();
    if let Some(wind) = &scene.wind {
        let h = scene.domain.cell_size;
        let domains = NoiseDomains::new(&wind.field);
        constants = FieldConstants::new(scene, &wind.field);
        for (slot, sphere) in spheres.iter_mut().zip(obstacles(&wind.field)) {
            *slot = sphere;
        }
        params = WindParams {
            offsets: domains.offsets_at(0.0),
            drift: domains.drift(),
            node_drag: wind.drag * h * h,
            packed_mass: wind.packed_density * h * h * h,
            pad: [0; 2],
        };
    }
    (constants, spheres, params)
}
