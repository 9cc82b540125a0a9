//! Pictures of a scene: the camera, stage, colours and snow look that a
//! scene file implies, for one frame's particles.

use std::borrow::Cow;

use firn_core::Scene;
use firn_core::scene::{ColliderGeometry, ColorBy, RenderStyle};
use firn_io::BodyPose;
use firn_mesh::TriangleMesh;
use glam::{Quat, Vec3};

use crate::camera::{CameraView, automatic_framing};
use crate::legend::Legend;
use crate::ramp::{Coloring, ValueRange, ramp};
use crate::stage::{DeformedMesh, Stage, StageCollider};
use crate::trails::Trails;
use crate::volume::SnowLook;
use crate::{DriftLayer, ParticleLayer, Picture};

/// Snow's sprite radius relative to the particle spacing: a little over half,
/// so neighbouring sprites overlap into a closed surface.
const RADIUS_PER_SPACING: f32 = 0.6;
/// Mean free path of light in snow at its rest density, in particle spacings.
const MEAN_FREE_PATH_SPACINGS: f32 = 0.6;

/// Drift sprites' radius relative to the snow's sprites: the flow's
/// billboards are twice the points' radius.
const DRIFT_RADIUS_PER_SPRITE: f32 = 2.0;
/// The colour drift sprites add: a cold white, so that blown snow glows
/// against the sky and the shaded snow.
const DRIFT_COLOR: Vec3 = Vec3::new(0.85, 0.92, 1.0);

/// One frame's particles, as the renderer needs them.
#[derive(Clone, Copy, Debug)]
pub struct FrameParticles<'a> {
    /// Positions.
    pub positions: &'a [Vec3],
    /// Masses, if known (otherwise derived from the scene's first material).
    pub masses: Option<&'a [f32]>,
    /// Values of the scene's `color_by` quantity, one per particle, if it is
    /// a ramp quantity.
    pub values: Option<&'a [f32]>,
    /// Recent positions per particle, for the `trails` style.
    pub trails: Option<Trails<'a>>,
    /// The snow's reconstructed surface, for the `surface` style.
    pub surface: Option<&'a TriangleMesh>,
    /// A snow scene's drift particles (`[wind.spindrift]`), drawn in the
    /// flow's look over the snow.
    pub drift: Option<&'a [Vec3]>,
    /// Where the scene's rigid bodies are and how they are turned, in
    /// scene order (empty without bodies).
    pub rigid_bodies: &'a [BodyPose],
}

/// The picture of `scene` at simulated time `time` in `style`, at the
/// scene's image size unless `size` overrides it.
pub fn scene_picture<'a>(
    scene: &Scene,
    time: f64,
    style: RenderStyle,
    particles: FrameParticles<'a>,
    size: Option<[u32; 2]>,
) -> Picture<'a> {
    let [width, height] = size.unwrap_or(scene.render.size);
    let camera = scene_camera(scene, time, width, height);
    let spacing = particle_spacing(scene);
    let masses = particles.masses.map_or_else(
        || {
            Cow::Owned(vec![
                uniform_mass(scene, spacing);
                particles.positions.len()
            ])
        },
        Cow::Borrowed,
    );
    let coloring = coloring(scene, particles.values);
    let legend = scene
        .render
        .legend
        .then(|| legend_for(scene, &coloring))
        .flatten();
    Picture {
        camera,
        style,
        stage: Stage {
            bodies: stage_bodies(scene, particles.rigid_bodies),
            ..scene_stage(scene, time)
        },
        particles: ParticleLayer {
            positions: particles.positions,
            masses,
            coloring,
            radius: sprite_radius(scene),
            look: SnowLook::for_density(
                reference_density(scene),
                MEAN_FREE_PATH_SPACINGS * spacing,
            ),
            trails: particles.trails,
            smooth_trails: scene.render.smooth_trails,
            surface: particles.surface,
        },
        legend,
        drift: particles.drift.map(|positions| DriftLayer {
            positions,
            radius: DRIFT_RADIUS_PER_SPRITE * sprite_radius(scene),
            color: DRIFT_COLOR,
        }),
    }
}

/// The scene's camera at time `t` (automatic framing where the scene is silent).
pub fn scene_camera(scene: &Scene, t: f64, width: u32, height: u32) -> CameraView {
    let camera = &scene.camera;
    let aspect = width as f32 / height as f32;
    let automatic = automatic_framing(
        scene.domain.min,
        scene.domain.max,
        camera.fov_degrees,
        aspect,
    );
    let (eye, look_at) = camera.view_at(t, automatic);
    CameraView::look_at(eye, look_at, camera.fov_degrees, width, height)
}

/// The container, the ground at the domain floor, and the colliders (and a
/// flow's obstacles) where they are at time `t`; a deforming mesh carries
/// its triangles of that instant, their distance field left until a ray
/// tracer asks for it.
pub fn scene_stage(scene: &Scene, t: f64) -> Stage {
    let mut colliders: Vec<StageCollider> = scene
        .colliders
        .iter()
        .map(|collider| {
            let pose = collider.pose_at(t);
            let deformed = match &collider.geometry {
                ColliderGeometry::MeshSequence(sequence) => {
                    Some(DeformedMesh::new(sequence.mesh_at(t), sequence.sdf_spacing))
                }
                _ => None,
            };
            StageCollider {
                geometry: collider.geometry.moved_to(pose.position),
                rotation: pose.rotation,
                deformed,
            }
        })
        .collect();
    // A flow's obstacles are drawn like sphere colliders.
    if let Some(flow) = scene.kind.flow() {
        colliders.extend(flow.obstacles.iter().map(|obstacle| {
            StageCollider::from(ColliderGeometry::Sphere {
                center: obstacle.center,
                radius: obstacle.radius,
            })
        }));
    }
    Stage {
        ground: Some(scene.domain.min.y),
        container: Some((scene.domain.min, scene.domain.max)),
        colliders,
        ..Stage::default()
    }
}

/// The scene's rigid bodies at their `poses` (in scene order): each body's
/// geometry at its reference point, turned by its rotation less the one
/// its placed mesh already carries.
pub fn stage_bodies(scene: &Scene, poses: &[BodyPose]) -> Vec<StageCollider> {
    scene
        .rigid_bodies
        .iter()
        .zip(poses)
        .map(|(body, pose)| StageCollider {
            geometry: body.geometry.moved_to(Vec3::from_array(pose.position)),
            rotation: Quat::from_array(pose.rotation) * body.baked_rotation().inverse(),
            deformed: None,
        })
        .collect()
}

/// The radius particles are drawn with: the scene's `point_radius`, or a
/// little over half the particle spacing.
pub fn sprite_radius(scene: &Scene) -> f32 {
    scene
        .render
        .point_radius
        .unwrap_or(RADIUS_PER_SPACING * particle_spacing(scene))
}

/// Distance between neighbouring particles of the densest-sampled body (for
/// flow scenes and scenes without bodies, a small fraction of the domain).
pub fn particle_spacing(scene: &Scene) -> f32 {
    let per_cell = scene
        .bodies
        .iter()
        .map(|body| body.particles_per_cell)
        .max();
    match per_cell {
        Some(count) => scene.domain.cell_size / (count.max(1) as f32).cbrt(),
        None => (scene.domain.max - scene.domain.min).max_element() / 400.0,
    }
}

/// Mass of one particle of the densest material at the given spacing.
pub fn uniform_mass(scene: &Scene, spacing: f32) -> f32 {
    reference_density(scene) * spacing.powi(3)
}

/// The densest material's rest density (400 kg/m³ without materials).
fn reference_density(scene: &Scene) -> f32 {
    scene
        .materials
        .iter()
        .map(|material| material.density)
        .fold(None, |best: Option<f32>, d| {
            Some(best.map_or(d, |b| b.max(d)))
        })
        .unwrap_or(400.0)
}

/// The colouring for the scene's `color_by` and the given per-particle values.
fn coloring<'a>(scene: &Scene, values: Option<&'a [f32]>) -> Coloring<'a> {
    let range = ramp_range(scene, scene.render.color_by);
    match (scene.render.color_by, values, range) {
        (ColorBy::Position, _, _) => Coloring::Position {
            min: scene.domain.min,
            max: scene.domain.max,
        },
        (_, Some(values), Some(range)) => Coloring::Ramp { values, range },
        _ => Coloring::Uniform(ramp(0.72)),
    }
}

/// The fixed ramp range of a quantity for this scene, so colours mean the
/// same in every frame.
pub fn ramp_range(scene: &Scene, color_by: ColorBy) -> Option<ValueRange> {
    match color_by {
        ColorBy::Density => {
            let rho = reference_density(scene);
            // Surface particles read low (their kernel sums see fewer
            // neighbours), so the range starts well below the rest density.
            Some(ValueRange {
                low: 0.25 * rho,
                high: 1.25 * rho,
            })
        }
        ColorBy::PlasticJ => Some(ValueRange {
            low: 1.25,
            high: 0.75,
        }),
        ColorBy::Speed => Some(ValueRange {
            low: 0.0,
            high: reference_speed(scene),
        }),
        ColorBy::Position | ColorBy::Uniform => None,
    }
}

/// A speed scale: the fastest initial body speed plus free fall over the domain height.
fn reference_speed(scene: &Scene) -> f32 {
    let thrown = scene
        .bodies
        .iter()
        .map(|body| body.velocity.length())
        .fold(0.0f32, f32::max);
    let height = scene.domain.max.y - scene.domain.min.y;
    let fall = (2.0 * scene.solver.gravity.length() * height).sqrt();
    (thrown + fall).max(1e-3)
}

/// The legend for a ramp colouring (none for position or uniform colours).
fn legend_for(scene: &Scene, coloring: &Coloring<'_>) -> Option<Legend> {
    let Coloring::Ramp { range, .. } = coloring else {
        return None;
    };
    let title = match scene.render.color_by {
        ColorBy::Density => "density kg/m3",
        ColorBy::PlasticJ => "plastic J",
        ColorBy::Speed => "speed m/s",
        ColorBy::Position | ColorBy::Uniform => return None,
    };
    Some(Legend {
        title: title.to_string(),
        range: *range,
    })
}
