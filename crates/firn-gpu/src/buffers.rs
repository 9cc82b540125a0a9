//! Creating storage and uniform buffers and reading them back.

use bytemuck::Pod;
use wgpu::util::DeviceExt;

use crate::context::GpuContext;
use crate::error::GpuError;

/// A storage buffer holding `contents` (at least 16 bytes, since empty
/// bindings are not allowed), copyable both ways.
pub fn storage_buffer<T: Pod>(context: &GpuContext, label: &str, contents: &[T]) -> wgpu::Buffer {
    let mut bytes = bytemuck::cast_slice::<T, u8>(contents).to_vec();
    bytes.resize(bytes.len().max(16).next_multiple_of(4), 0);
    context
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &bytes,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
        })
}

/// A uniform buffer holding `value`, which the host may rewrite.
pub fn uniform_buffer<T: Pod>(context: &GpuContext, label: &str, value: &T) -> wgpu::Buffer {
    context
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::bytes_of(value),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        })
}

/// A zeroed storage buffer of `bytes` bytes (at least 16).
pub fn zeroed_storage_buffer(context: &GpuContext, label: &str, bytes: u64) -> wgpu::Buffer {
    context.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(16).next_multiple_of(4),
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// The first `count` elements of each buffer, read back in one submission.
pub fn read_back<T: Pod>(
    context: &GpuContext,
    buffers: &[(&wgpu::Buffer, usize)],
) -> Result<Vec<Vec<T>>, GpuError> {
    let element = std::mem::size_of::<T>() as u64;
    let mut encoder = context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("read back"),
        });
    let staging: Vec<wgpu::Buffer> = buffers
        .iter()
        .map(|&(source, count)| {
            let size = (count as u64 * element).max(4).next_multiple_of(4);
            let target = context.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("staging"),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            encoder.copy_buffer_to_buffer(source, 0, &target, 0, size);
            target
        })
        .collect();
    context.queue.submit([encoder.finish()]);
    for buffer in &staging {
        buffer.map_async(wgpu::MapMode::Read, .., |_| {});
    }
    context.wait()?;
    staging
        .iter()
        .zip(buffers)
        .map(|(buffer, &(_, count))| {
            let view = buffer
                .get_mapped_range(..)
                .map_err(|error| GpuError::Device(format!("reading back: {error:?}")))?;
            let values = bytemuck::cast_slice::<u8, T>(&view[..count * element as usize]).to_vec();
            drop(view);
            buffer.unmap();
            Ok(values)
        })
        .collect()
}
