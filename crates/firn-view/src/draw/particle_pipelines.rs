//! The particle pipelines and their bind group layouts: group 1 is the
//! particle source (`particle_source.wgsl`), group 2 the trail rings
//! (`trails.wgsl`).

use super::gpu::{
    ColorTarget, DepthUse, PipelineSpec, render_pipeline, shader_module, storage_entry,
    uniform_entry,
};

const FRAME_SHADER: &str = include_str!("../../shaders/frame.wgsl");
const SOURCE_SHADER: &str = include_str!("../../shaders/particle_source.wgsl");
const SPRITE_SHADER: &str = include_str!("../../shaders/particles.wgsl");
const RIBBON_SHADER: &str = include_str!("../../shaders/trails.wgsl");

/// Which sprites are drawn.
#[derive(Clone, Copy, Debug)]
pub(super) enum SpriteKind {
    /// Sphere-shaded, depth-writing points.
    Points,
    /// Additive soft sprites.
    Billboards,
}

/// The three particle pipelines and the layouts of groups 1 and 2.
pub(super) struct ParticlePipelines {
    /// Group 1: the source uniform, positions and values.
    pub(super) source_layout: wgpu::BindGroupLayout,
    /// Group 2: the rings uniform, ring points and ring lengths.
    pub(super) rings_layout: wgpu::BindGroupLayout,
    points: wgpu::RenderPipeline,
    billboards: wgpu::RenderPipeline,
    /// Trails as additive ribbons.
    pub(super) ribbons: wgpu::RenderPipeline,
}

impl ParticlePipelines {
    /// The pipelines for targets like `target`.
    pub(super) fn new(
        device: &wgpu::Device,
        target: ColorTarget,
        frame_layout: &wgpu::BindGroupLayout,
    ) -> ParticlePipelines {
        let source_layout = vertex_buffers_layout(device, "firn-view particles");
        let rings_layout = vertex_buffers_layout(device, "firn-view trail rings");
        let sprites = shader_module(
            device,
            "firn-view sprites",
            &[FRAME_SHADER, SOURCE_SHADER, SPRITE_SHADER],
        );
        let ribbons = shader_module(
            device,
            "firn-view ribbons",
            &[FRAME_SHADER, SOURCE_SHADER, RIBBON_SHADER],
        );
        let sprite_groups = [frame_layout, &source_layout];
        let sprite_pipeline = |label, fragment, depth, additive| {
            render_pipeline(
                device,
                target,
                &PipelineSpec {
                    label,
                    groups: &sprite_groups,
                    module: &sprites,
                    vertex: "vertex_sprite",
                    fragment,
                    buffers: &[],
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    depth,
                    additive,
                },
            )
        };
        let points = sprite_pipeline(
            "firn-view points",
            "fragment_point",
            DepthUse::TestAndWrite,
            false,
        );
        let billboards = sprite_pipeline(
            "firn-view billboards",
            "fragment_billboard",
            DepthUse::TestOnly,
            true,
        );
        let ribbons = render_pipeline(
            device,
            target,
            &PipelineSpec {
                label: "firn-view ribbons",
                groups: &[frame_layout, &source_layout, &rings_layout],
                module: &ribbons,
                vertex: "vertex_ribbon",
                fragment: "fragment_ribbon",
                buffers: &[],
                topology: wgpu::PrimitiveTopology::TriangleList,
                depth: DepthUse::TestOnly,
                additive: true,
            },
        );
        ParticlePipelines {
            source_layout,
            rings_layout,
            points,
            billboards,
            ribbons,
        }
    }

    /// The pipeline of `kind`.
    pub(super) fn sprites(&self, kind: SpriteKind) -> &wgpu::RenderPipeline {
        match kind {
            SpriteKind::Points => &self.points,
            SpriteKind::Billboards => &self.billboards,
        }
    }
}

/// A layout of a uniform and two read-only storage buffers, read by vertex shaders.
fn vertex_buffers_layout(device: &wgpu::Device, label: &str) -> wgpu::BindGroupLayout {
    let vertex = wgpu::ShaderStages::VERTEX;
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &[
            uniform_entry(0, vertex),
            storage_entry(1, vertex),
            storage_entry(2, vertex),
        ],
    })
}
