//! Small scenes built in code for the solver tests.

#![allow(dead_code)]

use std::path::PathBuf;

use firn_core::Material;
use firn_core::scene::{
    Body, CacheFormat, Camera, Collider, Contact, ContactMode, Domain, Integrator, OutputSettings,
    RenderSettings, Scene, SceneKind, Shape, SolverSettings, TimeSettings, TimeStep, Transfer,
};
use glam::Vec3;

/// A unit-box scene with one body and no colliders besides the walls.
pub fn scene_with(body: Shape, velocity: Vec3, transfer: Transfer, cell_size: f32) -> Scene {
    Scene {
        name: "test".into(),
        domain: Domain {
            min: Vec3::ZERO,
            max: Vec3::ONE,
            cell_size,
            walls: Contact {
                mode: ContactMode::Separate,
                friction: 0.5,
            },
        },
        time: TimeSettings {
            duration: 1.0,
            fps: 30.0,
            step: TimeStep::Fixed { dt: 5e-4 },
            max_substeps_per_frame: TimeSettings::DEFAULT_MAX_SUBSTEPS_PER_FRAME,
        },
        solver: SolverSettings {
            transfer,
            flip_blend: 0.95,
            gravity: Vec3::new(0.0, -9.81, 0.0),
            seed: 7,
            integrator: Integrator::Explicit,
        },
        materials: vec![Material::preset("snow").unwrap()],
        bodies: vec![Body {
            shape: body,
            velocity,
            material: 0,
            particles_per_cell: 8,
            clumps: None,
        }],
        colliders: Vec::<Collider>::new(),
        rigid_bodies: Vec::new(),
        output: OutputSettings {
            directory: PathBuf::from("out/test"),
            formats: vec![CacheFormat::Ply],
            attributes: Vec::new(),
            checkpoint_every: 0,
            ..OutputSettings::default()
        },
        camera: Camera::default(),
        render: RenderSettings::default(),
        kind: SceneKind::Snow,
        compute: Default::default(),
        wind: None,
    }
}

/// A snowball of radius 0.1 at `center`.
pub fn snowball(center: Vec3, velocity: Vec3, transfer: Transfer) -> Scene {
    scene_with(
        Shape::Sphere {
            center,
            radius: 0.1,
        },
        velocity,
        transfer,
        0.04,
    )
}

/// Both transfer schemes.
pub const TRANSFERS: [Transfer; 2] = [Transfer::PicFlip, Transfer::Apic];
