//! Triangle meshes in a scene: snow bodies filled from a mesh, and mesh
//! colliders.
//!
//! A mesh file is placed by scaling it, rotating it and moving the centre of
//! its bounding box to a point of the scene. Bodies decide inside and outside
//! by the generalized winding number (Jacobson et al. 2013), so scanned meshes
//! with holes fill correctly; colliders sample a signed distance field built
//! once at the start and moved rigidly with the collider.
//!
//! The loaded geometry is derived from the placement, so it is not serialized:
//! a scene read back from a manifest calls [`crate::Scene::load_meshes`].

use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

use firn_mesh::{
    LoadedMesh, MeshError, MeshTransform, SignedDistanceField, TriangleMesh, WindingNumber,
    load_mesh,
};
use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

/// Where a mesh file goes in the scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshPlacement {
    /// The mesh file (OBJ, STL or PLY), resolved against the scene file's folder.
    pub file: PathBuf,
    /// Scale factors along the mesh's own x, y and z, applied first.
    pub scale: Vec3,
    /// Rotation in degrees about the x, then the y, then the z axis, applied
    /// after scaling.
    pub rotation_degrees: Vec3,
    /// Where the centre of the scaled and rotated mesh's bounding box goes.
    pub center: Vec3,
}

impl MeshPlacement {
    /// Loads the file and places its triangles in the scene.
    pub fn load(&self) -> Result<PlacedMesh, MeshError> {
        let LoadedMesh { mesh, diagnostics } = load_mesh(&self.file)?;
        let oriented = mesh.transformed(&MeshTransform {
            scale: self.scale,
            rotation: self.rotation(),
            translation: Vec3::ZERO,
        });
        let (low, high) = oriented.bounds();
        let offset = self.center - 0.5 * (low + high);
        let placed = oriented.transformed(&MeshTransform {
            translation: offset,
            ..MeshTransform::IDENTITY
        });
        Ok(PlacedMesh {
            mesh: placed,
            warnings: diagnostics.warnings(),
        })
    }

    /// The rotation: x first, then y, then z, about the fixed axes.
    pub fn rotation(&self) -> Quat {
        crate::scene::motion::rotation_from_degrees(self.rotation_degrees)
    }
}

/// A mesh in scene coordinates, with what its inspection found.
pub struct PlacedMesh {
    /// Triangles in scene coordinates.
    pub mesh: TriangleMesh,
    /// Problems found in the mesh (holes, non-manifold edges, ...), one
    /// sentence each; the mesh is still usable.
    pub warnings: Vec<String>,
}

/// Geometry derived from a placement: shared, skipped by serde, and equal to
/// any other (the placement it comes from is what compares).
pub struct Derived<T>(Option<Arc<T>>);

impl<T> Default for Derived<T> {
    fn default() -> Self {
        Derived(None)
    }
}

impl<T> Clone for Derived<T> {
    fn clone(&self) -> Self {
        Derived(self.0.clone())
    }
}

impl<T> Derived<T> {
    /// Wraps freshly built geometry.
    pub fn new(value: T) -> Derived<T> {
        Derived(Some(Arc::new(value)))
    }

    /// Whether the geometry has been built.
    pub fn is_loaded(&self) -> bool {
        self.0.is_some()
    }

    /// The geometry.
    ///
    /// # Panics
    ///
    /// If it was never built: a scene from [`crate::Scene::load`] has it, and
    /// one deserialized from JSON gets it from [`crate::Scene::load_meshes`].
    pub fn get(&self) -> &T {
        self.0
            .as_deref()
            .expect("mesh geometry is built by Scene::load or Scene::load_meshes")
    }
}

impl<T> PartialEq for Derived<T> {
    fn eq(&self, _other: &Self) -> bool {
        true
    }
}

impl<T> fmt::Debug for Derived<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.is_loaded() {
            "Derived(loaded)"
        } else {
            "Derived(not loaded)"
        })
    }
}

/// A body of snow shaped by a triangle mesh.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshBody {
    /// The file and how it is placed.
    pub placement: MeshPlacement,
    /// Lower corner of the placed mesh's bounding box.
    pub min: Vec3,
    /// Upper corner of the placed mesh's bounding box.
    pub max: Vec3,
    /// What the inspection of the mesh found, one sentence each.
    pub warnings: Vec<String>,
    /// The volume the placed mesh encloses, m³ (what its particles fill).
    #[serde(skip)]
    pub volume: f64,
    /// Inside test of the placed mesh.
    #[serde(skip)]
    pub solid: Derived<WindingNumber>,
}

impl MeshBody {
    /// Loads and places the mesh and builds its inside test.
    pub fn load(placement: MeshPlacement) -> Result<MeshBody, MeshError> {
        let mut body = MeshBody {
            placement,
            min: Vec3::ZERO,
            max: Vec3::ZERO,
            warnings: Vec::new(),
            volume: 0.0,
            solid: Derived::default(),
        };
        body.build()?;
        Ok(body)
    }

    /// (Re)builds the derived inside test from the placement.
    pub fn build(&mut self) -> Result<(), MeshError> {
        let placed = self.placement.load()?;
        (self.min, self.max) = placed.mesh.bounds();
        self.warnings = placed.warnings;
        self.volume = placed.mesh.enclosed_volume();
        self.solid = Derived::new(WindingNumber::new(&placed.mesh));
        Ok(())
    }

    /// Whether a point is inside: winding number above ½.
    pub fn contains(&self, point: Vec3) -> bool {
        self.solid.get().contains(point)
    }
}

/// Largest number of signed distance samples a mesh collider may take (64 MiB).
pub const MAX_SDF_SAMPLES: u64 = 1 << 24;

/// A rigid collider shaped by a triangle mesh; snow is kept outside of it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshCollider {
    /// The file and how it is placed at time zero.
    pub placement: MeshPlacement,
    /// The current position of the bounding-box centre (the collider's
    /// reference point); `placement.center` at time zero.
    pub center: Vec3,
    /// Spacing of the signed distance samples in metres.
    pub sdf_spacing: f32,
    /// What the inspection of the mesh found, one sentence each.
    pub warnings: Vec<String>,
    /// Signed distances around the mesh at its time-zero placement.
    #[serde(skip)]
    pub field: Derived<SignedDistanceField>,
}

impl MeshCollider {
    /// Samples of padding around the mesh on every side of the field.
    pub const PADDING_SAMPLES: u32 = 3;

    /// Loads and places the mesh and samples its signed distance field,
    /// unless the field would take more than [`MAX_SDF_SAMPLES`] samples.
    pub fn load(placement: MeshPlacement, sdf_spacing: f32) -> Result<MeshCollider, MeshError> {
        let placed = placement.load()?;
        let samples = MeshCollider::sdf_samples(placed.mesh.bounds(), sdf_spacing);
        if samples > MAX_SDF_SAMPLES {
            return Err(MeshError {
                path: placement.file.clone(),
                line: None,
                message: format!(
                    "at sdf_spacing = {sdf_spacing} m its signed distance field would take \
                     {samples} samples, more than {MAX_SDF_SAMPLES}"
                ),
                hint: "raise sdf_spacing, or scale the mesh down".into(),
            });
        }
        Ok(MeshCollider::from_placed(placement, placed, sdf_spacing))
    }

    /// Samples of the field of a mesh with bounds `(low, high)` at
    /// `spacing`, padding included (saturating at `u64::MAX`).
    pub fn sdf_samples((low, high): (Vec3, Vec3), spacing: f32) -> u64 {
        let padding = 2.0 * MeshCollider::PADDING_SAMPLES as f32;
        ((high - low) / spacing + padding)
            .to_array()
            .iter()
            .map(|n| (n.ceil().max(1.0) as u64).saturating_add(1))
            .fold(1u64, u64::saturating_mul)
    }

    /// Samples the signed distance field of an already placed mesh.
    pub fn from_placed(
        placement: MeshPlacement,
        placed: PlacedMesh,
        sdf_spacing: f32,
    ) -> MeshCollider {
        let padding = Self::PADDING_SAMPLES as f32 * sdf_spacing;
        MeshCollider {
            center: placement.center,
            placement,
            sdf_spacing,
            warnings: placed.warnings,
            field: Derived::new(SignedDistanceField::build(
                &placed.mesh,
                sdf_spacing,
                padding,
            )),
        }
    }

    /// (Re)builds the derived signed distance field from the placement.
    pub fn build(&mut self) -> Result<(), MeshError> {
        let rebuilt = MeshCollider::load(self.placement.clone(), self.sdf_spacing)?;
        self.warnings = rebuilt.warnings;
        self.field = rebuilt.field;
        Ok(())
    }

    /// Signed distance (negative inside) and outward normal at `point`, with
    /// the collider at its current position.
    pub fn signed_distance(&self, point: Vec3) -> (f32, Vec3) {
        let shift = self.center - self.placement.center;
        self.field.get().sample(point - shift)
    }

    /// The bounding box of the sampled field at the current position.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let shift = self.center - self.placement.center;
        let (low, high) = self.field.get().bounds();
        (low + shift, high + shift)
    }
}

impl crate::Scene {
    /// Builds the geometry of every mesh body, collider and rigid body that
    /// lacks it, as after reading the scene back from JSON.
    pub fn load_meshes(&mut self) -> Result<(), MeshError> {
        for body in &mut self.bodies {
            if let crate::scene::Shape::Mesh(mesh) = &mut body.shape
                && !mesh.solid.is_loaded()
            {
                mesh.build()?;
            }
        }
        for collider in &mut self.colliders {
            match &mut collider.geometry {
                crate::scene::ColliderGeometry::Mesh(mesh) if !mesh.field.is_loaded() => {
                    mesh.build()?;
                }
                crate::scene::ColliderGeometry::MeshSequence(sequence)
                    if !sequence.frames.is_loaded() =>
                {
                    sequence.build()?;
                }
                _ => {}
            }
        }
        for body in &mut self.rigid_bodies {
            if let crate::scene::ColliderGeometry::Mesh(mesh) = &mut body.geometry
                && !mesh.field.is_loaded()
            {
                mesh.build()?;
            }
        }
        Ok(())
    }

    /// What the inspection of the scene's meshes found, each prefixed by the
    /// body, collider or rigid body it belongs to, e.g.
    /// `bodies[0] (bunny.obj): ...`.
    pub fn mesh_warnings(&self) -> Vec<String> {
        let bodies = self.bodies.iter().enumerate().filter_map(|(index, body)| {
            let crate::scene::Shape::Mesh(mesh) = &body.shape else {
                return None;
            };
            Some((
                format!("bodies[{index}]"),
                &mesh.placement.file,
                &mesh.warnings,
            ))
        });
        let colliders = self
            .colliders
            .iter()
            .enumerate()
            .filter_map(|(index, collider)| {
                let (file, warnings) = match &collider.geometry {
                    crate::scene::ColliderGeometry::Mesh(mesh) => {
                        (&mesh.placement.file, &mesh.warnings)
                    }
                    crate::scene::ColliderGeometry::MeshSequence(sequence) => {
                        (&sequence.pattern, &sequence.warnings)
                    }
                    _ => return None,
                };
                Some((format!("colliders[{index}]"), file, warnings))
            });
        let rigid_bodies = self
            .rigid_bodies
            .iter()
            .enumerate()
            .filter_map(|(index, body)| match &body.geometry {
                crate::scene::ColliderGeometry::Mesh(mesh) => Some((
                    format!("rigid_bodies[{index}]"),
                    &mesh.placement.file,
                    &mesh.warnings,
                )),
                _ => None,
            });
        bodies
            .chain(colliders)
            .chain(rigid_bodies)
            .flat_map(|(owner, file, warnings)| {
                let file = file.display().to_string();
                warnings
                    .iter()
                    .map(move |warning| format!("{owner} ({file}): {warning}"))
            })
            .collect()
    }
}
