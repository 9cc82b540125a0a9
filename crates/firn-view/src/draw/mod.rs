//! Drawing a frame with wgpu: the sky, the ground, shaded colliders, the
//! wireframe container and the particles as sphere-shaded points on the
//! bluish ramp, additive billboards or fading trails, matching the look of
//! the offscreen renderer (`firn-render`).
//!
//! Particles come either from the host (a CPU simulation or a cache, uploaded
//! per frame) or straight from a GPU simulation's own buffers on the same
//! device ([`ParticleSource::Device`]), which are never copied back.
//!
//! Targets may have an sRGB format (shaders output linear colours and the
//! target encodes them) or a plain 8-bit one (shaders encode to sRGB
//! themselves; additive styles then add encoded values, slightly brighter
//! than on an sRGB target, so the viewer should prefer an sRGB view).

mod backdrop;
mod capture;
mod frame;
mod geometry;
mod gpu;
mod particle_pipelines;
mod particles;
mod solids;
mod values;
mod wireframe;

pub use capture::capture;
use firn_core::Scene;
use firn_core::scene::ColorBy;
use firn_gpu::draw::ParticleArrays;
use firn_render::ramp::ValueRange;
use firn_render::stage::Stage;
use firn_render::trails::Trails;
use glam::{Mat4, Vec3};

use self::backdrop::Backdrop;
use self::frame::FrameBindings;
use self::gpu::{ColorTarget, DepthTarget};
use self::particles::Particles;
use self::solids::Solids;
use self::wireframe::Wireframe;

/// How particles are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DrawStyle {
    /// Sphere-shaded sprites on the colour ramp.
    Points,
    /// Soft additive sprites.
    Billboards,
    /// Fading lines through each particle's recent positions (flows with trails).
    Trails,
}

/// Where the camera is and what it sees.
#[derive(Clone, Copy, Debug)]
pub struct ViewSetup {
    /// World to clip space (wgpu's depth range 0..1).
    pub view_projection: Mat4,
    /// Camera position in world space.
    pub eye: Vec3,
    /// Vertical field of view in radians.
    pub fov_y_radians: f32,
    /// Target size in pixels.
    pub size: [u32; 2],
}

/// A frame's particles.
#[derive(Clone, Copy, Debug)]
pub enum ParticleSource<'a> {
    /// On the host: uploaded for this frame.
    Host {
        /// Positions.
        positions: &'a [Vec3],
        /// Values of the colour quantity, one per particle (ramp quantities).
        values: Option<&'a [f32]>,
        /// Recent positions per particle.
        trails: Option<Trails<'a>>,
    },
    /// A GPU simulation's own buffers on this device.
    Device(ParticleArrays<'a>),
}

/// Everything one frame draws.
#[derive(Clone, Copy, Debug)]
pub struct DrawFrame<'a> {
    /// The camera.
    pub view: ViewSetup,
    /// How particles are drawn.
    pub style: DrawStyle,
    /// The quantity that colours particles.
    pub color_by: ColorBy,
    /// The value range spanning the ramp (ramp quantities).
    pub range: Option<ValueRange>,
    /// The particles.
    pub particles: ParticleSource<'a>,
    /// Sky, ground, container, colliders where they are now, and the light.
    pub stage: &'a Stage,
    /// Sprite radius in metres.
    pub point_radius: f32,
    /// A snow scene's drift particles (`[wind.spindrift]`), drawn in the
    /// flow's look, as additive billboards, over the snow.
    pub drift: Option<&'a [Vec3]>,
}

/// The pipelines and buffers that draw frames of one scene.
pub struct SceneRenderer {
    frame: FrameBindings,
    depth: DepthTarget,
    backdrop: Backdrop,
    solids: Solids,
    wireframe: Wireframe,
    particles: Particles,
    /// The drift's frame uniforms (its own colouring and sprite size).
    drift_frame: FrameBindings,
    /// The drift particles' pipelines and buffers.
    drift: Particles,
    /// The scene's domain: the box of colour by position when the stage has
    /// no container.
    domain: (Vec3, Vec3),
}

impl SceneRenderer {
    /// Pipelines for targets of `color_format`, and the scene's static
    /// geometry (mesh colliders' triangles, the container). A mesh collider
    /// whose file cannot be read again is not drawn.
    pub fn new(
        device: &wgpu::Device,
        color_format: wgpu::TextureFormat,
        scene: &Scene,
    ) -> SceneRenderer {
        let target = ColorTarget {
            format: color_format,
        };
        let frame = FrameBindings::new(device);
        let layout = frame.layout();
        let drift_frame = FrameBindings::new(device);
        SceneRenderer {
            drift: Particles::new(device, target, drift_frame.layout()),
            drift_frame,
            depth: DepthTarget::new(device, [1, 1]),
            backdrop: Backdrop::new(device, target, layout),
            solids: Solids::new(device, target, layout, scene),
            wireframe: Wireframe::new(device, target, layout),
            particles: Particles::new(device, target, layout),
            frame,
            domain: (scene.domain.min, scene.domain.max),
        }
    }

    /// Records the drawing of `frame` into `target` (cleared first): the
    /// device's colour values of the particles (a compute pass), then the
    /// backdrop, colliders, container, particles and drift (one render
    /// pass).
    /// Uniforms are written through `queue`, so submit `encoder` before
    /// drawing the next frame.
    pub fn draw(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        frame: &DrawFrame<'_>,
    ) {
        let look = self
            .particles
            .prepare(device, queue, encoder, frame, self.domain);
        self.frame
            .write(queue, &frame.view, frame.stage, look.coloring, look.sprites);
        let drift = frame.drift.map(|positions| DrawFrame {
            style: DrawStyle::Billboards,
            color_by: ColorBy::Uniform,
            range: None,
            particles: ParticleSource::Host {
                positions,
                values: None,
                trails: None,
            },
            drift: None,
            ..*frame
        });
        if let Some(drift) = &drift {
            let look = self
                .drift
                .prepare(device, queue, encoder, drift, self.domain);
            self.drift_frame
                .write(queue, &drift.view, drift.stage, look.coloring, look.sprites);
        }
        self.solids.prepare(device, queue, frame.stage);
        self.wireframe.prepare(queue, frame.stage);
        let depth = self.depth.view_for(device, frame.view.size);
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("firn-view scene"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(sky_clear_color(frame.stage)),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let group = self.frame.group();
        self.backdrop.draw(&mut pass, group);
        self.solids.draw(&mut pass, group);
        self.wireframe.draw(&mut pass, group);
        self.particles.draw(&mut pass, group);
        if drift.is_some() {
            self.drift.draw(&mut pass, self.drift_frame.group());
        }
    }
}

/// The clear colour: the top of the sky (the backdrop covers it anyway).
fn sky_clear_color(stage: &Stage) -> wgpu::Color {
    let [r, g, b] = stage.sky_top.to_array().map(f64::from);
    wgpu::Color { r, g, b, a: 1.0 }
}
