//! The sky gradient and the ground's checkerboard (`backdrop.wgsl`): one
//! full-screen triangle, ray-cast per pixel, that sets every pixel's colour
//! and depth before anything else is drawn.

use super::gpu::{ColorTarget, DepthUse, PipelineSpec, render_pipeline, shader_module};

const SHADER: [&str; 2] = [
    include_str!("../../shaders/frame.wgsl"),
    include_str!("../../shaders/backdrop.wgsl"),
];

/// The backdrop's pipeline.
pub(super) struct Backdrop {
    pipeline: wgpu::RenderPipeline,
}

impl Backdrop {
    /// The pipeline for targets like `target`.
    pub(super) fn new(
        device: &wgpu::Device,
        target: ColorTarget,
        frame_layout: &wgpu::BindGroupLayout,
    ) -> Backdrop {
        let module = shader_module(device, "firn-view backdrop", &SHADER);
        let pipeline = render_pipeline(
            device,
            target,
            &PipelineSpec {
                label: "firn-view backdrop",
                groups: &[frame_layout],
                module: &module,
                vertex: "vertex_fullscreen",
                fragment: "fragment_backdrop",
                buffers: &[],
                topology: wgpu::PrimitiveTopology::TriangleList,
                depth: DepthUse::Overwrite,
                additive: false,
            },
        );
        Backdrop { pipeline }
    }

    /// Covers the target with sky and ground.
    pub(super) fn draw(&self, pass: &mut wgpu::RenderPass<'_>, frame_group: &wgpu::BindGroup) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, frame_group, &[]);
        pass.draw(0..3, 0..1);
    }
}
