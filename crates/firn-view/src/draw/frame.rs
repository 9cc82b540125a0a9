//! What every pass of a frame shares (bind group 0, `frame.wgsl`): the
//! camera, the light, the backdrop, how particles are coloured and sized,
//! and the ramp table.

use bytemuck::{Pod, Zeroable};
use firn_render::ramp::{ValueRange, ramp};
use firn_render::stage::{GROUND_ALBEDO, Stage};
use firn_render::wireframe::EDGE_COLOR;
use glam::Vec3;

use super::ViewSetup;
use super::gpu::{bind_buffers, fill_at_creation, uniform_buffer, uniform_entry};

/// Samples of the ramp in the table (`RAMP_SAMPLES` in `frame.wgsl`): 64
/// intervals, so a ramp whose stops split [0, 1] into 2, 4, 8, ... equal
/// parts is reproduced exactly by linear interpolation.
const RAMP_SAMPLES: usize = 65;

/// The camera (`Camera` in `frame.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct CameraUniform {
    view_projection: [[f32; 4]; 4],
    inverse_view_projection: [[f32; 4]; 4],
    eye: [f32; 3],
    pixel_size: f32,
    right: [f32; 3],
    viewport_width: f32,
    up: [f32; 3],
    viewport_height: f32,
    forward: [f32; 3],
    _pad: f32,
}

/// The light (`Light` in `frame.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct LightUniform {
    direction: [f32; 3],
    _pad0: f32,
    color: [f32; 3],
    _pad1: f32,
    ambient: [f32; 3],
    _pad2: f32,
}

/// Sky, ground and container edges (`Backdrop` in `frame.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct BackdropUniform {
    sky_top: [f32; 3],
    ground_height: f32,
    sky_bottom: [f32; 3],
    ground_tile: f32,
    ground_albedo: [f32; 2],
    fog_start: f32,
    fog_span: f32,
    edge_color: [f32; 3],
    _pad: f32,
}

/// How particles are coloured (`Coloring` in `frame.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ColoringUniform {
    uniform_color: [f32; 3],
    mode: u32,
    box_min: [f32; 3],
    range_low: f32,
    box_max: [f32; 3],
    range_high: f32,
}

/// Sprite and ribbon sizes (`Sprites` in `frame.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SpritesUniform {
    radius: f32,
    min_radius_pixels: f32,
    intensity: f32,
    ribbon_width_pixels: f32,
}

/// Everything in group 0's uniform buffer (`Frame` in `frame.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct FrameUniform {
    camera: CameraUniform,
    light: LightUniform,
    backdrop: BackdropUniform,
    coloring: ColoringUniform,
    sprites: SpritesUniform,
}

/// How this frame's particles get their colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum ParticleColoring {
    /// Each particle's value on the ramp.
    Values(ValueRange),
    /// Distance from the box centre per axis as RGB (`Coloring::Position`).
    Position {
        /// Lower corner of the box.
        min: Vec3,
        /// Upper corner of the box.
        max: Vec3,
    },
    /// The ramp's colour at 0.72 for every particle.
    Uniform,
}

/// Colour modes (`COLOR_BY_VALUE`, ... in `frame.wgsl`).
const COLOR_BY_VALUE: u32 = 0;
const COLOR_BY_POSITION: u32 = 1;
const COLOR_UNIFORM: u32 = 2;

/// Where the ramp puts particles that all share one colour.
const UNIFORM_RAMP_POSITION: f32 = 0.72;

impl ParticleColoring {
    fn uniform(self) -> ColoringUniform {
        let (mode, range, (box_min, box_max)) = match self {
            ParticleColoring::Values(range) => (COLOR_BY_VALUE, range, (Vec3::ZERO, Vec3::ONE)),
            ParticleColoring::Position { min, max } => {
                (COLOR_BY_POSITION, UNUSED_RANGE, (min, max))
            }
            ParticleColoring::Uniform => (COLOR_UNIFORM, UNUSED_RANGE, (Vec3::ZERO, Vec3::ONE)),
        };
        ColoringUniform {
            uniform_color: ramp(UNIFORM_RAMP_POSITION).to_array(),
            mode,
            box_min: box_min.to_array(),
            range_low: range.low,
            box_max: box_max.to_array(),
            range_high: range.high,
        }
    }
}

/// The range sent when colours do not come from values.
const UNUSED_RANGE: ValueRange = ValueRange {
    low: 0.0,
    high: 1.0,
};

/// Sprite sizes of one frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct SpriteSize {
    /// Radius in metres.
    pub(super) radius: f32,
    /// Smallest radius in pixels.
    pub(super) min_radius_pixels: f32,
}

/// The uniforms of group 0 and their bind group.
pub(super) struct FrameBindings {
    layout: wgpu::BindGroupLayout,
    uniform: wgpu::Buffer,
    group: wgpu::BindGroup,
}

impl FrameBindings {
    /// The layout, buffers and bind group, with the ramp table filled once.
    pub(super) fn new(device: &wgpu::Device) -> FrameBindings {
        let stages = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("firn-view frame"),
            entries: &[uniform_entry(0, stages), uniform_entry(1, stages)],
        });
        let uniform = uniform_buffer(device, "firn-view frame", &FrameUniform::zeroed());
        let ramp_table = fill_at_creation(
            device,
            "firn-view ramp",
            wgpu::BufferUsages::UNIFORM,
            bytemuck::cast_slice(&ramp_table()),
        );
        let group = bind_buffers(device, "firn-view frame", &layout, &[&uniform, &ramp_table]);
        FrameBindings {
            layout,
            uniform,
            group,
        }
    }

    /// The layout of group 0.
    pub(super) fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// The bind group of group 0.
    pub(super) fn group(&self) -> &wgpu::BindGroup {
        &self.group
    }

    /// Writes this frame's uniforms.
    pub(super) fn write(
        &self,
        queue: &wgpu::Queue,
        view: &ViewSetup,
        stage: &Stage,
        coloring: ParticleColoring,
        sprites: SpriteSize,
    ) {
        let uniform = FrameUniform {
            camera: camera_uniform(view),
            light: LightUniform {
                direction: stage.light.direction.to_array(),
                color: stage.light.color.to_array(),
                ambient: stage.light.ambient.to_array(),
                ..LightUniform::zeroed()
            },
            backdrop: backdrop_uniform(stage, view.eye),
            coloring: coloring.uniform(),
            sprites: SpritesUniform {
                radius: sprites.radius,
                min_radius_pixels: sprites.min_radius_pixels,
                intensity: firn_render::ADDITIVE_INTENSITY,
                ribbon_width_pixels: firn_render::RIBBON_WIDTH_PIXELS,
            },
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
    }
}

/// The ramp sampled evenly from 0 to 1, padded to `vec4`s.
fn ramp_table() -> Vec<[f32; 4]> {
    (0..RAMP_SAMPLES)
        .map(|index| {
            ramp(index as f32 / (RAMP_SAMPLES - 1) as f32)
                .extend(1.0)
                .to_array()
        })
        .collect()
}

/// The camera's matrices, its axes in world space (recovered from the
/// view-projection matrix) and the pixel footprint.
fn camera_uniform(view: &ViewSetup) -> CameraUniform {
    let inverse = view.view_projection.inverse();
    let unproject = |x: f32, y: f32| inverse.project_point3(Vec3::new(x, y, 0.5));
    let center = unproject(0.0, 0.0);
    let forward = (center - view.eye).normalize();
    let right = (unproject(1.0, 0.0) - center).normalize();
    let up = right.cross(forward).normalize();
    let [width, height] = view.size.map(|extent| extent.max(1) as f32);
    CameraUniform {
        view_projection: view.view_projection.to_cols_array_2d(),
        inverse_view_projection: inverse.to_cols_array_2d(),
        eye: view.eye.to_array(),
        pixel_size: 2.0 * (0.5 * view.fov_y_radians).tan() / height,
        right: right.to_array(),
        viewport_width: width,
        up: up.to_array(),
        viewport_height: height,
        forward: forward.to_array(),
        _pad: 0.0,
    }
}

/// Sky, ground and edge colours; a ground tile of 0 means no ground.
fn backdrop_uniform(stage: &Stage, eye: Vec3) -> BackdropUniform {
    let (fog_start, fog_span) = stage.fog_range(eye);
    BackdropUniform {
        sky_top: stage.sky_top.to_array(),
        ground_height: stage.ground.unwrap_or(0.0),
        sky_bottom: stage.sky_bottom.to_array(),
        ground_tile: if stage.ground.is_some() {
            stage.ground_tile()
        } else {
            0.0
        },
        ground_albedo: GROUND_ALBEDO,
        // WGSL has no infinity: a start beyond any distance means no fog.
        fog_start: fog_start.min(f32::MAX),
        fog_span,
        edge_color: EDGE_COLOR.to_array(),
        _pad: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use glam::camera::rh::{proj, view};

    use super::*;

    #[test]
    fn uniform_layout_matches_the_wgsl_struct() {
        // Camera 192, Light 48, Backdrop 64, Coloring 48, Sprites 16.
        assert_eq!(size_of::<FrameUniform>(), 368);
    }

    #[test]
    fn camera_axes_come_back_from_the_matrix() {
        let eye = Vec3::new(0.0, 1.0, 5.0);
        let view = view::look_at_mat4(eye, Vec3::new(0.0, 1.0, 0.0), Vec3::Y);
        let projection = proj::directx::perspective(0.8, 1.5, 0.1, 100.0);
        let camera = camera_uniform(&ViewSetup {
            view_projection: projection * view,
            eye,
            fov_y_radians: 0.8,
            size: [150, 100],
        });
        let close = |a: [f32; 3], b: Vec3| (Vec3::from(a) - b).length() < 1e-4;
        assert!(close(camera.forward, Vec3::NEG_Z));
        assert!(close(camera.right, Vec3::X));
        assert!(close(camera.up, Vec3::Y));
    }

    #[test]
    fn ramp_table_reproduces_the_ramp() {
        let table = ramp_table();
        for step in 0..=40 {
            let t = step as f32 / 40.0;
            let scaled = t * (RAMP_SAMPLES - 1) as f32;
            let index = (scaled.floor() as usize).min(RAMP_SAMPLES - 2);
            let s = scaled - index as f32;
            let sampled =
                Vec3::from_slice(&table[index]).lerp(Vec3::from_slice(&table[index + 1]), s);
            assert!((sampled - ramp(t)).length() < 1e-5, "t = {t}");
        }
    }
}
