//! Reading a render target back to the host as an RGBA image.

/// Bytes per pixel of the formats [`capture`] reads.
const BYTES_PER_PIXEL: u32 = 4;

/// Whether the texture's bytes are in blue-green-red order. Panics for
/// formats other than 8-bit RGBA and BGRA.
fn is_bgra(format: wgpu::TextureFormat) -> bool {
    use wgpu::TextureFormat as Format;
    match format {
        Format::Rgba8Unorm | Format::Rgba8UnormSrgb => false,
        Format::Bgra8Unorm | Format::Bgra8UnormSrgb => true,
        other => panic!("capture reads 8-bit RGBA or BGRA targets, not {other:?}"),
    }
}

/// Reads `texture` (a render target with `COPY_SRC`, 8-bit RGBA or BGRA)
/// back as an sRGB RGBA image, whatever its channel order. The renderer
/// stores sRGB-encoded colours in non-sRGB targets too, so the bytes are
/// returned as they are. Blocks until the copy is done; panics if the
/// device is lost or the format is another.
pub fn capture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> image::RgbaImage {
    let bgra = is_bgra(texture.format());
    let (width, height) = (texture.width(), texture.height());
    let row_bytes = width * BYTES_PER_PIXEL;
    let padded_row_bytes = row_bytes.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("firn-view capture"),
        size: u64::from(padded_row_bytes) * u64::from(height),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("firn-view capture"),
    });
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded_row_bytes),
                rows_per_image: Some(height),
            },
        },
        texture.size(),
    );
    queue.submit([encoder.finish()]);
    let (sender, receiver) = std::sync::mpsc::channel();
    staging.map_async(wgpu::MapMode::Read, .., move |result| {
        // The receiver waits below; a closed channel cannot happen.
        let _ = sender.send(result);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("the device finishes the capture copy");
    receiver
        .recv()
        .expect("mapping the capture reports back")
        .expect("the capture buffer maps");
    let mapped = staging
        .get_mapped_range(..)
        .expect("the capture buffer is mapped");
    let mut pixels = Vec::with_capacity((row_bytes * height) as usize);
    for row in mapped.chunks_exact(padded_row_bytes as usize) {
        pixels.extend_from_slice(&row[..row_bytes as usize]);
    }
    drop(mapped);
    staging.unmap();
    if bgra {
        pixels
            .chunks_exact_mut(BYTES_PER_PIXEL as usize)
            .for_each(|pixel| pixel.swap(0, 2));
    }
    image::RgbaImage::from_raw(width, height, pixels).expect("the pixels fill the image")
}
