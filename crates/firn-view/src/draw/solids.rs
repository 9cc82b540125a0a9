//! Colliders and rigid bodies as shaded triangles (`solids.wgsl`): spheres
//! (a flow's obstacles too), boxes and cylinders scale a unit shape, a
//! capsule is a cylinder and the two spheres of its ends, mesh colliders
//! and bodies keep the triangles loaded once and move with their centre,
//! and planes (clipped to the container) and deforming meshes (their
//! triangles of the instant, without a distance field) are uploaded afresh
//! each frame. Bodies are drawn in their own colour (`BODY_ALBEDO`).

use std::ops::Range;

use bytemuck::{Pod, Zeroable};
use firn_core::Scene;
use firn_core::scene::{ColliderGeometry, MeshCollider, MeshPlacement};
use firn_render::stage::{BODY_ALBEDO, COLLIDER_ALBEDO, Stage, StageCollider, WALL_ALBEDO};
use glam::{Quat, Vec3};

use super::geometry::{
    SurfaceVertex, mesh_triangles, plane_polygon, unit_cube, unit_cylinder, unit_sphere,
};
use super::gpu::{
    ColorTarget, DepthUse, GrowingBuffer, PipelineSpec, fill_at_creation, render_pipeline,
    shader_module,
};

/// Blinn-Phong exponent of spheres, boxes and meshes (as firn_render::stage shades them).
const COLLIDER_SHININESS: f32 = 48.0;
/// Blinn-Phong exponent of walls (as firn_render::stage shades them).
const WALL_SHININESS: f32 = 16.0;

const SHADER: [&str; 2] = [
    include_str!("../../shaders/frame.wgsl"),
    include_str!("../../shaders/solids.wgsl"),
];

/// Where and how one collider is drawn (`SolidIn` locations 2 to 7): a
/// vertex p goes to pivot + rotation (p · scale + offset − pivot).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct SolidInstance {
    offset: [f32; 3],
    scale: [f32; 3],
    albedo: [f32; 3],
    shininess: f32,
    rotation: [f32; 4],
    pivot: [f32; 3],
}

impl SolidInstance {
    fn new(offset: Vec3, scale: Vec3, albedo: Vec3, shininess: f32) -> SolidInstance {
        SolidInstance {
            offset: offset.to_array(),
            scale: scale.to_array(),
            albedo: albedo.to_array(),
            shininess,
            rotation: Quat::IDENTITY.to_array(),
            pivot: offset.to_array(),
        }
    }

    /// The same instance turned by `rotation` about `pivot`.
    fn turned(mut self, rotation: Quat, pivot: Vec3) -> SolidInstance {
        self.rotation = rotation.to_array();
        self.pivot = pivot.to_array();
        self
    }
}

const SURFACE_ATTRIBUTES: [wgpu::VertexAttribute; 2] =
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];
const INSTANCE_ATTRIBUTES: [wgpu::VertexAttribute; 6] = wgpu::vertex_attr_array![
    2 => Float32x3, 3 => Float32x3, 4 => Float32x3, 5 => Float32, 6 => Float32x4, 7 => Float32x3
];

/// Triangles in a vertex buffer.
struct Shape {
    vertices: wgpu::Buffer,
    count: u32,
}

impl Shape {
    fn new(device: &wgpu::Device, label: &str, vertices: &[SurfaceVertex]) -> Shape {
        Shape {
            vertices: fill_at_creation(
                device,
                label,
                wgpu::BufferUsages::VERTEX,
                bytemuck::cast_slice(vertices),
            ),
            count: vertices.len() as u32,
        }
    }
}

/// A mesh collider's triangles at its time-zero placement.
struct PlacedShape {
    placement: MeshPlacement,
    shape: Shape,
}

/// Which triangles one collider draws.
#[derive(Clone, Debug)]
enum Triangles {
    Sphere,
    Cube,
    Cylinder,
    Mesh(usize),
    /// A range of this frame's own vertices: a clipped plane or a
    /// deforming mesh as it is now.
    ThisFrame(Range<u32>),
}

/// One collider of this frame: its triangles and its instance.
struct SolidDraw {
    triangles: Triangles,
    instance: u32,
}

/// The colliders' pipeline, shapes and per-frame instances.
pub(super) struct Solids {
    pipeline: wgpu::RenderPipeline,
    sphere: Shape,
    cube: Shape,
    cylinder: Shape,
    meshes: Vec<PlacedShape>,
    instances: GrowingBuffer,
    this_frame: GrowingBuffer,
    draws: Vec<SolidDraw>,
}

impl Solids {
    /// The pipeline, the unit shapes, and the triangles of the scene's mesh
    /// colliders. A mesh whose file cannot be read again is not drawn.
    pub(super) fn new(
        device: &wgpu::Device,
        target: ColorTarget,
        frame_layout: &wgpu::BindGroupLayout,
        scene: &Scene,
    ) -> Solids {
        let module = shader_module(device, "firn-view solids", &SHADER);
        let buffers = [
            Some(wgpu::VertexBufferLayout {
                array_stride: size_of::<SurfaceVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &SURFACE_ATTRIBUTES,
            }),
            Some(wgpu::VertexBufferLayout {
                array_stride: size_of::<SolidInstance>() as u64,
                step_mode: wgpu::VertexStepMode::Instance,
                attributes: &INSTANCE_ATTRIBUTES,
            }),
        ];
        let pipeline = render_pipeline(
            device,
            target,
            &PipelineSpec {
                label: "firn-view solids",
                groups: &[frame_layout],
                module: &module,
                vertex: "vertex_solid",
                fragment: "fragment_solid",
                buffers: &buffers,
                topology: wgpu::PrimitiveTopology::TriangleList,
                depth: DepthUse::TestAndWrite,
                additive: false,
            },
        );
        Solids {
            pipeline,
            sphere: Shape::new(device, "firn-view unit sphere", &unit_sphere()),
            cube: Shape::new(device, "firn-view unit cube", &unit_cube()),
            cylinder: Shape::new(device, "firn-view unit cylinder", &unit_cylinder()),
            meshes: load_meshes(device, scene),
            instances: GrowingBuffer::new(
                device,
                "firn-view collider instances",
                wgpu::BufferUsages::VERTEX,
            ),
            this_frame: GrowingBuffer::new(
                device,
                "firn-view planes and deforming meshes",
                wgpu::BufferUsages::VERTEX,
            ),
            draws: Vec::new(),
        }
    }

    /// Uploads where the stage's colliders and bodies are now.
    pub(super) fn prepare(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, stage: &Stage) {
        let mut instances = Vec::new();
        let mut frame_vertices = Vec::new();
        self.draws.clear();
        let colliders = stage.colliders.iter().map(|collider| (collider, None));
        let bodies = stage.bodies.iter().map(|body| (body, Some(BODY_ALBEDO)));
        for (solid, albedo) in colliders.chain(bodies) {
            for (triangles, mut instance) in
                self.placed(solid, stage.container, &mut frame_vertices)
            {
                if let Some(albedo) = albedo {
                    instance.albedo = albedo.to_array();
                }
                self.draws.push(SolidDraw {
                    triangles,
                    instance: instances.len() as u32,
                });
                instances.push(instance);
            }
        }
        self.instances
            .write(device, queue, bytemuck::cast_slice(&instances));
        self.this_frame
            .write(device, queue, bytemuck::cast_slice(&frame_vertices));
    }

    /// The triangles and instances that draw `collider`, turned about its
    /// reference point; a plane's clipped polygon (turned already) and a
    /// deforming mesh's triangles are appended to `frame_vertices`. None
    /// for a mesh that was not loaded.
    fn placed(
        &self,
        collider: &StageCollider,
        container: Option<(Vec3, Vec3)>,
        frame_vertices: &mut Vec<SurfaceVertex>,
    ) -> Vec<(Triangles, SolidInstance)> {
        let start = frame_vertices.len() as u32;
        let parts = if let Some(deformed) = &collider.deformed {
            frame_vertices.extend(mesh_triangles(&deformed.mesh));
            vec![(
                Triangles::ThisFrame(start..frame_vertices.len() as u32),
                SolidInstance::new(Vec3::ZERO, Vec3::ONE, COLLIDER_ALBEDO, COLLIDER_SHININESS),
            )]
        } else if let ColliderGeometry::HalfPlane { point, normal } = collider.geometry {
            let normal = collider.rotation * normal;
            frame_vertices.extend(plane_polygon(point, normal, container));
            vec![(
                Triangles::ThisFrame(start..frame_vertices.len() as u32),
                SolidInstance::new(Vec3::ZERO, Vec3::ONE, WALL_ALBEDO, WALL_SHININESS),
            )]
        } else {
            self.unturned(&collider.geometry)
        };
        let pivot = collider.geometry.reference_point();
        parts
            .into_iter()
            .map(|(triangles, instance)| (triangles, instance.turned(collider.rotation, pivot)))
            .collect()
    }

    /// The triangles and instances of a rigid solid that is not a plane,
    /// unturned: one part, or a capsule's three (its cylinder and the
    /// spheres of its ends); none for a mesh that was not loaded.
    fn unturned(&self, geometry: &ColliderGeometry) -> Vec<(Triangles, SolidInstance)> {
        let solid =
            |offset, scale| SolidInstance::new(offset, scale, COLLIDER_ALBEDO, COLLIDER_SHININESS);
        match *geometry {
            ColliderGeometry::Sphere { center, radius } => {
                vec![(Triangles::Sphere, solid(center, Vec3::splat(radius)))]
            }
            ColliderGeometry::Box { center, size } => vec![(Triangles::Cube, solid(center, size))],
            ColliderGeometry::Cylinder {
                center,
                radius,
                height,
            } => vec![(
                Triangles::Cylinder,
                solid(center, Vec3::new(radius, height, radius)),
            )],
            ColliderGeometry::Capsule {
                center,
                radius,
                height,
            } => {
                let shaft = (height - 2.0 * radius).max(0.0);
                let end = Vec3::new(0.0, 0.5 * shaft, 0.0);
                vec![
                    (
                        Triangles::Cylinder,
                        solid(center, Vec3::new(radius, shaft, radius)),
                    ),
                    (Triangles::Sphere, solid(center + end, Vec3::splat(radius))),
                    (Triangles::Sphere, solid(center - end, Vec3::splat(radius))),
                ]
            }
            ColliderGeometry::Mesh(ref mesh) => self
                .mesh_index(mesh)
                .map(|index| {
                    let shift = mesh.center - mesh.placement.center;
                    (Triangles::Mesh(index), solid(shift, Vec3::ONE))
                })
                .into_iter()
                .collect(),
            ColliderGeometry::HalfPlane { .. } | ColliderGeometry::MeshSequence(_) => Vec::new(),
        }
    }

    /// Draws the colliders of the last [`Solids::prepare`].
    pub(super) fn draw(&self, pass: &mut wgpu::RenderPass<'_>, frame_group: &wgpu::BindGroup) {
        if self.draws.is_empty() {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, frame_group, &[]);
        pass.set_vertex_buffer(1, self.instances.buffer().slice(..));
        for draw in &self.draws {
            let (buffer, vertices) = match &draw.triangles {
                Triangles::Sphere => (&self.sphere.vertices, 0..self.sphere.count),
                Triangles::Cube => (&self.cube.vertices, 0..self.cube.count),
                Triangles::Cylinder => (&self.cylinder.vertices, 0..self.cylinder.count),
                Triangles::Mesh(index) => {
                    let shape = &self.meshes[*index].shape;
                    (&shape.vertices, 0..shape.count)
                }
                Triangles::ThisFrame(range) => (self.this_frame.buffer(), range.clone()),
            };
            pass.set_vertex_buffer(0, buffer.slice(..));
            pass.draw(vertices, draw.instance..draw.instance + 1);
        }
    }

    /// The loaded triangles of a mesh collider, found by its placement.
    fn mesh_index(&self, mesh: &MeshCollider) -> Option<usize> {
        self.meshes
            .iter()
            .position(|placed| placed.placement == mesh.placement)
    }
}

/// The triangles of the scene's mesh colliders and mesh bodies at their
/// time-zero placement.
fn load_meshes(device: &wgpu::Device, scene: &Scene) -> Vec<PlacedShape> {
    let colliders = scene.colliders.iter().map(|collider| &collider.geometry);
    let bodies = scene.rigid_bodies.iter().map(|body| &body.geometry);
    colliders
        .chain(bodies)
        .filter_map(|geometry| match geometry {
            ColliderGeometry::Mesh(mesh) => Some(&mesh.placement),
            _ => None,
        })
        .filter_map(|placement| {
            let placed = placement.load().ok()?;
            let label = format!("firn-view mesh {}", placement.file.display());
            Some(PlacedShape {
                placement: placement.clone(),
                shape: Shape::new(device, &label, &mesh_triangles(&placed.mesh)),
            })
        })
        .collect()
}
