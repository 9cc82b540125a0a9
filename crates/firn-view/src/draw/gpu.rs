//! Small wgpu helpers the drawing passes share: buffers that grow on
//! demand, bind group layout entries, render pipelines over the frame's
//! colour and depth targets, and the depth texture.

use std::borrow::Cow;

/// Format of the renderer's depth texture.
pub(super) const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Smallest size of a renderer-owned buffer: bindings may not be empty.
const MIN_BUFFER_BYTES: u64 = 16;

/// A buffer the renderer owns and refills each frame, reallocated (to the
/// next power of two) only when the data outgrows it.
pub(super) struct GrowingBuffer {
    label: &'static str,
    usage: wgpu::BufferUsages,
    buffer: wgpu::Buffer,
}

impl GrowingBuffer {
    /// An empty buffer; `COPY_DST` is added to `usage`.
    pub(super) fn new(
        device: &wgpu::Device,
        label: &'static str,
        usage: wgpu::BufferUsages,
    ) -> GrowingBuffer {
        let usage = usage | wgpu::BufferUsages::COPY_DST;
        GrowingBuffer {
            label,
            usage,
            buffer: allocate(device, label, usage, MIN_BUFFER_BYTES),
        }
    }

    /// Makes room for at least `bytes` bytes (the contents are lost when it grows).
    pub(super) fn reserve(&mut self, device: &wgpu::Device, bytes: u64) {
        if bytes > self.buffer.size() {
            let size = bytes.next_power_of_two().max(MIN_BUFFER_BYTES);
            self.buffer = allocate(device, self.label, self.usage, size);
        }
    }

    /// Replaces the contents with `bytes` (a multiple of four bytes long).
    pub(super) fn write(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, bytes: &[u8]) {
        self.reserve(device, bytes.len() as u64);
        if !bytes.is_empty() {
            queue.write_buffer(&self.buffer, 0, bytes);
        }
    }

    /// The buffer as it is now.
    pub(super) fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }
}

fn allocate(
    device: &wgpu::Device,
    label: &str,
    usage: wgpu::BufferUsages,
    size: u64,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT),
        usage,
        mapped_at_creation: false,
    })
}

/// A uniform buffer holding `value`, rewritten with `queue.write_buffer`.
pub(super) fn uniform_buffer<T: bytemuck::Pod>(
    device: &wgpu::Device,
    label: &str,
    value: &T,
) -> wgpu::Buffer {
    fill_at_creation(
        device,
        label,
        wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        bytemuck::bytes_of(value),
    )
}

/// A buffer created with `bytes` as its contents.
pub(super) fn fill_at_creation(
    device: &wgpu::Device,
    label: &str,
    usage: wgpu::BufferUsages,
    bytes: &[u8],
) -> wgpu::Buffer {
    let size = (bytes.len() as u64)
        .max(MIN_BUFFER_BYTES)
        .next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage,
        mapped_at_creation: true,
    });
    buffer
        .get_mapped_range_mut(..)
        .expect("a buffer mapped at creation is mapped")
        .slice(..bytes.len())
        .copy_from_slice(bytes);
    buffer.unmap();
    buffer
}

/// A uniform buffer entry of a bind group layout.
pub(super) fn uniform_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(binding, visibility, wgpu::BufferBindingType::Uniform)
}

/// A read-only storage buffer entry of a bind group layout.
pub(super) fn storage_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(
        binding,
        visibility,
        wgpu::BufferBindingType::Storage { read_only: true },
    )
}

fn buffer_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    ty: wgpu::BufferBindingType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A bind group of whole buffers, bound at 0, 1, 2, ... in order.
pub(super) fn bind_buffers(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
        .iter()
        .zip(0..)
        .map(|(buffer, binding)| wgpu::BindGroupEntry {
            binding,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// A WGSL module made of `parts` in order (the shared frame declarations first).
pub(super) fn shader_module(
    device: &wgpu::Device,
    label: &str,
    parts: &[&str],
) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(Cow::Owned(parts.concat())),
    })
}

/// The colour target every drawing pipeline renders into.
#[derive(Clone, Copy, Debug)]
pub(super) struct ColorTarget {
    /// The target's format.
    pub(super) format: wgpu::TextureFormat,
}

impl ColorTarget {
    /// Whether shaders must sRGB-encode their output (the format stores
    /// what it is given rather than encoding linear values itself).
    fn encodes_in_shader(self) -> bool {
        !self.format.is_srgb()
    }
}

/// How a pipeline uses the depth buffer.
#[derive(Clone, Copy, Debug)]
pub(super) enum DepthUse {
    /// Overwrites depth everywhere (the backdrop).
    Overwrite,
    /// Depth-tested and writes its depth (opaque geometry).
    TestAndWrite,
    /// Depth-tested, writes nothing (additive sprites and ribbons).
    TestOnly,
}

impl DepthUse {
    fn state(self) -> wgpu::DepthStencilState {
        let (compare, write) = match self {
            DepthUse::Overwrite => (wgpu::CompareFunction::Always, true),
            DepthUse::TestAndWrite => (wgpu::CompareFunction::Less, true),
            DepthUse::TestOnly => (wgpu::CompareFunction::Less, false),
        };
        wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(write),
            depth_compare: Some(compare),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        }
    }
}

/// What differs between the drawing pipelines.
pub(super) struct PipelineSpec<'a> {
    /// Debug label.
    pub(super) label: &'a str,
    /// The pipeline's bind group layouts, group 0 first.
    pub(super) groups: &'a [&'a wgpu::BindGroupLayout],
    /// The module with both entry points.
    pub(super) module: &'a wgpu::ShaderModule,
    /// Vertex entry point.
    pub(super) vertex: &'a str,
    /// Fragment entry point.
    pub(super) fragment: &'a str,
    /// Vertex buffers.
    pub(super) buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
    /// Primitive topology.
    pub(super) topology: wgpu::PrimitiveTopology,
    /// Depth test and write.
    pub(super) depth: DepthUse,
    /// Adds onto the target instead of replacing it.
    pub(super) additive: bool,
}

/// Adds colour, keeps the target's alpha.
const ADDITIVE_BLEND: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
};

/// The render pipeline `spec` describes, drawing into `target`.
pub(super) fn render_pipeline(
    device: &wgpu::Device,
    target: ColorTarget,
    spec: &PipelineSpec<'_>,
) -> wgpu::RenderPipeline {
    let groups: Vec<Option<&wgpu::BindGroupLayout>> =
        spec.groups.iter().copied().map(Some).collect();
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(spec.label),
        bind_group_layouts: &groups,
        immediate_size: 0,
    });
    let constants = [(
        "ENCODE_SRGB",
        f64::from(u8::from(target.encodes_in_shader())),
    )];
    let options = wgpu::PipelineCompilationOptions {
        constants: &constants,
        ..wgpu::PipelineCompilationOptions::default()
    };
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(spec.label),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: spec.module,
            entry_point: Some(spec.vertex),
            compilation_options: options.clone(),
            buffers: spec.buffers,
        },
        primitive: wgpu::PrimitiveState {
            topology: spec.topology,
            ..wgpu::PrimitiveState::default()
        },
        depth_stencil: Some(spec.depth.state()),
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: spec.module,
            entry_point: Some(spec.fragment),
            compilation_options: options,
            targets: &[Some(wgpu::ColorTargetState {
                format: target.format,
                blend: spec.additive.then_some(ADDITIVE_BLEND),
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// The depth texture, resized to the target's size when that changes.
pub(super) struct DepthTarget {
    size: [u32; 2],
    view: wgpu::TextureView,
}

impl DepthTarget {
    /// A depth texture of `size` pixels.
    pub(super) fn new(device: &wgpu::Device, size: [u32; 2]) -> DepthTarget {
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("firn-view depth"),
            size: wgpu::Extent3d {
                width: size[0].max(1),
                height: size[1].max(1),
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        });
        DepthTarget {
            size,
            view: texture.create_view(&wgpu::TextureViewDescriptor::default()),
        }
    }

    /// The view for a target of `size` pixels (recreated if the size changed).
    pub(super) fn view_for(&mut self, device: &wgpu::Device, size: [u32; 2]) -> &wgpu::TextureView {
        if self.size != size {
            *self = DepthTarget::new(device, size);
        }
        &self.view
    }
}
