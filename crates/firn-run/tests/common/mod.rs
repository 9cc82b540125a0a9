//! Small scenes for the tests: a slab of snow thrown onto the floor (also
//! in a wind that lifts drift off it) and a curl-noise flow around a
//! sphere, each a fraction of a second of a few hundred particles, without
//! pictures. (Each test file uses some of them.)
#![allow(dead_code)]

use firn_core::Scene;
use firn_core::scene::{
    Attribute, Body, FlowEmitter, FlowEmitterShape, FlowObstacle, RenderStyle, RigidBody,
    Spindrift, Transfer, Wind,
};
use glam::{Quat, Vec3};

/// A slab of snow thrown onto the floor: six frames, every attribute
/// cached in PLY and VTK, a checkpoint every second frame.
pub fn slab() -> Scene {
    let mut scene = Scene::builder("slab")
        .unit_box(0.1)
        .duration(0.25)
        .fps(24.0)
        .transfer(Transfer::Apic)
        .body(
            Body::cuboid(Vec3::new(0.5, 0.25, 0.5), Vec3::new(0.3, 0.2, 0.3))
                .velocity(Vec3::new(0.0, -1.0, 0.0)),
        )
        .attributes([
            Attribute::Velocity,
            Attribute::PlasticJ,
            Attribute::ElasticJ,
            Attribute::Density,
            Attribute::Mass,
            Attribute::Material,
        ])
        .checkpoint_every(2)
        .build()
        .expect("the slab is a valid scene");
    scene.render.enabled = false;
    scene
}

/// A turned, spinning box of wood dropped onto a thin slab of snow at a
/// coarse 1/16 m: three frames at 24 fps, cached in PLY, no checkpoints.
pub fn box_on_slab() -> Scene {
    let mut scene = Scene::builder("box-on-slab")
        .unit_box(1.0 / 16.0)
        .duration(0.125)
        .fps(24.0)
        .transfer(Transfer::Apic)
        .body(Body::cuboid(
            Vec3::new(0.5, 0.1, 0.5),
            Vec3::new(0.8, 0.08, 0.8),
        ))
        .rigid_body(
            RigidBody::cuboid(Vec3::new(0.45, 0.4, 0.5), Vec3::new(0.3, 0.16, 0.2))
                .rotated(Quat::from_rotation_z(0.5))
                .moving(Vec3::new(0.4, -1.0, 0.0), Vec3::new(0.0, 4.0, 0.0)),
        )
        .build()
        .expect("the box on the slab is a valid scene");
    scene.render.enabled = false;
    scene
}

/// [`slab`] in a 10 m/s wind along +x whose spindrift lifts drift off it
/// within a few hundredths of a second.
pub fn drift_slab() -> Scene {
    let mut scene = slab();
    let spindrift = Spindrift {
        threshold_speed: 0.5,
        loose_density: 1000.0,
        rate: 40.0,
        ..Spindrift::default()
    };
    let mut wind = Wind::uniform(Vec3::X, 10.0);
    wind.spindrift = Some(spindrift);
    scene.wind = Some(wind);
    scene
}

/// A curl-noise flow of 200 particles around a sphere, with trails.
pub fn flow() -> Scene {
    let mut scene = Scene::builder("flow")
        .unit_box(0.05)
        .duration(0.5)
        .fps(30.0)
        .obstacle(FlowObstacle::new(Vec3::splat(0.5), 0.15))
        .emitter(FlowEmitter::count(
            FlowEmitterShape::Box {
                center: Vec3::new(0.2, 0.5, 0.5),
                size: Vec3::new(0.1, 0.3, 0.3),
            },
            200,
        ))
        .build()
        .expect("the flow is a valid scene");
    scene.render.enabled = false;
    scene.render.styles = vec![RenderStyle::Trails];
    scene
}
