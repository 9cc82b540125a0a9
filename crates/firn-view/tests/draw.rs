//! The viewer's drawing module on a real device (lavapipe in CI): frames are
//! rendered offscreen, read back and checked pixel by pixel, against the
//! offscreen CPU renderer where the two must agree.

use std::borrow::Cow;
use std::sync::Arc;

use firn_core::Scene;
use firn_core::scene::{ColliderGeometry, ColorBy};
use firn_gpu::GpuContext;
use firn_gpu::draw::{ParticleArrays, SnowArrays, StridedArray, TrailArrays};
use firn_render::film::encode_srgb;
use firn_render::ramp::{Coloring, ValueRange};
use firn_render::stage::Stage;
use firn_render::trails::Trails;
use firn_render::{CameraView, ParticleLayer, Picture, RenderStyle, SnowLook};
use firn_view::draw::{DrawFrame, DrawStyle, ParticleSource, SceneRenderer, ViewSetup, capture};
use glam::camera::rh::{proj, view};
use glam::{Vec2, Vec3};
use image::RgbaImage;
use wgpu::util::DeviceExt;

const WIDTH: u32 = 160;
const HEIGHT: u32 = 120;
const FOV_DEGREES: f32 = 40.0;
const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// Rest density of the test snow, and the ramp range around it.
const REST_DENSITY: f32 = 400.0;
const DENSITY_RANGE: ValueRange = ValueRange {
    low: 0.25 * REST_DENSITY,
    high: 1.25 * REST_DENSITY,
};

fn context() -> Option<Arc<GpuContext>> {
    firn_gpu::context_for_tests()
}

/// A scene in the unit cube with a little snow (its particles are not
/// drawn: the tests bring their own).
const SCENE_TOML: &str = "format = 1\nname = \"draw-test\"\n[domain]\nmax = [1.0, 1.0, 1.0]\ncell_size = 0.05\n\
    [time]\nduration = 1.0\n[[bodies]]\nshape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\nradius = 0.1\n";

fn scene() -> Scene {
    Scene::from_toml_str(SCENE_TOML, "draw test").expect("the test scene parses")
}

/// The camera every test looks through, the CPU renderer's and the viewer's.
struct Camera {
    eye: Vec3,
    look_at: Vec3,
}

const FRONT: Camera = Camera {
    eye: Vec3::new(0.5, 0.5, 3.2),
    look_at: Vec3::new(0.5, 0.5, 0.5),
};

impl Camera {
    fn view(&self) -> ViewSetup {
        let fov = FOV_DEGREES.to_radians();
        let projection = proj::directx::perspective(fov, WIDTH as f32 / HEIGHT as f32, 0.05, 50.0);
        ViewSetup {
            view_projection: projection * view::look_at_mat4(self.eye, self.look_at, Vec3::Y),
            eye: self.eye,
            fov_y_radians: fov,
            size: [WIDTH, HEIGHT],
        }
    }

    fn cpu(&self) -> CameraView {
        CameraView::look_at(self.eye, self.look_at, FOV_DEGREES, WIDTH, HEIGHT)
    }

    /// The pixel `point` projects to.
    fn pixel(&self, point: Vec3) -> Vec2 {
        self.cpu()
            .project(point)
            .expect("in front of the camera")
            .pixel
    }
}

/// A stage with the unit container, no ground, and `colliders`.
fn stage(colliders: Vec<ColliderGeometry>) -> Stage {
    Stage {
        container: Some((Vec3::ZERO, Vec3::ONE)),
        colliders: colliders.into_iter().map(Into::into).collect(),
        ..Stage::default()
    }
}

/// Particles on a cubic lattice of `spacing` inside a ball.
fn ball(center: Vec3, radius: f32, spacing: f32) -> Vec<Vec3> {
    let steps = (radius / spacing).ceil() as i32;
    let mut points = Vec::new();
    for i in -steps..=steps {
        for j in -steps..=steps {
            for k in -steps..=steps {
                let offset = Vec3::new(i as f32, j as f32, k as f32) * spacing;
                if offset.length() <= radius {
                    points.push(center + offset);
                }
            }
        }
    }
    points
}

/// A frame of `particles` seen through `FRONT`.
fn frame<'a>(
    stage: &'a Stage,
    style: DrawStyle,
    color_by: ColorBy,
    particles: ParticleSource<'a>,
) -> DrawFrame<'a> {
    DrawFrame {
        view: FRONT.view(),
        style,
        color_by,
        range: Some(DENSITY_RANGE),
        particles,
        stage,
        point_radius: 0.012,
        drift: None,
    }
}

/// Draws `frame` into a new `format` target and reads it back.
fn render_as(
    context: &GpuContext,
    scene: &Scene,
    format: wgpu::TextureFormat,
    frame: &DrawFrame<'_>,
) -> RgbaImage {
    let (device, queue) = (&context.device, &context.queue);
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("draw test target"),
        size: wgpu::Extent3d {
            width: WIDTH,
            height: HEIGHT,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
    let mut renderer = SceneRenderer::new(device, format, scene);
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
    renderer.draw(device, queue, &mut encoder, &view, frame);
    queue.submit([encoder.finish()]);
    capture(device, queue, &texture)
}

fn render(context: &GpuContext, frame: &DrawFrame<'_>) -> RgbaImage {
    render_as(context, &scene(), FORMAT, frame)
}

fn save(image: &RgbaImage, name: &str) {
    let path = std::env::temp_dir().join(format!("firn-draw-{name}.png"));
    image.save(&path).expect("the PNG is written");
}

fn rgb_at(image: &RgbaImage, pixel: Vec2) -> [u8; 3] {
    let p = image.get_pixel(pixel.x as u32, pixel.y as u32).0;
    [p[0], p[1], p[2]]
}

fn distance(a: [u8; 3], b: [u8; 3]) -> u8 {
    (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0)
}

/// The sky's encoded colour on row `y`.
fn sky_at(stage: &Stage, y: u32) -> [u8; 3] {
    encode_srgb(stage.sky(y as f32 + 0.5, HEIGHT as f32))
}

fn brightness_of(rgb: [u8; 3]) -> u32 {
    rgb.map(u32::from).iter().sum()
}

fn brightness_at(image: &RgbaImage, pixel: Vec2) -> u32 {
    brightness_of(rgb_at(image, pixel))
}

/// The largest difference of any channel of any pixel.
fn largest_difference(a: &RgbaImage, b: &RgbaImage) -> u8 {
    a.pixels()
        .zip(b.pixels())
        .flat_map(|(p, q)| (0..3).map(move |c| p.0[c].abs_diff(q.0[c])))
        .max()
        .unwrap_or(0)
}

/// Whether some pixel within one of `pixel` has about `color`.
fn near_pixel_has(image: &RgbaImage, pixel: Vec2, color: [u8; 3], tolerance: u8) -> bool {
    (-1..=1).any(|dy| {
        (-1..=1).any(|dx| {
            distance(
                rgb_at(image, pixel + Vec2::new(dx as f32, dy as f32)),
                color,
            ) <= tolerance
        })
    })
}

#[test]
fn host_points_show_bluish_snow_the_sky_the_container_and_a_shaded_sphere() {
    let Some(context) = context() else { return };
    let collider_center = Vec3::new(0.85, 0.2, 0.5);
    let stage = stage(vec![ColliderGeometry::Sphere {
        center: collider_center,
        radius: 0.1,
    }]);
    let positions = ball(Vec3::splat(0.5), 0.15, 0.02);
    let values = vec![REST_DENSITY; positions.len()];
    let particles = ParticleSource::Host {
        positions: &positions,
        values: Some(&values),
        trails: None,
    };
    let image = render(
        &context,
        &frame(&stage, DrawStyle::Points, ColorBy::Density, particles),
    );
    save(&image, "points");

    let [r, g, b] = rgb_at(&image, FRONT.pixel(Vec3::splat(0.5)));
    assert!(
        b > r + 40 && b >= g,
        "bluish snow at the centre: {:?}",
        [r, g, b]
    );
    for (x, y) in [
        (0, 0),
        (WIDTH - 1, 0),
        (0, HEIGHT - 1),
        (WIDTH - 1, HEIGHT - 1),
    ] {
        let corner = rgb_at(&image, Vec2::new(x as f32, y as f32));
        assert!(
            distance(corner, sky_at(&stage, y)) <= 1,
            "sky at ({x}, {y}): {corner:?}"
        );
    }
    let edge = FRONT.pixel(Vec3::new(0.25, 1.0, 1.0));
    let edge_color = encode_srgb(firn_render::wireframe::EDGE_COLOR);
    assert!(
        near_pixel_has(&image, edge, edge_color, 2),
        "container edge at {edge}"
    );

    // The sphere is shaded like the CPU renderer's at its middle.
    let cpu = cpu_render(&stage, &[], RenderStyle::Points);
    let middle = FRONT.pixel(collider_center);
    let [r, g, b] = rgb_at(&image, middle);
    assert!(r > g + 30 && r > b + 30, "collider albedo: {:?}", [r, g, b]);
    assert!(
        distance([r, g, b], cpu_rgb_at(&cpu, middle)) <= 3,
        "shading as on the CPU"
    );
}

/// The CPU renderer's picture of `stage` and `positions` (coloured by position).
fn cpu_render(stage: &Stage, positions: &[Vec3], style: RenderStyle) -> image::RgbImage {
    firn_render::render(&Picture {
        camera: FRONT.cpu(),
        style,
        stage: stage.clone(),
        particles: ParticleLayer {
            positions,
            masses: Cow::Owned(vec![1.0; positions.len()]),
            coloring: Coloring::Position {
                min: Vec3::ZERO,
                max: Vec3::ONE,
            },
            radius: 0.1,
            look: SnowLook::for_density(REST_DENSITY, 0.01),
            trails: None,
            smooth_trails: false,
            surface: None,
        },
        legend: None,
        drift: None,
    })
}

/// Whether no neighbour of pixel (x, y) differs from it by more than a few levels.
fn is_smooth(image: &image::RgbImage, x: u32, y: u32) -> bool {
    let center = image.get_pixel(x, y).0;
    (y - 1..=y + 1)
        .all(|ny| (x - 1..=x + 1).all(|nx| distance(image.get_pixel(nx, ny).0, center) <= 6))
}

fn cpu_rgb_at(image: &image::RgbImage, pixel: Vec2) -> [u8; 3] {
    image.get_pixel(pixel.x as u32, pixel.y as u32).0
}

#[test]
fn the_stage_and_large_points_look_as_the_cpu_renderer_draws_them() {
    let Some(context) = context() else { return };
    let mut stage = stage(vec![
        ColliderGeometry::Sphere {
            center: Vec3::new(0.8, 0.25, 0.5),
            radius: 0.12,
        },
        ColliderGeometry::Box {
            center: Vec3::new(0.2, 0.2, 0.5),
            size: Vec3::new(0.2, 0.3, 0.2),
        },
        ColliderGeometry::HalfPlane {
            point: Vec3::new(0.0, 0.0, 0.1),
            normal: Vec3::Z,
        },
    ]);
    stage.ground = Some(0.0);
    let positions = [Vec3::new(0.35, 0.75, 0.6), Vec3::new(0.7, 0.7, 0.6)];
    let particles = ParticleSource::Host {
        positions: &positions,
        values: None,
        trails: None,
    };
    let mut gpu_frame = frame(&stage, DrawStyle::Points, ColorBy::Position, particles);
    gpu_frame.point_radius = 0.1;
    let image = render(&context, &gpu_frame);
    save(&image, "stage");
    let cpu = cpu_render(&stage, &positions, RenderStyle::Points);
    // Edges differ (the CPU renderer supersamples): compare where the CPU
    // picture is smooth.
    let smooth: Vec<(u32, u32)> = (1..HEIGHT - 1)
        .flat_map(|y| (1..WIDTH - 1).map(move |x| (x, y)))
        .filter(|&(x, y)| is_smooth(&cpu, x, y))
        .collect();
    let differing = smooth
        .iter()
        .filter(|&&(x, y)| {
            let gpu = image.get_pixel(x, y).0;
            distance([gpu[0], gpu[1], gpu[2]], cpu.get_pixel(x, y).0) > 3
        })
        .count();
    assert!(
        smooth.len() > (WIDTH * HEIGHT / 2) as usize && differing * 100 < smooth.len(),
        "{differing} of {} smooth pixels differ from the CPU picture",
        smooth.len()
    );
    for point in positions {
        let pixel = FRONT.pixel(point);
        assert!(
            distance(rgb_at(&image, pixel), cpu_rgb_at(&cpu, pixel)) <= 4,
            "point at {pixel}"
        );
    }
}

/// Host particles' snow state in the strided layouts of a GPU snow
/// simulation: position and mass in one vec4 record, velocity and V⁰ in
/// another, F_E as three padded columns, J_P in a two-word record.
struct DeviceSnow {
    position_mass: wgpu::Buffer,
    velocity_volume: wgpu::Buffer,
    elastic: wgpu::Buffer,
    plastic: wgpu::Buffer,
    count: u32,
}

/// The test snow's state of particle `i`: mass, V⁰, F_E (columns), J_P, velocity.
struct SnowState {
    mass: f32,
    volume0: f32,
    elastic: [Vec3; 3],
    plastic_j: f32,
    velocity: Vec3,
}

fn snow_state(i: usize) -> SnowState {
    let wave = (i as f32 * 0.37).sin();
    SnowState {
        mass: 0.0032 * (1.0 + 0.3 * wave),
        volume0: 8e-6,
        elastic: [
            Vec3::new(1.0 + 0.1 * wave, 0.02, 0.0),
            Vec3::new(0.0, 0.95, 0.01),
            Vec3::new(0.03, 0.0, 1.05),
        ],
        plastic_j: 0.9 + 0.2 * (i as f32 * 0.11).cos(),
        velocity: Vec3::new(wave, 2.0 * wave, -0.5) * 3.0,
    }
}

impl SnowState {
    fn density(&self) -> f32 {
        let f = glam::Mat3::from_cols(self.elastic[0], self.elastic[1], self.elastic[2]);
        self.mass / (self.volume0 * f.determinant() * self.plastic_j)
    }
}

fn storage(device: &wgpu::Device, words: &[f32]) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("test simulation array"),
        contents: bytemuck::cast_slice(words),
        usage: wgpu::BufferUsages::STORAGE,
    })
}

impl DeviceSnow {
    fn new(device: &wgpu::Device, positions: &[Vec3]) -> DeviceSnow {
        let states: Vec<SnowState> = (0..positions.len()).map(snow_state).collect();
        let position_mass: Vec<f32> = positions
            .iter()
            .zip(&states)
            .flat_map(|(p, s)| [p.x, p.y, p.z, s.mass])
            .collect();
        let velocity_volume: Vec<f32> = states
            .iter()
            .flat_map(|s| [s.velocity.x, s.velocity.y, s.velocity.z, s.volume0])
            .collect();
        let elastic: Vec<f32> = states
            .iter()
            .flat_map(|s| {
                s.elastic
                    .iter()
                    .flat_map(|column| [column.x, column.y, column.z, 0.0])
            })
            .collect();
        let plastic: Vec<f32> = states.iter().flat_map(|s| [-1.0, s.plastic_j]).collect();
        DeviceSnow {
            position_mass: storage(device, &position_mass),
            velocity_volume: storage(device, &velocity_volume),
            elastic: storage(device, &elastic),
            plastic: storage(device, &plastic),
            count: positions.len() as u32,
        }
    }

    fn arrays(&self) -> ParticleArrays<'_> {
        let strided = |buffer, stride, offset| StridedArray {
            buffer,
            stride,
            offset,
        };
        ParticleArrays {
            count: self.count,
            positions: strided(&self.position_mass, 4, 0),
            velocities: strided(&self.velocity_volume, 4, 0),
            snow: Some(SnowArrays {
                mass: strided(&self.position_mass, 4, 3),
                volume0: strided(&self.velocity_volume, 4, 3),
                elastic: strided(&self.elastic, 12, 0),
                plastic_j: strided(&self.plastic, 2, 1),
            }),
            trails: None,
        }
    }
}

/// Host values of `color_by` for the test snow.
fn host_values(color_by: ColorBy, count: usize) -> Vec<f32> {
    (0..count)
        .map(snow_state)
        .map(|s| match color_by {
            ColorBy::Density => s.density(),
            ColorBy::PlasticJ => s.plastic_j,
            _ => s.velocity.length(),
        })
        .collect()
}

#[test]
fn device_particles_look_the_same_as_host_particles() {
    let Some(context) = context() else { return };
    let stage = stage(Vec::new());
    let positions = ball(Vec3::splat(0.5), 0.2, 0.025);
    let snow = DeviceSnow::new(&context.device, &positions);
    let ranges = [
        (ColorBy::Density, DENSITY_RANGE),
        (
            ColorBy::PlasticJ,
            ValueRange {
                low: 1.25,
                high: 0.75,
            },
        ),
        (
            ColorBy::Speed,
            ValueRange {
                low: 0.0,
                high: 10.0,
            },
        ),
    ];
    for (color_by, range) in ranges {
        let values = host_values(color_by, positions.len());
        let host = ParticleSource::Host {
            positions: &positions,
            values: Some(&values),
            trails: None,
        };
        let mut host_frame = frame(&stage, DrawStyle::Points, color_by, host);
        host_frame.range = Some(range);
        // Sprites overlap into a closed surface.
        host_frame.point_radius = 0.016;
        let device_frame = DrawFrame {
            particles: ParticleSource::Device(snow.arrays()),
            ..host_frame
        };
        let (host_image, device_image) = (
            render(&context, &host_frame),
            render(&context, &device_frame),
        );
        if color_by == ColorBy::Density {
            save(&device_image, "device-points");
        }
        let difference = largest_difference(&host_image, &device_image);
        assert!(
            difference <= 1,
            "{color_by:?}: host and device differ by {difference}"
        );
        // The snow is drawn, and its values vary: equal pictures are not two empty or uniform ones.
        let center = FRONT.pixel(Vec3::splat(0.5));
        let colors: std::collections::HashSet<[u8; 3]> = (-8..=8)
            .flat_map(|dy| (-8..=8).map(move |dx| center + Vec2::new(dx as f32, dy as f32)))
            .map(|pixel| rgb_at(&device_image, pixel))
            .collect();
        assert!(
            colors.len() > 40,
            "{color_by:?}: {} colours in the snow",
            colors.len()
        );
        let sky = sky_at(&stage, center.y as u32);
        assert!(
            distance(rgb_at(&device_image, center), sky) > 20,
            "{color_by:?}: snow at the centre"
        );
    }
}

#[test]
fn billboards_add_up_where_particles_are_dense() {
    let Some(context) = context() else { return };
    let stage = stage(Vec::new());
    let single = Vec3::new(0.25, 0.5, 0.5);
    let crowd = Vec3::new(0.75, 0.5, 0.5);
    let mut positions = vec![single];
    positions.extend((0..12).map(|i| crowd + Vec3::new(0.0, 0.0, 0.002 * i as f32)));
    let particles = ParticleSource::Host {
        positions: &positions,
        values: None,
        trails: None,
    };
    let mut billboards = frame(&stage, DrawStyle::Billboards, ColorBy::Uniform, particles);
    billboards.point_radius = 0.04;
    let image = render(&context, &billboards);
    let brightness = |point: Vec3| brightness_at(&image, FRONT.pixel(point));
    let sky = brightness_of(sky_at(&stage, HEIGHT / 2));
    assert!(brightness(single) > sky + 30, "one sprite adds light");
    assert!(
        brightness(crowd) > brightness(single) + 100,
        "twelve sprites add more"
    );

    let ball = ball(Vec3::splat(0.5), 0.2, 0.025);
    let ball_particles = ParticleSource::Host {
        positions: &ball,
        values: None,
        trails: None,
    };
    save(
        &render(
            &context,
            &frame(
                &stage,
                DrawStyle::Billboards,
                ColorBy::Position,
                ball_particles,
            ),
        ),
        "billboards",
    );
}

/// Rings of `capacity` points per particle: particle p's trail runs from
/// x = 0.15 to 0.85 at height `0.3 + 0.1 p`, oldest at the left.
fn trail_points(particles: usize, capacity: usize) -> Vec<Vec<Vec3>> {
    (0..particles)
        .map(|p| {
            (0..capacity)
                .map(|i| {
                    Vec3::new(
                        0.15 + 0.7 * i as f32 / (capacity - 1) as f32,
                        0.3 + 0.1 * p as f32,
                        0.5,
                    )
                })
                .collect()
        })
        .collect()
}

#[test]
fn trails_draw_fading_lines_between_ring_points_from_host_and_device() {
    let Some(context) = context() else { return };
    let stage = stage(Vec::new());
    let (count, capacity) = (5, 8);
    let rings = trail_points(count, capacity);
    let oldest_first: Vec<Vec3> = rings.iter().flatten().copied().collect();
    let lengths = vec![capacity as u32; count];
    let newest: Vec<Vec3> = rings.iter().map(|ring| ring[capacity - 1]).collect();
    let host = ParticleSource::Host {
        positions: &newest,
        values: None,
        trails: Some(Trails {
            points: &oldest_first,
            capacity,
            lengths: &lengths,
        }),
    };
    let host_frame = frame(&stage, DrawStyle::Trails, ColorBy::Position, host);
    let image = render(&context, &host_frame);
    save(&image, "trails");

    // The line may fall between two rows of pixels: take the brighter.
    let brightness = |point: Vec3| {
        let pixel = FRONT.pixel(point);
        [-1.0, 0.0]
            .map(|dy| brightness_at(&image, pixel + Vec2::new(0.0, dy)))
            .into_iter()
            .max()
            .unwrap_or(0)
    };
    let sky = brightness_of(sky_at(&stage, HEIGHT / 2));
    let along = |x: f32| Vec3::new(x, 0.5, 0.5);
    assert!(brightness(along(0.8)) > sky + 30, "the new end is drawn");
    assert!(
        brightness(along(0.8)) > brightness(along(0.25)) + 30,
        "the old end fades"
    );
    assert!(
        brightness_at(&image, FRONT.pixel(Vec3::new(0.5, 0.55, 0.5))) < sky + 6,
        "nothing between trails"
    );

    // The same rings on the device, rotated so that the newest point sits at slot `head`.
    let head = 3;
    let ring_words: Vec<f32> = rings
        .iter()
        .flat_map(|ring| {
            (0..capacity).map(move |slot| ring[(slot + capacity - head - 1) % capacity])
        })
        .flat_map(|p| p.to_array())
        .collect();
    let device = &context.device;
    let positions: Vec<f32> = newest.iter().flat_map(|p| p.to_array()).collect();
    let (positions, velocities) = (storage(device, &positions), storage(device, &positions));
    let (points, lengths) = (
        storage(device, &ring_words),
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("test trail lengths"),
            contents: bytemuck::cast_slice(&lengths),
            usage: wgpu::BufferUsages::STORAGE,
        }),
    );
    let strided = |buffer| StridedArray {
        buffer,
        stride: 3,
        offset: 0,
    };
    let device_frame = DrawFrame {
        particles: ParticleSource::Device(ParticleArrays {
            count: count as u32,
            positions: strided(&positions),
            velocities: strided(&velocities),
            snow: None,
            trails: Some(TrailArrays {
                points: &points,
                lengths: &lengths,
                capacity: capacity as u32,
                head: head as u32,
                count: count as u32,
            }),
        }),
        ..host_frame
    };
    let difference = largest_difference(&image, &render(&context, &device_frame));
    assert!(
        difference <= 1,
        "host and device trails differ by {difference}"
    );
}

#[test]
fn bgra_and_non_srgb_targets_read_back_as_the_same_picture() {
    let Some(context) = context() else { return };
    let stage = stage(vec![ColliderGeometry::Sphere {
        center: Vec3::new(0.8, 0.3, 0.5),
        radius: 0.1,
    }]);
    let positions = ball(Vec3::splat(0.5), 0.15, 0.02);
    let particles = ParticleSource::Host {
        positions: &positions,
        values: None,
        trails: None,
    };
    let points = frame(&stage, DrawStyle::Points, ColorBy::Position, particles);
    let scene = scene();
    let reference = render_as(&context, &scene, FORMAT, &points);
    let bgra = render_as(
        &context,
        &scene,
        wgpu::TextureFormat::Bgra8UnormSrgb,
        &points,
    );
    assert_eq!(largest_difference(&reference, &bgra), 0);
    let unorm = render_as(&context, &scene, wgpu::TextureFormat::Bgra8Unorm, &points);
    let difference = largest_difference(&reference, &unorm);
    assert!(
        difference <= 1,
        "encoded in the shader: differs by {difference}"
    );
}

/// A closed cube of edge 1 centred at the origin, as an OBJ file.
const CUBE_OBJ: &str = "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5\n\
v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n\
f 1 4 3\nf 1 3 2\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 4 8 7\nf 4 7 3\nf 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6\n";

#[test]
fn a_mesh_collider_is_drawn_where_its_centre_is_now() {
    let Some(context) = context() else { return };
    let folder = tempfile::tempdir().expect("a temporary folder");
    std::fs::write(folder.path().join("cube.obj"), CUBE_OBJ).expect("the mesh is written");
    let toml = format!(
        "{SCENE_TOML}[[colliders]]\nshape = \"mesh\"\nmesh = \"cube.obj\"\nsdf_spacing = 0.02\n\
         scale = 0.2\ncenter = [0.3, 0.3, 0.5]\n"
    );
    let path = folder.path().join("scene.toml");
    std::fs::write(&path, toml).expect("the scene is written");
    let scene = Scene::load(&path).expect("the mesh scene loads");
    let mut moved = scene.colliders[0].geometry.clone();
    let ColliderGeometry::Mesh(mesh) = &mut moved else {
        panic!("a mesh collider");
    };
    let (start, now) = (mesh.center, Vec3::new(0.7, 0.6, 0.5));
    mesh.center = now;
    let stage = stage(vec![moved]);
    let particles = ParticleSource::Host {
        positions: &[],
        values: None,
        trails: None,
    };
    let image = render_as(
        &context,
        &scene,
        FORMAT,
        &frame(&stage, DrawStyle::Points, ColorBy::Uniform, particles),
    );
    save(&image, "mesh");
    let [r, g, b] = rgb_at(&image, FRONT.pixel(now));
    assert!(
        r > g + 30 && r > b + 30,
        "the mesh at its centre now: {:?}",
        [r, g, b]
    );
    let there_before = rgb_at(&image, FRONT.pixel(start));
    assert!(
        distance(there_before, sky_at(&stage, FRONT.pixel(start).y as u32)) <= 1,
        "nothing where it started"
    );
}

/// [`CUBE_OBJ`] moved `dx` along x.
fn cube_obj_moved(dx: f32) -> String {
    let line = |line: &str| match line.strip_prefix("v ") {
        Some(xyz) => {
            let [x, y, z] = [0, 1, 2].map(|i| xyz.split(' ').nth(i).expect("x y z"));
            let x: f32 = x.parse().expect("a number");
            format!("v {} {y} {z}\n", x + dx)
        }
        None => format!("{line}\n"),
    };
    CUBE_OBJ.lines().map(line).collect()
}

#[test]
fn a_deforming_mesh_is_drawn_where_it_is_now_without_a_distance_field() {
    let Some(context) = context() else { return };
    let folder = tempfile::tempdir().expect("a temporary folder");
    for (number, dx) in [(1, 0.0), (2, 2.0)] {
        let path = folder.path().join(format!("cube_{number:04}.obj"));
        std::fs::write(path, cube_obj_moved(dx)).expect("the mesh is written");
    }
    // Scaled to 0.2 m, the cube's centre is at x = 0.3 at 0 s and at 0.7
    // at 1 s, the second file's time.
    let toml = format!(
        "{SCENE_TOML}[[colliders]]\nshape = \"mesh\"\nsequence = \"cube_####.obj\"\n\
         frame_rate = 1\nsdf_spacing = 0.02\nscale = 0.2\ncenter = [0.3, 0.5, 0.5]\n"
    );
    let path = folder.path().join("scene.toml");
    std::fs::write(&path, toml).expect("the scene is written");
    let scene = Scene::load(&path).expect("the sequence scene loads");
    let (left, right) = (Vec3::new(0.3, 0.5, 0.5), Vec3::new(0.7, 0.5, 0.5));
    for (time, now, not) in [(0.0, left, right), (1.0, right, left)] {
        let mut stage = firn_render::scene_view::scene_stage(&scene, time);
        stage.ground = None;
        let particles = ParticleSource::Host {
            positions: &[],
            values: None,
            trails: None,
        };
        let image = render_as(
            &context,
            &scene,
            FORMAT,
            &frame(&stage, DrawStyle::Points, ColorBy::Uniform, particles),
        );
        save(&image, "deforming");
        let [r, g, b] = rgb_at(&image, FRONT.pixel(now));
        assert!(
            r > g + 30 && r > b + 30,
            "at {time} s the mesh is at {now}: {:?}",
            [r, g, b]
        );
        let elsewhere = rgb_at(&image, FRONT.pixel(not));
        assert!(
            distance(elsewhere, sky_at(&stage, FRONT.pixel(not).y as u32)) <= 1,
            "at {time} s nothing at {not}"
        );
        let deformed = stage.colliders[0]
            .deformed
            .as_ref()
            .expect("a deforming mesh");
        assert!(!deformed.has_field(), "the viewer builds no distance field");
    }
}

#[test]
fn drift_glows_over_the_snow_as_billboards() {
    let Some(context) = context() else { return };
    let stage = stage(Vec::new());
    let snow = ball(Vec3::new(0.35, 0.5, 0.5), 0.12, 0.02);
    let drift_at = Vec3::new(0.75, 0.6, 0.5);
    let drift = vec![drift_at; 4];
    let particles = ParticleSource::Host {
        positions: &snow,
        values: None,
        trails: None,
    };
    let plain = frame(&stage, DrawStyle::Points, ColorBy::Uniform, particles);
    let blown = DrawFrame {
        drift: Some(&drift),
        ..plain
    };
    let (before, after) = (render(&context, &plain), render(&context, &blown));
    save(&after, "drift");
    let at = FRONT.pixel(drift_at);
    assert!(
        brightness_at(&after, at) > brightness_at(&before, at) + 60,
        "the drift does not glow at {at}"
    );
    let snow_at = FRONT.pixel(Vec3::new(0.35, 0.5, 0.5));
    assert_eq!(rgb_at(&after, snow_at), rgb_at(&before, snow_at));
}

#[test]
fn rigid_bodies_are_drawn_in_their_colour_turned_as_their_pose_says() {
    let Some(context) = context() else { return };
    let folder = tempfile::tempdir().expect("a temporary folder");
    std::fs::write(folder.path().join("cube.obj"), CUBE_OBJ).expect("the mesh is written");
    // A box bar along x, and a mesh bar placed standing (its file's cube
    // scaled long along x, turned 90° about z at the start).
    let toml = format!(
        "{SCENE_TOML}[[rigid_bodies]]\nshape = \"box\"\ncenter = [0.3, 0.8, 0.5]\n\
         size = [0.4, 0.08, 0.08]\n[[rigid_bodies]]\nshape = \"mesh\"\nmesh = \"cube.obj\"\n\
         scale = [0.4, 0.08, 0.08]\ncenter = [0.8, 0.3, 0.5]\nrotation = [0.0, 0.0, 90.0]\n\
         sdf_spacing = 0.02\n"
    );
    let path = folder.path().join("scene.toml");
    std::fs::write(&path, toml).expect("the scene is written");
    let scene = Scene::load(&path).expect("the scene with bodies loads");
    let upright = glam::Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    let pose = |position: Vec3| firn_io::BodyPose {
        position: position.to_array(),
        rotation: upright.to_array(),
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
    };
    // Both stand: the box turned upright, the mesh at its starting turn.
    let (box_at, mesh_at) = (Vec3::new(0.25, 0.5, 0.5), Vec3::new(0.75, 0.5, 0.5));
    let mut stage = stage(Vec::new());
    stage.bodies = firn_render::scene_view::stage_bodies(&scene, &[pose(box_at), pose(mesh_at)]);
    let particles = ParticleSource::Host {
        positions: &[],
        values: None,
        trails: None,
    };
    let image = render_as(
        &context,
        &scene,
        FORMAT,
        &frame(&stage, DrawStyle::Points, ColorBy::Uniform, particles),
    );
    save(&image, "bodies");
    let is_body = |point: Vec3| {
        let [r, g, b] = rgb_at(&image, FRONT.pixel(point + Vec3::new(0.0, 0.0, 0.04)));
        r > g && g > b.saturating_add(20) && g > r / 2 + r / 5
    };
    for centre in [box_at, mesh_at] {
        for offset in [Vec3::ZERO, Vec3::new(0.0, 0.15, 0.0)] {
            assert!(is_body(centre + offset), "a body at {}", centre + offset);
        }
        assert!(
            !is_body(centre + Vec3::new(0.15, 0.0, 0.0)),
            "{centre} stands"
        );
    }
}

#[test]
fn a_capsule_body_is_drawn_with_round_ends() {
    let Some(context) = context() else { return };
    let toml = format!(
        "{SCENE_TOML}[[rigid_bodies]]\nshape = \"capsule\"\ncenter = [0.5, 0.5, 0.5]\n\
         radius = 0.08\nheight = 0.4\n"
    );
    let scene = Scene::from_toml_str(&toml, "capsule").expect("the scene with a capsule loads");
    let centre = Vec3::new(0.5, 0.5, 0.5);
    let pose = firn_io::BodyPose {
        position: centre.to_array(),
        rotation: glam::Quat::IDENTITY.to_array(),
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
    };
    let mut stage = stage(Vec::new());
    stage.bodies = firn_render::scene_view::stage_bodies(&scene, &[pose]);
    let particles = ParticleSource::Host {
        positions: &[],
        values: None,
        trails: None,
    };
    let image = render_as(
        &context,
        &scene,
        FORMAT,
        &frame(&stage, DrawStyle::Points, ColorBy::Uniform, particles),
    );
    save(&image, "capsule");
    // The body's warm colour, lit or in shade, against the cool sky.
    let is_body = |point: Vec3| {
        let [r, _, b] = rgb_at(&image, FRONT.pixel(point + Vec3::new(0.0, 0.0, 0.08)));
        r > b.saturating_add(15)
    };
    // Its axis and the tip of each end are drawn; the corners of the
    // cylinder around it (inside that cylinder, outside the round ends) are
    // not.
    for along in [0.0, 0.18, -0.18] {
        assert!(
            is_body(centre + Vec3::new(0.0, along, 0.0)),
            "the capsule at y {along}"
        );
    }
    for corner in [Vec3::new(0.07, 0.19, 0.0), Vec3::new(-0.07, -0.19, 0.0)] {
        assert!(!is_body(centre + corner), "a square corner at {corner}");
    }
}
