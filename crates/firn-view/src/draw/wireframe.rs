//! The container's twelve edges as a line list (`wireframe.wgsl`).

use firn_render::stage::Stage;
use glam::Vec3;

use super::geometry::box_edges;
use super::gpu::{ColorTarget, DepthUse, PipelineSpec, render_pipeline, shader_module};

const SHADER: [&str; 2] = [
    include_str!("../../shaders/frame.wgsl"),
    include_str!("../../shaders/wireframe.wgsl"),
];

/// End points of the twelve edges.
const EDGE_POINTS: u32 = 24;

const POSITION_ATTRIBUTES: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![0 => Float32x3];

/// The container's pipeline and its edges' vertex buffer.
pub(super) struct Wireframe {
    pipeline: wgpu::RenderPipeline,
    edges: wgpu::Buffer,
    visible: bool,
}

impl Wireframe {
    /// The pipeline and a buffer for the edges.
    pub(super) fn new(
        device: &wgpu::Device,
        target: ColorTarget,
        frame_layout: &wgpu::BindGroupLayout,
    ) -> Wireframe {
        let module = shader_module(device, "firn-view wireframe", &SHADER);
        let buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: size_of::<Vec3>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &POSITION_ATTRIBUTES,
        })];
        let pipeline = render_pipeline(
            device,
            target,
            &PipelineSpec {
                label: "firn-view wireframe",
                groups: &[frame_layout],
                module: &module,
                vertex: "vertex_edge",
                fragment: "fragment_edge",
                buffers: &buffers,
                topology: wgpu::PrimitiveTopology::LineList,
                depth: DepthUse::TestAndWrite,
                additive: false,
            },
        );
        let edges = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("firn-view container edges"),
            size: u64::from(EDGE_POINTS) * size_of::<Vec3>() as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Wireframe {
            pipeline,
            edges,
            visible: false,
        }
    }

    /// Uploads the stage's container, if it has one.
    pub(super) fn prepare(&mut self, queue: &wgpu::Queue, stage: &Stage) {
        self.visible = stage.container.is_some();
        if let Some((min, max)) = stage.container {
            let points: Vec<Vec3> = box_edges(min, max).into_iter().flatten().collect();
            queue.write_buffer(&self.edges, 0, bytemuck::cast_slice(&points));
        }
    }

    /// Draws the edges of the last [`Wireframe::prepare`].
    pub(super) fn draw(&self, pass: &mut wgpu::RenderPass<'_>, frame_group: &wgpu::BindGroup) {
        if !self.visible {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, frame_group, &[]);
        pass.set_vertex_buffer(0, self.edges.slice(..));
        pass.draw(0..EDGE_POINTS, 0..1);
    }
}
