//! Everything in a picture that is not particles: the sky, the ground plane,
//! the colliders and rigid bodies (Blinn-Phong shaded, thesis section 5.7)
//! and the light.
//! These are ray-cast per sample; the particles are drawn over them with a
//! depth test.

use std::fmt;
use std::sync::OnceLock;

use firn_core::scene::{ColliderGeometry, MeshCollider};
use firn_mesh::{SignedDistanceField, TriangleMesh};
use glam::{Quat, Vec2, Vec3};

use crate::camera::CameraView;
use crate::film::Film;

/// A directional key light plus an ambient sky term.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Unit direction from the scene towards the light.
    pub direction: Vec3,
    /// Radiance of the key light (linear RGB).
    pub color: Vec3,
    /// Ambient sky light (linear RGB).
    pub ambient: Vec3,
}

impl Default for Light {
    fn default() -> Light {
        Light {
            direction: Vec3::new(-0.35, 0.8, 0.5).normalize(),
            color: Vec3::new(1.0, 0.97, 0.92),
            ambient: Vec3::new(0.30, 0.34, 0.42),
        }
    }
}

/// The backdrop and solid geometry of a picture.
#[derive(Clone, Debug, PartialEq)]
pub struct Stage {
    /// Sky colour at the top of the image (linear RGB).
    pub sky_top: Vec3,
    /// Sky colour at the bottom of the image (linear RGB).
    pub sky_bottom: Vec3,
    /// Height of the ground plane (y), if one is drawn.
    pub ground: Option<f32>,
    /// The container (domain box) as (min, max), drawn as a wireframe; it
    /// also bounds plane colliders.
    pub container: Option<(Vec3, Vec3)>,
    /// Colliders, placed and turned as they are at the picture's time.
    pub colliders: Vec<StageCollider>,
    /// Rigid bodies, placed and turned as they are at the picture's time,
    /// drawn like colliders in a colour of their own ([`BODY_ALBEDO`]).
    pub bodies: Vec<StageCollider>,
    /// The lighting.
    pub light: Light,
}

/// A collider as a picture shows it: its geometry at its current
/// reference point, turned by `rotation` about that point.
#[derive(Clone, Debug, PartialEq)]
pub struct StageCollider {
    /// The geometry, unturned, at the collider's current reference point.
    pub geometry: ColliderGeometry,
    /// The collider's orientation about its reference point.
    pub rotation: Quat,
    /// A deforming mesh's triangles at the picture's time (`geometry` is
    /// then the sequence they come from); `None` for a rigid collider.
    pub deformed: Option<DeformedMesh>,
}

impl From<ColliderGeometry> for StageCollider {
    /// An unturned rigid collider.
    fn from(geometry: ColliderGeometry) -> StageCollider {
        StageCollider {
            geometry,
            rotation: Quat::IDENTITY,
            deformed: None,
        }
    }
}

/// A deforming mesh at one instant, in scene coordinates. A viewer draws
/// its triangles as they are; the ray tracer reads a signed distance field
/// of them, built the first time a ray needs it, so a stage that is only
/// rasterised never pays for one.
#[derive(Clone)]
pub struct DeformedMesh {
    /// The triangles where they are at the picture's time.
    pub mesh: TriangleMesh,
    /// Spacing of the distance field's samples, metres.
    pub sdf_spacing: f32,
    field: OnceLock<SignedDistanceField>,
}

impl DeformedMesh {
    /// The mesh, its distance field (at `sdf_spacing`) not yet built.
    pub fn new(mesh: TriangleMesh, sdf_spacing: f32) -> DeformedMesh {
        DeformedMesh {
            mesh,
            sdf_spacing,
            field: OnceLock::new(),
        }
    }

    /// The signed distance field around the mesh, built on the first call.
    pub fn field(&self) -> &SignedDistanceField {
        self.field.get_or_init(|| {
            let padding = MeshCollider::PADDING_SAMPLES as f32 * self.sdf_spacing;
            SignedDistanceField::build(&self.mesh, self.sdf_spacing, padding)
        })
    }

    /// Whether [`DeformedMesh::field`] has been built.
    pub fn has_field(&self) -> bool {
        self.field.get().is_some()
    }
}

impl PartialEq for DeformedMesh {
    /// The same triangles at the same spacing (the field follows from them).
    fn eq(&self, other: &DeformedMesh) -> bool {
        self.mesh == other.mesh && self.sdf_spacing == other.sdf_spacing
    }
}

impl fmt::Debug for DeformedMesh {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("DeformedMesh")
            .field("vertices", &self.mesh.vertices.len())
            .field("triangles", &self.mesh.triangles.len())
            .field("sdf_spacing", &self.sdf_spacing)
            .field("has_field", &self.has_field())
            .finish()
    }
}

impl Default for Stage {
    fn default() -> Stage {
        Stage {
            sky_top: Vec3::new(0.075, 0.085, 0.11),
            sky_bottom: Vec3::new(0.20, 0.21, 0.24),
            ground: None,
            container: None,
            colliders: Vec::new(),
            bodies: Vec::new(),
            light: Light::default(),
        }
    }
}

/// Albedo of sphere and box colliders.
pub const COLLIDER_ALBEDO: Vec3 = Vec3::new(0.55, 0.24, 0.18);
/// Albedo of rigid bodies: a warm wood, apart from the colliders' red.
pub const BODY_ALBEDO: Vec3 = Vec3::new(0.62, 0.46, 0.27);
/// Albedo of plane colliders (walls).
pub const WALL_ALBEDO: Vec3 = Vec3::new(0.42, 0.45, 0.50);
/// Albedo of the two tones of the ground's checkerboard.
pub const GROUND_ALBEDO: [f32; 2] = [0.16, 0.185];

/// What a ray hit first.
struct SurfaceHit {
    distance: f32,
    normal: Vec3,
    albedo: Vec3,
    shininess: f32,
    is_ground: bool,
}

impl Stage {
    /// Sky colour for image row `y` of `height` rows.
    pub fn sky(&self, y: f32, height: f32) -> Vec3 {
        self.sky_top
            .lerp(self.sky_bottom, (y / height).clamp(0.0, 1.0))
    }

    /// Fills every sample of `film` with the sky or the nearest surface.
    /// `shadow` gives the fraction of key light reaching a surface point
    /// (1 when nothing casts shadows).
    pub fn draw(
        &self,
        film: &mut Film,
        camera: &CameraView,
        shadow: &(dyn Fn(Vec3) -> f32 + Sync),
    ) {
        let height = film.height as f32;
        let fog = self.fog_range(camera.eye);
        let tile = self.ground_tile();
        film.par_bands(|_, band| {
            for y in band.rows() {
                for x in 0..band.width {
                    let pixel = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    let direction = camera.ray(pixel);
                    let index = band.index(x, y);
                    match self.trace(camera.eye, direction, tile) {
                        Some(hit) => {
                            let point = camera.eye + direction * hit.distance;
                            let lit = self.shade(&hit, direction, shadow(point));
                            let haze = if hit.is_ground {
                                ((hit.distance - fog.0) / fog.1).clamp(0.0, 1.0)
                            } else {
                                0.0
                            };
                            band.color[index] = lit.lerp(self.sky(pixel.y, height), haze);
                            band.depth[index] = hit.distance * direction.dot(camera.forward);
                        }
                        None => band.color[index] = self.sky(pixel.y, height),
                    }
                }
            }
        });
    }

    /// The nearest surface along the ray, if any; `tile` is the ground's checker size.
    fn trace(&self, origin: Vec3, direction: Vec3, tile: f32) -> Option<SurfaceHit> {
        let mut best: Option<SurfaceHit> = None;
        let mut consider = |hit: Option<SurfaceHit>| {
            if let Some(hit) = hit
                && best.as_ref().is_none_or(|b| hit.distance < b.distance)
            {
                best = Some(hit);
            }
        };
        if let Some(height) = self.ground {
            consider(hit_ground(origin, direction, height, tile));
        }
        for collider in &self.colliders {
            consider(self.hit_collider(collider, origin, direction));
        }
        for body in &self.bodies {
            let hit = self.hit_collider(body, origin, direction);
            consider(hit.map(|hit| SurfaceHit {
                albedo: BODY_ALBEDO,
                ..hit
            }));
        }
        best
    }

    /// Edge of the ground's checker tiles: a round number near a tenth of the container.
    pub fn ground_tile(&self) -> f32 {
        self.container.map_or(0.1, |(min, max)| {
            let extent = (max - min).max_element();
            10f32.powf((extent * 0.1).log10().round())
        })
    }

    /// Where a ray meets `collider`: traced in the collider's own frame
    /// when it is turned, the normal turned back.
    fn hit_collider(
        &self,
        collider: &StageCollider,
        origin: Vec3,
        direction: Vec3,
    ) -> Option<SurfaceHit> {
        if collider.rotation == Quat::IDENTITY {
            return self.hit_unturned(collider, origin, direction);
        }
        let center = collider.geometry.reference_point();
        let inverse = collider.rotation.inverse();
        let local_origin = center + inverse * (origin - center);
        let mut hit = self.hit_unturned(collider, local_origin, inverse * direction)?;
        hit.normal = collider.rotation * hit.normal;
        Some(hit)
    }

    /// Where a ray meets `collider` in its own frame: its deformed mesh
    /// where it has one, else its geometry.
    fn hit_unturned(
        &self,
        collider: &StageCollider,
        origin: Vec3,
        direction: Vec3,
    ) -> Option<SurfaceHit> {
        let Some(deformed) = &collider.deformed else {
            return self.hit_geometry(&collider.geometry, origin, direction);
        };
        let field = deformed.field();
        let steps = mesh_steps(deformed.sdf_spacing);
        march(
            |p| field.sample(p),
            field.bounds(),
            steps,
            origin,
            direction,
        )
        .map(solid_hit)
    }

    fn hit_geometry(
        &self,
        collider: &ColliderGeometry,
        origin: Vec3,
        direction: Vec3,
    ) -> Option<SurfaceHit> {
        let distance_to = |p| collider.signed_distance(p);
        match *collider {
            ColliderGeometry::Sphere { center, radius } => {
                let distance = intersect_sphere(origin, direction, center, radius)?;
                let normal = (origin + direction * distance - center).normalize();
                Some(solid_hit((distance, normal)))
            }
            ColliderGeometry::Box { center, size } => {
                intersect_box(origin, direction, center - 0.5 * size, center + 0.5 * size)
                    .map(solid_hit)
            }
            ColliderGeometry::Mesh(ref mesh) => {
                let steps = mesh_steps(mesh.sdf_spacing);
                march(distance_to, mesh.bounds(), steps, origin, direction).map(solid_hit)
            }
            ColliderGeometry::Cylinder { center, .. }
            | ColliderGeometry::Capsule { center, .. } => {
                let reach = Vec3::splat(collider.reach());
                let bounds = (center - reach, center + reach);
                let steps = (1e-4 * reach.x, 0.0);
                march(distance_to, bounds, steps, origin, direction).map(solid_hit)
            }
            // Drawn through the stage collider's deformed mesh
            // (`hit_unturned`); the sequence alone has no time.
            ColliderGeometry::MeshSequence(_) => None,
            ColliderGeometry::HalfPlane { point, normal } => {
                let distance = intersect_plane(origin, direction, point, normal)?;
                let hit = origin + direction * distance;
                // A plane is drawn only inside the container (it bounds the snow there).
                let inside = self.container.is_none_or(|(min, max)| {
                    let margin = 1e-3 * (max - min).max_element();
                    hit.cmpge(min - margin).all() && hit.cmple(max + margin).all()
                });
                inside.then_some(SurfaceHit {
                    distance,
                    normal,
                    albedo: WALL_ALBEDO,
                    shininess: 16.0,
                    is_ground: false,
                })
            }
        }
    }

    /// The colour of a fully lit solid point with `normal` and `albedo`, seen
    /// along the unit ray `direction`: the colliders' shading, for other
    /// solids (the snow's surface).
    pub fn shade_solid(&self, normal: Vec3, direction: Vec3, albedo: Vec3, shininess: f32) -> Vec3 {
        let hit = SurfaceHit {
            distance: 0.0,
            normal,
            albedo,
            shininess,
            is_ground: false,
        };
        self.shade(&hit, direction, 1.0)
    }

    /// Blinn-Phong: ambient + diffuse + specular, the key light scaled by `light_fraction`.
    fn shade(&self, hit: &SurfaceHit, direction: Vec3, light_fraction: f32) -> Vec3 {
        let light = &self.light;
        // Planes are seen from either side.
        let normal = if hit.normal.dot(direction) > 0.0 {
            -hit.normal
        } else {
            hit.normal
        };
        let diffuse = normal.dot(light.direction).max(0.0);
        let mut color = hit.albedo * (light.ambient + light.color * diffuse * light_fraction);
        if hit.shininess > 0.0 && diffuse > 0.0 {
            let half = (light.direction - direction).normalize();
            let specular = normal.dot(half).max(0.0).powf(hit.shininess);
            color += light.color * (0.35 * specular * light_fraction);
        }
        color
    }

    /// Where the ground starts fading into the sky and over what distance
    /// from `eye`, so the far plane meets the horizon softly.
    pub fn fog_range(&self, eye: Vec3) -> (f32, f32) {
        let Some((min, max)) = self.container else {
            return (f32::INFINITY, 1.0);
        };
        let center = 0.5 * (min + max);
        let reach = (eye - center).length() + (max - min).length();
        (reach * 0.6, reach * 1.4)
    }
}

/// A collider's surface `distance` along a ray with `normal`: solids share
/// one look, a glossy rigid body.
fn solid_hit((distance, normal): (f32, Vec3)) -> SurfaceHit {
    SurfaceHit {
        distance,
        normal,
        albedo: COLLIDER_ALBEDO,
        shininess: 48.0,
        is_ground: false,
    }
}

/// The ground plane at `height`, a checkerboard of `tile`-sized squares.
fn hit_ground(origin: Vec3, direction: Vec3, height: f32, tile: f32) -> Option<SurfaceHit> {
    let distance = intersect_plane(origin, direction, Vec3::new(0.0, height, 0.0), Vec3::Y)?;
    let point = origin + direction * distance;
    let parity = ((point.x / tile).floor() + (point.z / tile).floor()) as i64 & 1;
    Some(SurfaceHit {
        distance,
        normal: Vec3::Y,
        albedo: Vec3::splat(GROUND_ALBEDO[parity as usize]),
        shininess: 0.0,
        is_ground: true,
    })
}

/// Distance along a unit ray to a plane through `point` with `normal`.
fn intersect_plane(origin: Vec3, direction: Vec3, point: Vec3, normal: Vec3) -> Option<f32> {
    let denominator = direction.dot(normal);
    if denominator.abs() < 1e-8 {
        return None;
    }
    let distance = (point - origin).dot(normal) / denominator;
    (distance > 0.0).then_some(distance)
}

/// Distance along a unit ray to the first intersection with a sphere.
fn intersect_sphere(origin: Vec3, direction: Vec3, center: Vec3, radius: f32) -> Option<f32> {
    let offset = origin - center;
    let b = offset.dot(direction);
    let c = offset.length_squared() - radius * radius;
    let discriminant = b * b - c;
    if discriminant < 0.0 {
        return None;
    }
    let root = discriminant.sqrt();
    [-b - root, -b + root].into_iter().find(|&t| t > 0.0)
}

/// Distance and outward normal of the first intersection with an axis-aligned box.
pub fn intersect_box(origin: Vec3, direction: Vec3, min: Vec3, max: Vec3) -> Option<(f32, Vec3)> {
    let (near, far) = slab_interval(origin, direction, min, max)?;
    let distance = if near > 0.0 { near } else { far };
    if distance <= 0.0 {
        return None;
    }
    let point = origin + direction * distance;
    let center = 0.5 * (min + max);
    let local = (point - center) / (0.5 * (max - min)).max(Vec3::splat(1e-12));
    let axis = local.abs().max_position();
    let mut normal = Vec3::ZERO;
    normal[axis] = local[axis].signum();
    Some((distance, normal))
}

/// The first crossing of a unit ray with a solid's surface inside the box
/// `low..high`, found by sphere tracing its signed distance `distance_to`
/// (Hart 1996): each step advances by the distance to the nearest surface,
/// which cannot overshoot it, and by at least `min_step`; a point nearer
/// than `surface` is on it.
fn march(
    distance_to: impl Fn(Vec3) -> (f32, Vec3),
    (low, high): (Vec3, Vec3),
    (surface, min_step): (f32, f32),
    origin: Vec3,
    direction: Vec3,
) -> Option<(f32, Vec3)> {
    const MAX_STEPS: u32 = 512;
    let (near, far) = slab_interval(origin, direction, low, high)?;
    let mut distance = near.max(0.0);
    for _ in 0..MAX_STEPS {
        if distance > far {
            return None;
        }
        let (gap, normal) = distance_to(origin + direction * distance);
        if gap < surface {
            return Some((distance, normal));
        }
        distance += gap.max(min_step);
    }
    None
}

/// The surface tolerance and the least step of [`march`] through a mesh's
/// distance field sampled `spacing` apart.
fn mesh_steps(spacing: f32) -> (f32, f32) {
    (0.05 * spacing, 0.1 * spacing)
}

/// The parameter interval [near, far] in which a ray is inside a box, if any.
pub fn slab_interval(origin: Vec3, direction: Vec3, min: Vec3, max: Vec3) -> Option<(f32, f32)> {
    let inverse = direction.recip();
    let a = (min - origin) * inverse;
    let b = (max - origin) * inverse;
    let near = a.min(b).max_element();
    let far = a.max(b).min_element();
    (far >= near.max(0.0)).then_some((near, far))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_hits_sphere_front_face() {
        let t = intersect_sphere(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z, Vec3::ZERO, 1.0);
        assert_eq!(t, Some(4.0));
        assert_eq!(
            intersect_sphere(Vec3::new(0.0, 2.0, 5.0), Vec3::NEG_Z, Vec3::ZERO, 1.0),
            None
        );
    }

    #[test]
    fn ray_hits_box_with_the_face_normal() {
        let (t, normal) = intersect_box(
            Vec3::new(0.2, 0.1, 5.0),
            Vec3::NEG_Z,
            Vec3::splat(-1.0),
            Vec3::ONE,
        )
        .expect("hit");
        assert!((t - 4.0).abs() < 1e-6);
        assert_eq!(normal, Vec3::Z);
    }

    #[test]
    fn nearer_collider_wins() {
        let stage = Stage {
            colliders: vec![
                ColliderGeometry::Sphere {
                    center: Vec3::new(0.0, 0.0, -3.0),
                    radius: 1.0,
                }
                .into(),
                ColliderGeometry::Sphere {
                    center: Vec3::new(0.0, 0.0, -1.0),
                    radius: 0.5,
                }
                .into(),
            ],
            ..Stage::default()
        };
        let hit = stage
            .trace(Vec3::new(0.0, 0.0, 2.0), Vec3::NEG_Z, 0.1)
            .expect("hit");
        assert!((hit.distance - 2.5).abs() < 1e-5);
    }
}
