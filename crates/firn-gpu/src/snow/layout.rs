//! Host mirrors of the structs in `shaders/snow/layout.wgsl` and
//! `shaders/common/*.wgsl`, byte for byte.

use bytemuck::{Pod, Zeroable};
use firn_core::scene::{ColliderGeometry, ContactMode, Motion, PathShape};
use firn_mpm::snow_model::MaterialConstants;
use glam::{Mat3, Vec3};

use super::sequences::SequenceRegion;

/// `Params`: the run's constants and the current frame's time window.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Params {
    pub origin: [f32; 4],
    pub dims: [u32; 4],
    pub gravity: [f32; 4],
    pub lower: [f32; 4],
    pub upper: [f32; 4],
    pub stepping: [f32; 4],
    pub scales: [f32; 4],
    pub flags: [u32; 4],
    pub implicit: [f32; 4],
}

/// `StepState`: what the substeps of a frame share.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct StepState {
    pub dt: f32,
    pub elapsed: f32,
    pub running: u32,
    pub steps: u32,
    pub max_speed_bits: u32,
    pub max_wave_bits: u32,
    pub non_finite: u32,
    pub left_domain: u32,
    pub overflow: u32,
    pub speed_squared: f32,
    pub wave_speed_squared: f32,
    pub waiting: u32,
    pub grid_blocks: u32,
}

/// The head of `SolveState` (`shaders/snow/implicit.wgsl`), before its
/// partial sums: how the last substep's semi-implicit solve went.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct SolveHeader {
    pub running: u32,
    pub solved: u32,
    pub iterations: u32,
    pub converged: u32,
    pub active_nodes: u32,
    pub residual: f32,
    pub momentum: f32,
    pub stop_at: f32,
    pub reference: f32,
    pub rz: f32,
    pub z_sz: f32,
    pub denominator: f32,
    pub alpha: f32,
    pub gamma: f32,
    pub pad: [u32; 2],
}

/// `StepState::waiting` when the particles reached more grid blocks than the
/// grid has room for (`WAITING_FOR_GRID_BLOCKS` in `begin_step.wgsl`).
pub const WAITING_FOR_GRID_BLOCKS: u32 = 2;

/// No particle: the "none" value of the trouble indices.
pub const NO_PARTICLE: u32 = u32::MAX;

/// `Material`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuMaterial {
    pub mu0: f32,
    pub lambda0: f32,
    pub hardening: f32,
    pub min_stretch: f32,
    pub max_stretch: f32,
    pub wave_speed_squared: f32,
    pub density: f32,
    pub pad: f32,
}

impl From<&MaterialConstants> for GpuMaterial {
    fn from(constants: &MaterialConstants) -> GpuMaterial {
        GpuMaterial {
            mu0: constants.mu0,
            lambda0: constants.lambda0,
            hardening: constants.hardening,
            min_stretch: constants.min_stretch,
            max_stretch: constants.max_stretch,
            wave_speed_squared: constants.wave_speed_squared,
            density: 0.0,
            pad: 0.0,
        }
    }
}

/// `Collider`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuCollider {
    pub shape: u32,
    pub contact: u32,
    pub friction: f32,
    pub motion: u32,
    pub first_key: u32,
    pub key_count: u32,
    pub turns: u32,
    pub path: u32,
    pub reference: [f32; 4],
    pub extent: [f32; 4],
    pub velocity: [f32; 4],
    pub angular_velocity: [f32; 4],
    pub rotation: [f32; 4],
    pub sdf_origin: [f32; 4],
    pub sdf_dims: [u32; 4],
}

/// `ColliderPose` (`shaders/common/colliders.wgsl`): a placed collider as
/// the contact kernels read it; `position.w` is 1 for a turned one.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuColliderPose {
    pub position: [f32; 4],
    pub velocity: [f32; 4],
    pub rotation: [f32; 4],
    pub angular_velocity: [f32; 4],
}

/// `PlacedBody` (`shaders/snow/layout.wgsl`): a rigid body as the grid
/// update meets it in one substep.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuPlacedBody {
    pub collider: GpuCollider,
    pub pose: GpuColliderPose,
    pub center_of_mass: [f32; 4],
}

/// `PlasticState`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuPlastic {
    pub plastic_j: f32,
    pub material: u32,
}

/// A `mat3x3<f32>` in storage layout: three columns padded to 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuMat3(pub [[f32; 4]; 3]);

impl From<Mat3> for GpuMat3 {
    fn from(m: Mat3) -> GpuMat3 {
        GpuMat3([
            m.x_axis.extend(0.0).into(),
            m.y_axis.extend(0.0).into(),
            m.z_axis.extend(0.0).into(),
        ])
    }
}

impl From<GpuMat3> for Mat3 {
    fn from(m: GpuMat3) -> Mat3 {
        let column = |c: [f32; 4]| Vec3::new(c[0], c[1], c[2]);
        Mat3::from_cols(column(m.0[0]), column(m.0[1]), column(m.0[2]))
    }
}

/// The colliders as the kernels read them: the colliders (scene colliders,
/// then the six walls), their keyframes (two vectors a key: position and
/// time, then the orientation quaternion) and the fields of the mesh
/// colliders, one after another (a rigid mesh's signed distances as f32
/// bits, a deforming mesh's region, whose bands come when the run needs
/// them).
#[derive(Debug, Default)]
pub struct PackedColliders {
    pub colliders: Vec<GpuCollider>,
    pub keys: Vec<[f32; 4]>,
    pub fields: Vec<u32>,
    pub sequences: Vec<SequenceRegion>,
}

/// Packs `colliders` for the kernels.
pub fn pack_colliders(colliders: &[firn_core::scene::Collider]) -> PackedColliders {
    let mut packed = Vec::with_capacity(colliders.len());
    let mut keys = Vec::new();
    let mut fields = Vec::new();
    let mut sequences = Vec::new();
    for (index, collider) in colliders.iter().enumerate() {
        let mut gpu = GpuCollider {
            contact: match collider.contact.mode {
                ContactMode::Sticky => 0,
                ContactMode::Separate => 1,
                ContactMode::Slip => 2,
            },
            friction: collider.contact.friction,
            turns: u32::from(collider.turns()),
            rotation: collider.rotation.to_array(),
            ..GpuCollider::default()
        };
        match collider.geometry {
            ColliderGeometry::HalfPlane { point, normal } => {
                gpu.shape = 0;
                gpu.reference = point.extend(0.0).into();
                gpu.extent = normal.extend(0.0).into();
            }
            ColliderGeometry::Sphere { center, radius } => {
                gpu.shape = 1;
                gpu.reference = center.extend(radius).into();
            }
            ColliderGeometry::Box { center, size } => {
                gpu.shape = 2;
                gpu.reference = center.extend(0.0).into();
                gpu.extent = size.extend(0.0).into();
            }
            ColliderGeometry::Cylinder {
                center,
                radius,
                height,
            } => {
                gpu.shape = 4;
                gpu.reference = center.extend(0.0).into();
                gpu.extent = [radius, height, 0.0, 0.0];
            }
            ColliderGeometry::Capsule {
                center,
                radius,
                height,
            } => {
                gpu.shape = 6;
                gpu.reference = center.extend(0.0).into();
                gpu.extent = [radius, height, 0.0, 0.0];
            }
            ColliderGeometry::MeshSequence(ref sequence) => {
                let region = SequenceRegion::reserve(index, sequence, &mut fields);
                gpu.shape = 5;
                gpu.reference = sequence.reference_point().extend(0.0).into();
                gpu.extent = [sequence.start as f32, sequence.frame_rate as f32, 0.0, 0.0];
                gpu.sdf_dims = [
                    sequence.frame_count.saturating_sub(1),
                    0,
                    0,
                    region.offset(),
                ];
                sequences.push(region);
            }
            ColliderGeometry::Mesh(ref mesh) => {
                // The field is sampled around the time-zero placement; the
                // collider's motion moves its reference point (the centre).
                let field = mesh.field.get();
                gpu.shape = 3;
                gpu.reference = mesh.center.extend(0.0).into();
                gpu.extent = mesh.placement.center.extend(0.0).into();
                gpu.sdf_origin = field.bounds().0.extend(field.spacing()).into();
                gpu.sdf_dims = field.dims().extend(fields.len() as u32).into();
                fields.extend(field.values().iter().map(|d| d.to_bits()));
            }
        }
        match &collider.motion {
            Motion::Static => gpu.motion = 0,
            Motion::Linear {
                velocity,
                angular_velocity,
            } => {
                gpu.motion = 1;
                gpu.velocity = velocity.extend(0.0).into();
                gpu.angular_velocity = angular_velocity.extend(0.0).into();
            }
            Motion::Keyframed { keys: frames, path } => {
                gpu.motion = 2;
                gpu.path = match path {
                    PathShape::Linear => 0,
                    PathShape::CatmullRom => 1,
                };
                gpu.first_key = (keys.len() / 2) as u32;
                gpu.key_count = frames.len() as u32;
                for key in frames {
                    keys.push(key.position.extend(key.time as f32).to_array());
                    keys.push(key.rotation.to_array());
                }
            }
        }
        packed.push(gpu);
    }
    PackedColliders {
        colliders: packed,
        keys,
        fields,
        sequences,
    }
}
