//! firn-render: pictures of simulations without a GPU or a display.
//!
//! A [`Picture`] is everything one image shows: a camera, a [`Stage`] (sky,
//! ground, colliders, container) and particles in one [`RenderStyle`].
//! [`render`] turns it into an 8-bit sRGB image on all cores; the result is
//! the same bytes for any thread count. [`scene_view`] builds pictures from a
//! scene and a frame's particles, and [`output`] writes PNGs and animations.
//!
//! - `points` (thesis section 5.7): sphere-shaded, depth-tested sprites with
//!   the bluish ramp.
//! - `volume` (the thesis' future work, chapter 7): a density grid
//!   ray-marched with Beer-Lambert extinction and single scattering.
//! - `surface`: the snow's reconstructed surface mesh, rasterised and shaded
//!   like the colliders.
//!
//! Every style renders 2x2 samples per pixel and averages them (anti-aliasing).

pub mod billboards;
pub mod camera;
pub mod film;
pub mod legend;
pub mod output;
pub mod points;
pub mod ramp;
pub mod scene_view;
pub mod stage;
pub mod surface;
pub mod trails;
pub mod volume;
pub mod wireframe;

use std::borrow::Cow;

pub use camera::CameraView;
pub use firn_core::scene::RenderStyle;
use firn_mesh::TriangleMesh;
use glam::Vec3;
use image::RgbImage;
pub use legend::Legend;
pub use ramp::{Coloring, ValueRange};
pub use stage::{DeformedMesh, Light, Stage, StageCollider};
pub use trails::{RibbonLook, Trails};
pub use volume::{DensityGrid, SnowLook};

use crate::film::Film;

/// Supersampling factor per axis of every style (anti-aliasing).
pub const SUPERSAMPLING: u32 = 2;
/// Width of the container's edges in output pixels.
const EDGE_WIDTH_PIXELS: f32 = 1.3;

/// The particles of one picture.
#[derive(Clone, Debug)]
pub struct ParticleLayer<'a> {
    /// Positions.
    pub positions: &'a [Vec3],
    /// Masses (used by the `volume` style).
    pub masses: Cow<'a, [f32]>,
    /// Colours (used by the `points` style).
    pub coloring: Coloring<'a>,
    /// Sprite radius in metres (`points`) and voxel size scale (`volume`).
    pub radius: f32,
    /// Optical properties (`volume`).
    pub look: SnowLook,
    /// Recent positions per particle (`trails`).
    pub trails: Option<Trails<'a>>,
    /// Draw trails along a uniform cubic B-spline through the positions.
    pub smooth_trails: bool,
    /// The snow's surface (`surface`; without one that style shows the
    /// stage only).
    pub surface: Option<&'a TriangleMesh>,
}

/// Particles drawn over a picture's own in the flow's look (seed 002's
/// billboards): a snow scene's spindrift, in the air beside the snow.
#[derive(Clone, Copy, Debug)]
pub struct DriftLayer<'a> {
    /// Positions.
    pub positions: &'a [Vec3],
    /// Sprite radius in metres.
    pub radius: f32,
    /// Colour each sprite adds at its centre (before the additive intensity).
    pub color: Vec3,
}

/// Everything one image shows.
#[derive(Clone, Debug)]
pub struct Picture<'a> {
    /// The camera, at the output resolution.
    pub camera: CameraView,
    /// How the particles are drawn.
    pub style: RenderStyle,
    /// Sky, ground, colliders, container and light.
    pub stage: Stage,
    /// The particles.
    pub particles: ParticleLayer<'a>,
    /// A colour legend, if wanted.
    pub legend: Option<Legend>,
    /// Drift particles drawn as billboards over the others, in every style.
    pub drift: Option<DriftLayer<'a>>,
}

/// Renders `picture` to an 8-bit sRGB image.
pub fn render(picture: &Picture<'_>) -> RgbImage {
    let mut image = match picture.style {
        RenderStyle::Volume => render_volume(picture),
        RenderStyle::Points => render_points(picture),
        RenderStyle::Billboards | RenderStyle::Trails => render_additive(picture),
        RenderStyle::Surface => render_surface(picture),
    };
    // The volume and surface looks are not coloured by a quantity, so they
    // have no legend.
    if let Some(legend) = &picture.legend
        && !matches!(picture.style, RenderStyle::Volume | RenderStyle::Surface)
    {
        legend::draw_legend(&mut image, legend);
    }
    image
}

/// A supersampled film holding the stage (unshadowed) and the container,
/// ready for particles, with the camera that matches it.
fn staged_film(picture: &Picture<'_>) -> (Film, CameraView) {
    let camera = picture.camera.scaled(SUPERSAMPLING);
    let mut film = Film::new(camera.width, camera.height);
    picture.stage.draw(&mut film, &camera, &|_| 1.0);
    draw_container(&mut film, &camera, &picture.stage, SUPERSAMPLING as f32);
    (film, camera)
}

fn render_points(picture: &Picture<'_>) -> RgbImage {
    let (mut film, camera) = staged_film(picture);
    let particles = &picture.particles;
    points::draw_points(
        &mut film,
        &camera,
        particles.positions,
        &particles.coloring,
        particles.radius,
        &picture.stage.light,
    );
    finish(film, &camera, picture, SUPERSAMPLING)
}

/// Adds the picture's drift onto `film` (a supersampled `factor` times)
/// and resolves it to the output image.
fn finish(mut film: Film, camera: &CameraView, picture: &Picture<'_>, factor: u32) -> RgbImage {
    if let Some(drift) = &picture.drift {
        billboards::draw_billboards(
            &mut film,
            camera,
            drift.positions,
            &Coloring::Uniform(drift.color),
            drift.radius,
            ADDITIVE_INTENSITY,
        );
    }
    film.resolve(factor)
}

fn render_surface(picture: &Picture<'_>) -> RgbImage {
    let (mut film, camera) = staged_film(picture);
    if let Some(mesh) = picture.particles.surface {
        surface::draw_surface(&mut film, &camera, mesh, &picture.stage);
    }
    finish(film, &camera, picture, SUPERSAMPLING)
}

/// Brightness a billboard adds at its centre, and a ribbon at its newest end.
pub const ADDITIVE_INTENSITY: f32 = 0.35;
/// Width of trail ribbons in output pixels.
pub const RIBBON_WIDTH_PIXELS: f32 = 1.6;

/// Billboards, or trails where the picture has them (billboards otherwise),
/// added over the stage.
fn render_additive(picture: &Picture<'_>) -> RgbImage {
    let (mut film, camera) = staged_film(picture);
    let particles = &picture.particles;
    match (&particles.trails, picture.style) {
        (Some(trails), RenderStyle::Trails) => {
            let look = RibbonLook {
                width: RIBBON_WIDTH_PIXELS * SUPERSAMPLING as f32,
                intensity: ADDITIVE_INTENSITY,
                smooth: particles.smooth_trails,
            };
            trails::draw_trails(&mut film, &camera, trails, &particles.coloring, &look);
        }
        _ => billboards::draw_billboards(
            &mut film,
            &camera,
            particles.positions,
            &particles.coloring,
            2.0 * particles.radius,
            ADDITIVE_INTENSITY,
        ),
    }
    finish(film, &camera, picture, SUPERSAMPLING)
}

fn render_volume(picture: &Picture<'_>) -> RgbImage {
    let factor = SUPERSAMPLING;
    let camera = picture.camera.scaled(factor);
    let particles = &picture.particles;
    let mut film = Film::new(camera.width, camera.height);
    let grid = DensityGrid::deposit(
        particles.positions,
        &particles.masses,
        2.0 * particles.radius,
    );
    let light = picture.stage.light;
    let shadow = |point: Vec3| volume::surface_shadow(&grid, &particles.look, &light, point);
    picture.stage.draw(&mut film, &camera, &shadow);
    draw_container(&mut film, &camera, &picture.stage, factor as f32);
    volume::draw_volume(&mut film, &camera, &grid, &particles.look, &light);
    finish(film, &camera, picture, factor)
}

/// Draws the container's edges `scale` times the nominal width (in samples).
fn draw_container(film: &mut Film, camera: &CameraView, stage: &Stage, scale: f32) {
    if let Some((min, max)) = stage.container {
        wireframe::draw_box(film, camera, min, max, EDGE_WIDTH_PIXELS * scale);
    }
}
