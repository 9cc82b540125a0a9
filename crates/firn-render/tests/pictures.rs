//! Pictures of small known scenes, checked pixel by pixel.

use std::borrow::Cow;

use firn_render::film::encode_srgb;
use firn_render::ramp::ramp;
use firn_render::{
    CameraView, Coloring, DriftLayer, ParticleLayer, Picture, RenderStyle, SnowLook, Stage,
    ValueRange, render,
};
use glam::{Vec2, Vec3};
use image::RgbImage;

const WIDTH: u32 = 160;
const HEIGHT: u32 = 120;

/// Particles filling a ball on a cubic lattice.
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

fn camera() -> CameraView {
    CameraView::look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 40.0, WIDTH, HEIGHT)
}

/// A picture with a plain stage: no ground, no container, no colliders.
fn picture<'a>(positions: &'a [Vec3], coloring: Coloring<'a>, style: RenderStyle) -> Picture<'a> {
    Picture {
        camera: camera(),
        style,
        stage: Stage::default(),
        particles: ParticleLayer {
            positions,
            masses: Cow::Owned(vec![400.0 * 0.02f32.powi(3); positions.len()]),
            coloring,
            radius: 0.012,
            look: SnowLook::for_density(400.0, 0.012),
            trails: None,
            smooth_trails: false,
            surface: None,
        },
        legend: None,
        drift: None,
    }
}

fn sky_pixel(stage: &Stage, y: u32) -> [u8; 3] {
    // The sky is evaluated at sample centres; with 2x2 supersampling the
    // four samples of a pixel sit at y + 0.25 and y + 0.75.
    let s = firn_render::SUPERSAMPLING as f32;
    let height = HEIGHT as f32 * s;
    let mut sum = Vec3::ZERO;
    for sy in 0..firn_render::SUPERSAMPLING {
        sum += stage.sky(y as f32 * s + sy as f32 + 0.5, height);
    }
    encode_srgb(sum / s)
}

#[test]
fn a_ball_appears_where_the_projection_says_and_nowhere_else() {
    let center = Vec3::new(0.25, -0.1, 0.0);
    let radius = 0.2;
    let positions = ball(center, radius, 0.02);
    let picture = picture(
        &positions,
        Coloring::Uniform(Vec3::splat(0.8)),
        RenderStyle::Points,
    );
    let image = render(&picture);
    let projected = camera().project(center).expect("in front");
    // The silhouette radius of a ball seen from distance d is r d / sqrt(d² - r²);
    // the sprites add their own radius.
    let pixels_per_metre = projected.scale;
    let silhouette = (radius + 0.012) * pixels_per_metre * 1.02;
    let stage = Stage::default();
    let mut covered = 0;
    for (x, y, pixel) in image.enumerate_pixels() {
        let distance = (Vec2::new(x as f32 + 0.5, y as f32 + 0.5) - projected.pixel).length();
        if distance < 0.8 * radius * pixels_per_metre {
            assert_ne!(
                pixel.0,
                sky_pixel(&stage, y),
                "inside the ball at ({x}, {y})"
            );
            covered += 1;
        } else if distance > silhouette + 1.5 {
            assert_eq!(
                pixel.0,
                sky_pixel(&stage, y),
                "outside the ball at ({x}, {y})"
            );
        }
    }
    assert!(covered > 100, "the ball covers {covered} pixels");
}

#[test]
fn the_background_is_the_background() {
    let picture = picture(&[], Coloring::Uniform(Vec3::ONE), RenderStyle::Points);
    let image = render(&picture);
    let stage = Stage::default();
    for (_, y, pixel) in image.enumerate_pixels() {
        assert_eq!(pixel.0, sky_pixel(&stage, y));
    }
    let volume = render(&Picture {
        style: RenderStyle::Volume,
        ..picture
    });
    for (_, y, pixel) in volume.enumerate_pixels() {
        assert_eq!(pixel.0, sky_pixel(&stage, y));
    }
}

/// Colour at the image centre of two balls on the view axis, the near one
/// coloured with ramp value `near_value`, the far one with `1 - near_value`.
fn centre_of_two_balls(near_value: f32) -> [u8; 3] {
    let mut positions = ball(Vec3::new(0.0, 0.0, 0.5), 0.1, 0.02);
    let near_count = positions.len();
    positions.extend(ball(Vec3::new(0.0, 0.0, -0.5), 0.3, 0.02));
    let values: Vec<f32> = (0..positions.len())
        .map(|i| {
            if i < near_count {
                near_value
            } else {
                1.0 - near_value
            }
        })
        .collect();
    let coloring = Coloring::Ramp {
        values: &values,
        range: ValueRange {
            low: 0.0,
            high: 1.0,
        },
    };
    let image = render(&picture(&positions, coloring, RenderStyle::Points));
    image.get_pixel(WIDTH / 2, HEIGHT / 2).0
}

#[test]
fn a_nearer_ball_hides_a_farther_one() {
    let blue_in_front = centre_of_two_balls(0.0);
    let white_in_front = centre_of_two_balls(1.0);
    let brightness = |p: [u8; 3]| p.iter().map(|&c| c as u32).sum::<u32>();
    // The near ball decides the colour, whichever is drawn first.
    assert!(
        brightness(white_in_front) > brightness(blue_in_front) + 150,
        "{white_in_front:?} vs {blue_in_front:?}"
    );
    let blue = ramp(0.0);
    assert!(
        blue_in_front[2] > blue_in_front[0],
        "{blue_in_front:?} ~ {blue}"
    );
}

/// Mean brightness above the sky within `radius` pixels of where `point` projects.
fn brightness_around(image: &RgbImage, point: Vec3, radius: f32) -> f32 {
    let center = camera().project(point).expect("in front").pixel;
    let stage = Stage::default();
    let (mut sum, mut count) = (0.0, 0);
    for (x, y, pixel) in image.enumerate_pixels() {
        if (Vec2::new(x as f32 + 0.5, y as f32 + 0.5) - center).length() < radius {
            let sky = encode_srgb(stage.sky(y as f32 + 0.5, HEIGHT as f32));
            sum += pixel
                .0
                .iter()
                .zip(sky)
                .map(|(&p, s)| p as f32 - s as f32)
                .sum::<f32>();
            count += 1;
        }
    }
    sum / count as f32
}

#[test]
fn volume_is_more_opaque_where_snow_is_denser() {
    // Two equal balls; the right one's particles weigh four times as much.
    let left = Vec3::new(-0.4, 0.0, 0.0);
    let right = Vec3::new(0.4, 0.0, 0.0);
    let mut positions = ball(left, 0.15, 0.02);
    let split = positions.len();
    positions.extend(ball(right, 0.15, 0.02));
    let light = 50.0 * 0.02f32.powi(3);
    let masses: Vec<f32> = (0..positions.len())
        .map(|i| if i < split { light } else { 4.0 * light })
        .collect();
    let mut picture = picture(
        &positions,
        Coloring::Uniform(Vec3::ONE),
        RenderStyle::Volume,
    );
    picture.particles.masses = Cow::Owned(masses);
    picture.particles.radius = 0.01;
    picture.particles.look = SnowLook::for_density(400.0, 0.05);
    let image = render(&picture);
    let pixels = 0.1 * camera().project(left).expect("in front").scale;
    let powder = brightness_around(&image, left, pixels);
    let packed = brightness_around(&image, right, pixels);
    assert!(powder > 5.0, "powder is visible: {powder}");
    assert!(packed > powder * 1.3, "packed {packed} vs powder {powder}");
}

#[test]
fn the_same_picture_renders_to_the_same_bytes_on_any_thread_count() {
    let positions = ball(Vec3::ZERO, 0.3, 0.02);
    let values: Vec<f32> = positions.iter().map(|p| p.y).collect();
    let coloring = Coloring::Ramp {
        values: &values,
        range: ValueRange {
            low: -0.3,
            high: 0.3,
        },
    };
    let mesh = sphere_mesh(Vec3::ZERO, 0.3, 24, 48);
    for style in [
        RenderStyle::Points,
        RenderStyle::Volume,
        RenderStyle::Surface,
    ] {
        let mut picture = picture(&positions, coloring, style);
        picture.particles.surface = Some(&mesh);
        let first = render(&picture);
        let second = render(&picture);
        let single = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool")
            .install(|| render(&picture));
        assert_eq!(first.as_raw(), second.as_raw(), "{style:?}");
        assert_eq!(first.as_raw(), single.as_raw(), "{style:?}");
    }
}

fn brightness(pixel: [u8; 3]) -> u32 {
    pixel.iter().map(|&c| c as u32).sum()
}

#[test]
fn billboards_add_up_and_hide_behind_solid_colliders() {
    let one = [Vec3::ZERO];
    let two = [Vec3::ZERO, Vec3::ZERO];
    let white = Coloring::Uniform(Vec3::ONE);
    let single = render(&picture(&one, white, RenderStyle::Billboards));
    let double = render(&picture(&two, white, RenderStyle::Billboards));
    let centre = |image: &RgbImage| brightness(image.get_pixel(WIDTH / 2, HEIGHT / 2).0);
    assert!(centre(&double) > centre(&single) + 20, "additive blending");
    let mut hidden = picture(&one, white, RenderStyle::Billboards);
    hidden.stage.colliders = vec![
        firn_core::scene::ColliderGeometry::Sphere {
            center: Vec3::new(0.0, 0.0, 1.0),
            radius: 0.3,
        }
        .into(),
    ];
    let mut bare = hidden.clone();
    bare.particles.positions = &[];
    assert_eq!(render(&hidden).as_raw(), render(&bare).as_raw());
}

#[test]
fn trails_follow_the_path_and_fade_towards_the_oldest_end() {
    // One particle that moved along x from -0.5 to 0.5 (newest).
    let path: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new(-0.5 + i as f32 / 7.0, 0.0, 0.0))
        .collect();
    let lengths = [8u32];
    let mut picture = picture(
        &path[7..],
        Coloring::Uniform(Vec3::ONE),
        RenderStyle::Trails,
    );
    picture.particles.trails = Some(firn_render::Trails {
        points: &path,
        capacity: 8,
        lengths: &lengths,
    });
    let image = render(&picture);
    let at = |x: f32| {
        let pixel = camera()
            .project(Vec3::new(x, 0.0, 0.0))
            .expect("visible")
            .pixel;
        image.get_pixel(pixel.x as u32, pixel.y as u32).0
    };
    let stage = Stage::default();
    let sky = sky_pixel(&stage, HEIGHT / 2);
    assert!(
        brightness(at(0.4)) > brightness(at(-0.3)),
        "newer is brighter"
    );
    assert!(brightness(at(-0.3)) >= brightness(sky));
    assert_eq!(
        image.get_pixel(WIDTH / 2, 5).0,
        sky_pixel(&stage, 5),
        "off the path"
    );
}

#[test]
fn a_cube_mesh_collider_looks_like_the_box_it_is_shaped_as() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("cube.obj");
    std::fs::write(
        &file,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
         f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n",
    )
    .unwrap();
    let center = Vec3::new(0.1, -0.05, 0.0);
    let size = Vec3::new(0.5, 0.4, 0.45);
    let placement = firn_core::scene::MeshPlacement {
        file,
        scale: size,
        rotation_degrees: Vec3::ZERO,
        center,
    };
    let mesh = firn_core::scene::MeshCollider::load(placement, 0.01).unwrap();
    let with = |geometry: firn_core::scene::ColliderGeometry| {
        let mut scene = picture(&[], Coloring::Uniform(Vec3::ONE), RenderStyle::Points);
        scene.stage.colliders = vec![geometry.into()];
        render(&scene)
    };
    let meshed = with(firn_core::scene::ColliderGeometry::Mesh(Box::new(mesh)));
    let boxed = with(firn_core::scene::ColliderGeometry::Box { center, size });
    let bare = render(&picture(
        &[],
        Coloring::Uniform(Vec3::ONE),
        RenderStyle::Points,
    ));
    let pixels = (WIDTH * HEIGHT) as usize;
    let covered = (0..pixels)
        .filter(|&i| boxed.as_raw()[3 * i..3 * i + 3] != bare.as_raw()[3 * i..3 * i + 3])
        .count();
    let silhouette_mismatch = (0..pixels)
        .filter(|&i| {
            let on_box = boxed.as_raw()[3 * i..3 * i + 3] != bare.as_raw()[3 * i..3 * i + 3];
            let on_mesh = meshed.as_raw()[3 * i..3 * i + 3] != bare.as_raw()[3 * i..3 * i + 3];
            on_box != on_mesh
        })
        .count();
    assert!(covered > 300, "the box covers {covered} pixels");
    assert!(
        silhouette_mismatch * 20 < covered,
        "{silhouette_mismatch} of {covered} pixels differ in coverage"
    );
}

/// A closed latitude-longitude sphere mesh, counter-clockwise from outside.
fn sphere_mesh(center: Vec3, radius: f32, rings: u32, segments: u32) -> firn_mesh::TriangleMesh {
    let mut vertices = vec![center + Vec3::Y * radius, center - Vec3::Y * radius];
    for ring in 1..rings {
        let polar = std::f32::consts::PI * ring as f32 / rings as f32;
        for segment in 0..segments {
            let azimuth = std::f32::consts::TAU * segment as f32 / segments as f32;
            let direction = Vec3::new(
                polar.sin() * azimuth.cos(),
                polar.cos(),
                -polar.sin() * azimuth.sin(),
            );
            vertices.push(center + direction * radius);
        }
    }
    let at = |ring: u32, segment: u32| 2 + (ring - 1) * segments + segment % segments;
    let mut triangles = Vec::new();
    for segment in 0..segments {
        triangles.push([0, at(1, segment), at(1, segment + 1)]);
        triangles.push([1, at(rings - 1, segment + 1), at(rings - 1, segment)]);
        for ring in 1..rings - 1 {
            let (a, b) = (at(ring, segment), at(ring, segment + 1));
            let (c, d) = (at(ring + 1, segment), at(ring + 1, segment + 1));
            triangles.push([a, c, d]);
            triangles.push([a, d, b]);
        }
    }
    firn_mesh::TriangleMesh {
        vertices,
        triangles,
    }
}

#[test]
fn a_surface_appears_where_its_projection_says_lit_from_the_light() {
    let center = Vec3::new(-0.2, 0.1, 0.0);
    let radius = 0.3;
    let mesh = sphere_mesh(center, radius, 48, 96);
    assert!(mesh.signed_volume() > 0.0, "the test sphere faces outwards");
    let mut picture = picture(&[], Coloring::Uniform(Vec3::ONE), RenderStyle::Surface);
    picture.particles.surface = Some(&mesh);
    let image = render(&picture);
    let projected = camera().project(center).expect("in front");
    let distance_to_eye = (camera().eye - center).length();
    let silhouette = radius * distance_to_eye / (distance_to_eye.powi(2) - radius.powi(2)).sqrt()
        * projected.scale;
    let stage = Stage::default();
    let mut covered = 0;
    for (x, y, pixel) in image.enumerate_pixels() {
        let distance = (Vec2::new(x as f32 + 0.5, y as f32 + 0.5) - projected.pixel).length();
        if distance < silhouette - 1.5 {
            assert_ne!(pixel.0, sky_pixel(&stage, y), "inside at ({x}, {y})");
            covered += 1;
        } else if distance > silhouette + 1.5 {
            assert_eq!(pixel.0, sky_pixel(&stage, y), "outside at ({x}, {y})");
        }
    }
    assert!(covered > 500, "the surface covers {covered} pixels");
    // The light comes from above, left and in front: the top of the ball
    // is brighter than its bottom.
    let brightness = |offset: Vec2| {
        let pixel = projected.pixel + offset * silhouette;
        let [r, g, b] = image.get_pixel(pixel.x as u32, pixel.y as u32).0;
        u32::from(r) + u32::from(g) + u32::from(b)
    };
    let (top, bottom) = (
        brightness(Vec2::new(0.0, -0.7)),
        brightness(Vec2::new(0.0, 0.7)),
    );
    assert!(top > bottom + 100, "top {top}, bottom {bottom}");
}

#[test]
fn the_surface_style_without_a_surface_shows_the_stage() {
    let bare = render(&picture(
        &[],
        Coloring::Uniform(Vec3::ONE),
        RenderStyle::Points,
    ));
    let surface = render(&picture(
        &[],
        Coloring::Uniform(Vec3::ONE),
        RenderStyle::Surface,
    ));
    assert_eq!(bare, surface);
}

#[test]
fn drift_glows_over_the_snow_in_every_style_and_only_where_it_is() {
    let snow = ball(Vec3::new(-0.3, 0.0, 0.0), 0.15, 0.02);
    let drift_at = Vec3::new(0.35, 0.1, 0.0);
    let drift = vec![drift_at; 3];
    for style in [
        RenderStyle::Points,
        RenderStyle::Volume,
        RenderStyle::Surface,
    ] {
        let plain = picture(&snow, Coloring::Uniform(Vec3::splat(0.8)), style);
        let blown = Picture {
            drift: Some(DriftLayer {
                positions: &drift,
                radius: 0.03,
                color: Vec3::ONE,
            }),
            ..plain.clone()
        };
        let (before, after) = (render(&plain), render(&blown));
        let projected = camera().project(drift_at).expect("in front");
        let (x, y) = (projected.pixel.x as u32, projected.pixel.y as u32);
        let brightness = |image: &RgbImage, x: u32, y: u32| -> u32 {
            image.get_pixel(x, y).0.iter().map(|&c| u32::from(c)).sum()
        };
        assert!(
            brightness(&after, x, y) > brightness(&before, x, y) + 60,
            "{style:?}: the drift does not show at its place"
        );
        let reach = 0.03 * projected.scale + 2.0;
        for (px, py, pixel) in after.enumerate_pixels() {
            let distance = (Vec2::new(px as f32 + 0.5, py as f32 + 0.5) - projected.pixel).length();
            if distance > reach {
                assert_eq!(pixel, before.get_pixel(px, py), "{style:?} at ({px}, {py})");
            }
        }
    }
}

/// A cube of edge 0.3 centred at `(x, 0, 0)` as an OBJ, its corners in a
/// fixed order so that every frame has the same topology.
fn cube_obj(x: f32) -> String {
    let mut text = String::new();
    for corner in 0..8 {
        let pick = |bit: u32| if corner & bit == 0 { -0.15 } else { 0.15 };
        text += &format!("v {} {} {}\n", x + pick(1), pick(2), pick(4));
    }
    text + "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n"
}

#[test]
fn a_deforming_mesh_collider_is_drawn_where_its_mesh_is_at_the_picture_time() {
    let folder = tempfile::tempdir().unwrap();
    std::fs::write(folder.path().join("cube_0001.obj"), cube_obj(-0.3)).unwrap();
    std::fs::write(folder.path().join("cube_0002.obj"), cube_obj(0.3)).unwrap();
    let toml = "format = 1\nname = \"deforming\"\n[domain]\nmin = [-1.0, -1.0, -1.0]\n\
        max = [1.0, 1.0, 1.0]\ncell_size = 0.1\n[time]\nduration = 1.0\n[[bodies]]\n\
        shape = \"sphere\"\ncenter = [0.0, -0.8, 0.0]\nradius = 0.1\n[[colliders]]\n\
        shape = \"mesh\"\nsequence = \"cube_####.obj\"\nframe_rate = 2\nsdf_spacing = 0.02\n";
    let path = folder.path().join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    let scene = firn_core::Scene::load(&path).expect("the scene loads");
    let is_collider = |image: &RgbImage, x: f32| {
        let pixel = camera()
            .project(Vec3::new(x, 0.0, 0.0))
            .expect("in front")
            .pixel;
        let [r, g, b] = image.get_pixel(pixel.x as u32, pixel.y as u32).0;
        r > g.saturating_add(30) && r > b.saturating_add(30)
    };
    // Mesh frame 2 is at 0.5 s; at 0.25 s the cube is halfway.
    for (time, centre) in [(0.0, -0.3), (0.25, 0.0), (0.5, 0.3)] {
        let stage = firn_render::scene_view::scene_stage(&scene, time);
        let mut shown = picture(&[], Coloring::Uniform(Vec3::ONE), RenderStyle::Points);
        shown.stage.colliders = stage.colliders;
        let image = render(&shown);
        for x in [-0.3, 0.0, 0.3] {
            assert_eq!(
                is_collider(&image, x),
                x == centre,
                "at {time} s the cube is at x = {centre}, the pixel of x = {x}"
            );
        }
    }
}

/// A bar 0.6 m long along x, 0.1 m thick, centred at the origin, as an OBJ.
fn bar_obj() -> String {
    let mut text = String::new();
    for corner in 0..8 {
        let pick = |bit: u32, half: f32| if corner & bit == 0 { -half } else { half };
        text += &format!("v {} {} {}\n", pick(1, 0.3), pick(2, 0.05), pick(4, 0.05));
    }
    text + "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n"
}

#[test]
fn rigid_bodies_are_drawn_in_their_own_colour_where_their_pose_puts_them() {
    use firn_io::BodyPose;
    use glam::Quat;
    let folder = tempfile::tempdir().unwrap();
    std::fs::write(folder.path().join("bar.obj"), bar_obj()).unwrap();
    // A box bar along x and the same bar as a mesh, placed standing up
    // (turned 90° about z at the start: its vertices carry that turn).
    let toml = "format = 1\nname = \"bars\"\n[domain]\nmin = [-1.0, -1.0, -1.0]\n\
        max = [1.0, 1.0, 1.0]\ncell_size = 0.1\n[time]\nduration = 1.0\n[[bodies]]\n\
        shape = \"sphere\"\ncenter = [0.0, -0.8, 0.0]\nradius = 0.1\n[[rigid_bodies]]\n\
        shape = \"box\"\ncenter = [-0.4, 0.0, 0.0]\nsize = [0.6, 0.1, 0.1]\n\
        [[rigid_bodies]]\nshape = \"mesh\"\nmesh = \"bar.obj\"\ncenter = [0.4, 0.0, 0.0]\n\
        rotation = [0.0, 0.0, 90.0]\nsdf_spacing = 0.02\n";
    let path = folder.path().join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    let scene = firn_core::Scene::load(&path).expect("the scene loads");
    let upright = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    let pose = |position: Vec3, rotation: Quat| BodyPose {
        position: position.to_array(),
        rotation: rotation.to_array(),
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
    };
    let drawn = |poses: &[BodyPose]| {
        let mut shown = picture(&[], Coloring::Uniform(Vec3::ONE), RenderStyle::Points);
        shown.stage.bodies = firn_render::scene_view::stage_bodies(&scene, poses);
        render(&shown)
    };
    let colour_at = |image: &RgbImage, point: Vec3| {
        let pixel = camera().project(point).expect("in front").pixel;
        image.get_pixel(pixel.x as u32, pixel.y as u32).0
    };
    // The wood tone: red over green over blue, green well above the
    // colliders' brick red.
    let is_body = |[r, g, b]: [u8; 3]| r > g && g > b.saturating_add(20) && g > r / 2 + r / 5;
    // The box turned upright and moved up; the mesh at its starting turn,
    // moved down: both stand.
    let image = drawn(&[
        pose(Vec3::new(-0.4, 0.1, 0.0), upright),
        pose(Vec3::new(0.4, -0.1, 0.0), upright),
    ]);
    for (x, y) in [(-0.4, 0.1), (-0.4, 0.32), (0.4, -0.1), (0.4, -0.32)] {
        let colour = colour_at(&image, Vec3::new(x, y, 0.05));
        assert!(is_body(colour), "({x}, {y}) is {colour:?}, not a body");
    }
    for (x, y) in [(-0.6, 0.1), (-0.4, -0.2), (0.6, -0.1), (0.4, 0.2)] {
        let colour = colour_at(&image, Vec3::new(x, y, 0.05));
        assert!(!is_body(colour), "({x}, {y}) is {colour:?}, a body");
    }
    // The same bodies at their starting poses: the box lies along x.
    let start = drawn(&[
        pose(Vec3::new(-0.4, 0.0, 0.0), Quat::IDENTITY),
        pose(Vec3::new(0.4, 0.0, 0.0), upright),
    ]);
    assert!(is_body(colour_at(&start, Vec3::new(-0.6, 0.0, 0.05))));
    assert!(!is_body(colour_at(&start, Vec3::new(-0.4, 0.2, 0.05))));
    assert!(is_body(colour_at(&start, Vec3::new(0.4, 0.2, 0.05))));
}
