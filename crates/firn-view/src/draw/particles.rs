//! The particles (`particle_source.wgsl`, `particles.wgsl`, `trails.wgsl`):
//! sphere-shaded points, additive billboards or fading ribbons, read in the
//! vertex shaders from storage buffers: a GPU simulation's own, or the
//! renderer's upload of host data.

use bytemuck::{Pod, Zeroable};
use firn_core::scene::ColorBy;
use firn_gpu::draw::{ParticleArrays, TrailArrays};
use firn_render::trails::Trails;
use glam::Vec3;

use super::frame::{ParticleColoring, SpriteSize};
use super::gpu::{ColorTarget, GrowingBuffer, bind_buffers, uniform_buffer};
use super::particle_pipelines::{ParticlePipelines, SpriteKind};
use super::values::ValueKernels;
use super::{DrawFrame, DrawStyle, ParticleSource};

/// Smallest radius of a point in pixels, so far particles do not vanish
/// between pixel centres.
const POINT_MIN_RADIUS_PIXELS: f32 = 0.75;
/// Smallest radius of a billboard in pixels.
const BILLBOARD_MIN_RADIUS_PIXELS: f32 = 1.0;
/// Billboards are this many times the point radius (as in firn_render).
const BILLBOARD_RADIUS_PER_POINT_RADIUS: f32 = 2.0;
/// Vertices of a sprite's quad (two triangles).
const QUAD_VERTICES: u32 = 6;
/// `rings.head` when every ring is stored oldest first (`NEWEST_LAST` in
/// `trails.wgsl`).
const NEWEST_LAST: u32 = u32::MAX;

/// Where positions are (`Source` in `particle_source.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct SourceUniform {
    count: u32,
    position_stride: u32,
    position_offset: u32,
    _pad: u32,
}

/// How the trail rings are laid out (`Rings` in `trails.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct RingsUniform {
    capacity: u32,
    head: u32,
    _pad: [u32; 2],
}

/// One frame's particle draw, ready for the pass.
enum ParticleDraw {
    /// Points or billboards: one quad per particle.
    Sprites {
        kind: SpriteKind,
        source: wgpu::BindGroup,
        count: u32,
    },
    /// One ribbon per ring.
    Ribbons {
        source: wgpu::BindGroup,
        rings: wgpu::BindGroup,
        vertices_per_ring: u32,
        ring_count: u32,
    },
}

/// What a frame's particles look like, for the frame uniforms.
#[derive(Clone, Copy, Debug)]
pub(super) struct ParticleLook {
    /// Their colours.
    pub(super) coloring: ParticleColoring,
    /// Their sprites' size.
    pub(super) sprites: SpriteSize,
}

/// The particle pipelines, the value kernels and the buffers host data is
/// uploaded into.
pub(super) struct Particles {
    pipelines: ParticlePipelines,
    kernels: ValueKernels,
    source_uniform: wgpu::Buffer,
    rings_uniform: wgpu::Buffer,
    positions: GrowingBuffer,
    values: GrowingBuffer,
    ring_points: GrowingBuffer,
    ring_lengths: GrowingBuffer,
    prepared: Option<ParticleDraw>,
}

impl Particles {
    /// Pipelines for targets like `target`, and empty upload buffers.
    pub(super) fn new(
        device: &wgpu::Device,
        target: ColorTarget,
        frame_layout: &wgpu::BindGroupLayout,
    ) -> Particles {
        let storage = wgpu::BufferUsages::STORAGE;
        Particles {
            pipelines: ParticlePipelines::new(device, target, frame_layout),
            kernels: ValueKernels::new(device),
            source_uniform: uniform_buffer(
                device,
                "firn-view particle source",
                &SourceUniform::zeroed(),
            ),
            rings_uniform: uniform_buffer(device, "firn-view trail rings", &RingsUniform::zeroed()),
            positions: GrowingBuffer::new(device, "firn-view positions", storage),
            values: GrowingBuffer::new(device, "firn-view values", storage),
            ring_points: GrowingBuffer::new(device, "firn-view trail points", storage),
            ring_lengths: GrowingBuffer::new(device, "firn-view trail lengths", storage),
            prepared: None,
        }
    }

    /// Uploads host particles (or records the colour values of device
    /// particles into `encoder`) and binds them for this frame; returns how
    /// they look.
    pub(super) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        frame: &DrawFrame<'_>,
        domain: (Vec3, Vec3),
    ) -> ParticleLook {
        let has_values = match frame.particles {
            ParticleSource::Host {
                positions, values, ..
            } => self.upload_host(
                device,
                queue,
                positions,
                values.filter(|_| wants_values(frame)),
            ),
            ParticleSource::Device(arrays) => self.bind_device(
                device,
                queue,
                encoder,
                frame.color_by,
                &arrays,
                wants_values(frame),
            ),
        };
        let coloring = coloring(frame, has_values, frame.stage.container.unwrap_or(domain));
        let style = drawn_style(frame);
        self.prepared = self.particle_draw(device, queue, frame, style);
        ParticleLook {
            coloring,
            sprites: sprite_size(style, frame.point_radius),
        }
    }

    /// Draws the particles of the last [`Particles::prepare`].
    pub(super) fn draw(&self, pass: &mut wgpu::RenderPass<'_>, frame_group: &wgpu::BindGroup) {
        let Some(prepared) = &self.prepared else {
            return;
        };
        pass.set_bind_group(0, frame_group, &[]);
        match prepared {
            ParticleDraw::Sprites {
                kind,
                source,
                count,
            } => {
                pass.set_pipeline(self.pipelines.sprites(*kind));
                pass.set_bind_group(1, source, &[]);
                pass.draw(0..QUAD_VERTICES, 0..*count);
            }
            ParticleDraw::Ribbons {
                source,
                rings,
                vertices_per_ring,
                ring_count,
            } => {
                pass.set_pipeline(&self.pipelines.ribbons);
                pass.set_bind_group(1, source, &[]);
                pass.set_bind_group(2, rings, &[]);
                pass.draw(0..*vertices_per_ring, 0..*ring_count);
            }
        }
    }

    /// Uploads host positions and values; whether there are values.
    fn upload_host(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        positions: &[Vec3],
        values: Option<&[f32]>,
    ) -> bool {
        self.positions
            .write(device, queue, bytemuck::cast_slice(positions));
        let source = SourceUniform {
            count: positions.len() as u32,
            position_stride: 3,
            position_offset: 0,
            _pad: 0,
        };
        queue.write_buffer(&self.source_uniform, 0, bytemuck::bytes_of(&source));
        let Some(values) = values else {
            return false;
        };
        assert_eq!(
            values.len(),
            positions.len(),
            "one colour value per particle"
        );
        self.values
            .write(device, queue, bytemuck::cast_slice(values));
        true
    }

    /// Points the source at a simulation's buffers and, if `wants_values`,
    /// records the computation of their colour values; whether there are
    /// values.
    fn bind_device(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        color_by: ColorBy,
        arrays: &ParticleArrays<'_>,
        wants_values: bool,
    ) -> bool {
        let source = SourceUniform {
            count: arrays.count,
            position_stride: arrays.positions.stride,
            position_offset: arrays.positions.offset,
            _pad: 0,
        };
        queue.write_buffer(&self.source_uniform, 0, bytemuck::bytes_of(&source));
        wants_values
            && arrays.count > 0
            && self
                .kernels
                .record(device, queue, encoder, color_by, arrays, &mut self.values)
    }

    /// The draw of this frame's particles in `style`; `None` when there is nothing to draw.
    fn particle_draw(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &DrawFrame<'_>,
        style: DrawStyle,
    ) -> Option<ParticleDraw> {
        let (positions, count) = match frame.particles {
            ParticleSource::Host { positions, .. } => {
                (self.positions.buffer(), positions.len() as u32)
            }
            ParticleSource::Device(arrays) => (arrays.positions.buffer, arrays.count),
        };
        if count == 0 {
            return None;
        }
        let source = bind_buffers(
            device,
            "firn-view particles",
            &self.pipelines.source_layout,
            &[&self.source_uniform, positions, self.values.buffer()],
        );
        match style {
            DrawStyle::Points | DrawStyle::Billboards => Some(ParticleDraw::Sprites {
                kind: if style == DrawStyle::Points {
                    SpriteKind::Points
                } else {
                    SpriteKind::Billboards
                },
                source,
                count,
            }),
            DrawStyle::Trails => self.ribbon_draw(device, queue, frame, source),
        }
    }

    /// The ribbons of the frame's trail rings (uploaded first for a host source).
    fn ribbon_draw(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &DrawFrame<'_>,
        source: wgpu::BindGroup,
    ) -> Option<ParticleDraw> {
        let (rings, points, lengths, ring_count) = match frame.particles {
            ParticleSource::Host {
                trails: Some(trails),
                ..
            } => {
                let uniform = self.upload_host_rings(device, queue, &trails);
                (
                    uniform,
                    self.ring_points.buffer(),
                    self.ring_lengths.buffer(),
                    trails.lengths.len() as u32,
                )
            }
            ParticleSource::Device(ParticleArrays {
                trails:
                    Some(TrailArrays {
                        points,
                        lengths,
                        capacity,
                        head,
                        count,
                    }),
                ..
            }) => {
                let uniform = RingsUniform {
                    capacity,
                    head,
                    _pad: [0; 2],
                };
                (uniform, points, lengths, count)
            }
            _ => return None,
        };
        queue.write_buffer(&self.rings_uniform, 0, bytemuck::bytes_of(&rings));
        let vertices_per_ring = QUAD_VERTICES * rings.capacity.saturating_sub(1);
        if ring_count == 0 || vertices_per_ring == 0 {
            return None;
        }
        let rings = bind_buffers(
            device,
            "firn-view trail rings",
            &self.pipelines.rings_layout,
            &[&self.rings_uniform, points, lengths],
        );
        Some(ParticleDraw::Ribbons {
            source,
            rings,
            vertices_per_ring,
            ring_count,
        })
    }

    /// Uploads host trails, stored oldest first.
    fn upload_host_rings(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        trails: &Trails<'_>,
    ) -> RingsUniform {
        self.ring_points
            .write(device, queue, bytemuck::cast_slice(trails.points));
        self.ring_lengths
            .write(device, queue, bytemuck::cast_slice(trails.lengths));
        RingsUniform {
            capacity: trails.capacity as u32,
            head: NEWEST_LAST,
            _pad: [0; 2],
        }
    }
}

/// The style drawn: trails fall back to billboards without rings (as in firn_render).
fn drawn_style(frame: &DrawFrame<'_>) -> DrawStyle {
    let has_rings = match frame.particles {
        ParticleSource::Host { trails, .. } => trails.is_some(),
        ParticleSource::Device(arrays) => arrays.trails.is_some(),
    };
    match frame.style {
        DrawStyle::Trails if !has_rings => DrawStyle::Billboards,
        style => style,
    }
}

/// Whether the frame colours particles by value: a ramp quantity with a range.
fn wants_values(frame: &DrawFrame<'_>) -> bool {
    let ramp_quantity = matches!(
        frame.color_by,
        ColorBy::Density | ColorBy::PlasticJ | ColorBy::Speed
    );
    ramp_quantity && frame.range.is_some()
}

/// How particles are coloured: by position in `bounds`, by value when there
/// are values and a range, and uniformly otherwise.
fn coloring(frame: &DrawFrame<'_>, has_values: bool, bounds: (Vec3, Vec3)) -> ParticleColoring {
    match (frame.color_by, frame.range) {
        (ColorBy::Position, _) => ParticleColoring::Position {
            min: bounds.0,
            max: bounds.1,
        },
        (ColorBy::Uniform, _) => ParticleColoring::Uniform,
        (_, Some(range)) if has_values => ParticleColoring::Values(range),
        _ => ParticleColoring::Uniform,
    }
}

/// Sprite radius and its smallest size in pixels for `style`.
fn sprite_size(style: DrawStyle, point_radius: f32) -> SpriteSize {
    match style {
        DrawStyle::Billboards => SpriteSize {
            radius: BILLBOARD_RADIUS_PER_POINT_RADIUS * point_radius,
            min_radius_pixels: BILLBOARD_MIN_RADIUS_PIXELS,
        },
        DrawStyle::Points | DrawStyle::Trails => SpriteSize {
            radius: point_radius,
            min_radius_pixels: POINT_MIN_RADIUS_PIXELS,
        },
    }
}
