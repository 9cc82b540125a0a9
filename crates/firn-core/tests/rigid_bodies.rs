//! `[[rigid_bodies]]` in scene files and in code: each shape resolves to
//! the model with its defaults, bad values and bodies that start inside
//! another solid are refused at the right line and key, and colliders take
//! capsules.

use std::fs;

use firn_core::scene::motion::rotation_from_degrees;
use firn_core::scene::{BodyMass, ColliderGeometry, ContactMode, Integrator, MeshSolid, RigidBody};
use firn_core::{Scene, SceneError};
use glam::{Quat, Vec3};

/// A valid snow scene in 12 lines; what a test adds starts on line 13.
const HEAD: &str = "format = 1

[domain]
max = [2.0, 2.0, 2.0]
cell_size = 0.05

[time]
duration = 1.0
[[bodies]]
shape = \"sphere\"
center = [1.0, 0.3, 1.0]
radius = 0.2
";

fn load(tail: &str) -> Result<Scene, Box<SceneError>> {
    Scene::from_toml_str(&format!("{HEAD}{tail}"), "scenes/rigid.toml").map_err(Box::new)
}

/// The error of a scene that must not load, at `line` and `key`, saying `says`.
#[track_caller]
fn refused(tail: &str, line: usize, key: &str, says: &str) -> SceneError {
    let err = *load(tail).expect_err(&format!("should be refused:\n{tail}"));
    assert_eq!(err.line, Some(line), "wrong line:\n{err}");
    assert_eq!(err.key.as_deref(), Some(key), "wrong key:\n{err}");
    assert!(
        err.to_string().contains(says),
        "should say {says:?}:\n{err}"
    );
    assert!(!err.hint.is_empty(), "no fix:\n{err}");
    err
}

/// A ball of `radius` at `center`, as a `[[rigid_bodies]]` table of 4 lines.
fn ball(center: [f32; 3], radius: f32) -> String {
    format!(
        "[[rigid_bodies]]\nshape = \"sphere\"\ncenter = [{}, {}, {}]\nradius = {radius}\n",
        center[0], center[1], center[2]
    )
}

#[test]
fn each_shape_resolves_with_its_defaults() {
    let scene = load(
        "[[rigid_bodies]]
shape = \"sphere\"
center = [0.5, 1.5, 0.5]
radius = 0.1
[[rigid_bodies]]
shape = \"box\"
center = [1.5, 1.5, 0.5]
size = [0.2, 0.1, 0.3]
rotation = [0.0, 90.0, 0.0]
mass = 12.5
[[rigid_bodies]]
shape = \"cylinder\"
center = [0.5, 1.5, 1.5]
radius = 0.1
height = 0.3
quaternion = [0.0, 0.0, 1.0, 1.0]
density = 900.0
velocity = [1.0, 0.0, 0.0]
angular_velocity = [0.0, 2.0, 0.0]
[[rigid_bodies]]
shape = \"capsule\"
center = [1.5, 1.5, 1.5]
radius = 0.1
height = 0.4
mode = \"sticky\"
friction = 0.5
restitution = 0.4
",
    )
    .unwrap_or_else(|err| panic!("{err}"));
    let [sphere, cuboid, cylinder, capsule] = &scene.rigid_bodies[..] else {
        panic!("four bodies: {:?}", scene.rigid_bodies);
    };

    assert_eq!(
        *sphere,
        RigidBody::sphere(Vec3::new(0.5, 1.5, 0.5), 0.1),
        "a sphere with every default"
    );
    assert_eq!(sphere.mass, BodyMass::Density(RigidBody::DEFAULT_DENSITY));
    assert_eq!(sphere.contact, RigidBody::default_contact());
    assert_eq!(sphere.contact.mode, ContactMode::Separate);
    assert_eq!(sphere.contact.friction, 0.3);
    assert_eq!((sphere.restitution, sphere.rotation), (0.0, Quat::IDENTITY));

    assert_eq!(
        cuboid.geometry,
        ColliderGeometry::Box {
            center: Vec3::new(1.5, 1.5, 0.5),
            size: Vec3::new(0.2, 0.1, 0.3)
        }
    );
    assert_eq!(cuboid.mass, BodyMass::Mass(12.5));
    assert_eq!(
        cuboid.rotation,
        rotation_from_degrees(Vec3::new(0.0, 90.0, 0.0))
    );
    assert_eq!(cuboid.baked_rotation(), Quat::IDENTITY);

    let quarter_turn = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    assert!(
        cylinder.rotation.abs_diff_eq(quarter_turn, 1e-6),
        "the quaternion, normalised: {:?}",
        cylinder.rotation
    );
    assert_eq!(cylinder.mass, BodyMass::Density(900.0));
    assert_eq!(
        (cylinder.velocity, cylinder.angular_velocity),
        (Vec3::X, Vec3::new(0.0, 2.0, 0.0))
    );

    assert_eq!(
        capsule.geometry,
        ColliderGeometry::Capsule {
            center: Vec3::new(1.5, 1.5, 1.5),
            radius: 0.1,
            height: 0.4
        }
    );
    assert_eq!(capsule.contact.mode, ContactMode::Sticky);
    assert_eq!(capsule.contact.friction, 0.5);
    assert_eq!(capsule.restitution, 0.4);
}

/// A closed unit cube as an OBJ, faces wound outwards.
const CUBE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

/// A unit square, flat: no volume.
const SQUARE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1 4 3 2\n";

/// Loads a scene file whose rigid bodies and colliders are `tail`, next to
/// the meshes `cube.obj` and `square.obj`.
fn load_with_meshes(tail: &str) -> Result<Scene, Box<SceneError>> {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("cube.obj"), CUBE_OBJ).unwrap();
    fs::write(dir.path().join("square.obj"), SQUARE_OBJ).unwrap();
    let path = dir.path().join("scene.toml");
    fs::write(&path, format!("{HEAD}{tail}")).unwrap();
    Scene::load(&path).map_err(Box::new)
}

#[test]
fn a_mesh_body_carries_its_rotation_in_its_placement_and_its_model() {
    let scene = load_with_meshes(
        "[[rigid_bodies]]
shape = \"mesh\"
mesh = \"cube.obj\"
scale = 0.2
rotation = [0.0, 0.0, 30.0]
center = [1.0, 1.5, 1.0]
solid = \"decomposition\"
[[rigid_bodies]]
shape = \"mesh\"
mesh = \"cube.obj\"
scale = 0.2
quaternion = [0.0, 0.3826834, 0.0, 0.9238795]
center = [0.5, 1.5, 0.5]
",
    )
    .unwrap_or_else(|err| panic!("{err}"));
    let turned = &scene.rigid_bodies[0];
    let ColliderGeometry::Mesh(mesh) = &turned.geometry else {
        panic!("a mesh: {:?}", turned.geometry);
    };
    assert_eq!(mesh.placement.rotation_degrees, Vec3::new(0.0, 0.0, 30.0));
    assert_eq!(mesh.sdf_spacing, 0.025, "half the cell size");
    let turn = rotation_from_degrees(Vec3::new(0.0, 0.0, 30.0));
    assert_eq!((turned.rotation, turned.baked_rotation()), (turn, turn));
    assert_eq!(turned.solid, MeshSolid::Decomposition);
    // The field was sampled turned: a corner of the unturned cube is outside.
    let center = Vec3::new(1.0, 1.5, 1.0);
    let inside = turned.geometry.signed_distance(center).0;
    assert!(inside < -0.07, "{inside}");
    assert!(
        turned
            .geometry
            .signed_distance(center + Vec3::splat(0.099))
            .0
            > 0.0
    );

    let by_quaternion = &scene.rigid_bodies[1];
    let eighth_turn = Quat::from_rotation_y(std::f32::consts::FRAC_PI_4);
    assert!(
        by_quaternion.rotation.abs_diff_eq(eighth_turn, 1e-5),
        "{:?}",
        by_quaternion.rotation
    );
    assert_eq!(by_quaternion.solid, MeshSolid::Hull);
}

#[test]
fn bad_values_are_refused_at_their_key() {
    let sphere = "[[rigid_bodies]]\nshape = \"sphere\"\ncenter = [1.0, 1.5, 1.0]\nradius = 0.1\n";
    let cases = [
        ("mass = 0.0", "mass", "greater than 0"),
        ("density = -3.0", "density", "greater than 0"),
        ("density = nan", "density", "a finite number greater than 0"),
        (
            "density = 400.0\nmass = 2.0",
            "mass",
            "both density and mass",
        ),
        ("velocity = [inf, 0.0, 0.0]", "velocity", "finite"),
        (
            "angular_velocity = [0.0, nan, 0.0]",
            "angular_velocity",
            "finite",
        ),
        ("rotation = [nan, 0.0, 0.0]", "rotation", "finite"),
        (
            "quaternion = [0.0, 0.0, 0.0, 0.0]",
            "quaternion",
            "not zero",
        ),
        (
            "rotation = [0.0, 9.0, 0.0]\nquaternion = [0.0, 0.0, 0.0, 1.0]",
            "quaternion",
            "both rotation and quaternion",
        ),
        ("restitution = 1.5", "restitution", "between 0 and 1"),
        ("friction = -0.1", "friction", "0 or more"),
        (
            "size = [0.1, 0.1, 0.1]",
            "size",
            "does not apply to a sphere",
        ),
        ("solid = \"hull\"", "solid", "does not apply to a sphere"),
    ];
    for (keys, key, says) in cases {
        let line = 17 + keys.lines().count() - 1;
        refused(
            &format!("{sphere}{keys}\n"),
            line,
            &format!("rigid_bodies[0].{key}"),
            says,
        );
    }
    let shapes = [
        (
            "sphere\"\ncenter = [1.0, 1.5, nan]\nradius = 0.1",
            15,
            "center",
            "finite",
        ),
        (
            "sphere\"\ncenter = [1.0, 1.5, 1.0]\nradius = 0.0",
            16,
            "radius",
            "greater than 0",
        ),
        (
            "box\"\ncenter = [1.0, 1.5, 1.0]\nsize = [0.1, -0.1, 0.1]",
            16,
            "size",
            "greater than 0",
        ),
        (
            "cylinder\"\ncenter = [1.0, 1.5, 1.0]\nradius = 0.1\nheight = 0.0",
            17,
            "height",
            "greater than 0",
        ),
        (
            "capsule\"\ncenter = [1.0, 1.5, 1.0]\nradius = 0.1\nheight = 0.15",
            17,
            "height",
            "at least twice the radius",
        ),
        (
            "capsule\"\ncenter = [1.0, 1.5, 1.0]\nheight = 0.5",
            13,
            "radius",
            "needs `radius`",
        ),
    ];
    for (keys, line, key, says) in shapes {
        refused(
            &format!("[[rigid_bodies]]\nshape = \"{keys}\n"),
            line,
            &format!("rigid_bodies[0].{key}"),
            says,
        );
    }
    refused(
        "[[rigid_bodies]]\ncenter = [1.0, 1.5, 1.0]\n",
        13,
        "rigid_bodies[0].shape",
        "needs `shape`",
    );
    refused(
        "[[rigid_bodies]]\nshape = \"sphere\"\nradiuss = 0.1\n",
        15,
        "rigid_bodies[0].radiuss",
        "did you mean `radius`?",
    );
}

#[test]
fn a_mesh_body_needs_a_volume() {
    let err = *load_with_meshes(
        "[[rigid_bodies]]
shape = \"mesh\"
mesh = \"square.obj\"
scale = 0.2
rotation = [30.0, 0.0, 10.0]
center = [1.0, 1.5, 1.0]
",
    )
    .expect_err("a flat mesh has no volume");
    assert_eq!(err.line, Some(15), "{err}");
    assert_eq!(err.key.as_deref(), Some("rigid_bodies[0].mesh"), "{err}");
    assert!(
        err.message.contains("square.obj") && err.message.contains("encloses no volume"),
        "{err}"
    );
}

#[test]
fn a_body_may_start_touching_but_not_inside_another_solid() {
    let floor =
        "[[colliders]]\nshape = \"plane\"\npoint = [0.0, 1.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\n";
    // Resting on the floor, or a little (under a quarter cell) in it.
    load(&format!("{floor}{}", ball([1.0, 1.1, 1.0], 0.1))).unwrap();
    load(&format!("{floor}{}", ball([1.0, 1.09, 1.0], 0.1))).unwrap();
    let sunk = refused(
        &format!("{floor}{}", ball([1.0, 1.05, 1.0], 0.1)),
        19,
        "rigid_bodies[0].center",
        "rigid_bodies[0] starts inside colliders[0]: its surface reaches 0.05 m into it",
    );
    assert!(sunk.hint.contains("up by about 0.05"), "{sunk}");

    // A box standing on a corner reaches lower than its centre's height
    // less half its size: its turn is read.
    let cube = |turn: f32| {
        format!(
            "[[rigid_bodies]]\nshape = \"box\"\ncenter = [1.0, 1.11, 1.0]\nsize = [0.2, 0.2, 0.2]\nrotation = [0.0, 0.0, {turn}]\n"
        )
    };
    load(&format!("{floor}{}", cube(0.0))).unwrap();
    refused(
        &format!("{floor}{}", cube(45.0)),
        19,
        "rigid_bodies[0].center",
        "starts inside colliders[0]",
    );

    // Two balls in each other: the first is named, with the way out of the
    // second.
    let err = refused(
        &format!(
            "{}{}",
            ball([1.0, 1.5, 1.0], 0.1),
            ball([1.15, 1.5, 1.0], 0.1)
        ),
        15,
        "rigid_bodies[0].center",
        "rigid_bodies[0] starts inside rigid_bodies[1]",
    );
    assert!(err.hint.contains("along -x"), "{err}");
    load(&format!(
        "{}{}",
        ball([1.0, 1.5, 1.0], 0.1),
        ball([1.2, 1.5, 1.0], 0.1)
    ))
    .unwrap();

    // Past the domain's walls.
    let out = refused(
        &ball([1.95, 1.5, 1.0], 0.1),
        15,
        "rigid_bodies[0].center",
        "starts outside the domain: it reaches 0.05 m past the walls along x",
    );
    assert!(out.hint.contains("along -x by about 0.05"), "{out}");
}

#[test]
fn a_body_inside_a_mesh_collider_or_a_turning_one_is_found() {
    let stamp = "[[colliders]]
shape = \"mesh\"
mesh = \"cube.obj\"
scale = 0.4
center = [1.0, 1.0, 1.0]
";
    load_with_meshes(&format!("{stamp}{}", ball([1.0, 1.3, 1.0], 0.1))).unwrap();
    let err = *load_with_meshes(&format!("{stamp}{}", ball([1.0, 1.25, 1.0], 0.1)))
        .expect_err("the ball reaches into the cube");
    assert_eq!(err.key.as_deref(), Some("rigid_bodies[0].center"), "{err}");
    assert!(err.message.contains("inside colliders[0]"), "{err}");

    // A paddle keyed to start turned a quarter about z: upright, it reaches
    // the ball beside it.
    let paddle = |turn: f32| {
        format!(
            "[[colliders]]\nshape = \"box\"\ncenter = [1.0, 1.0, 1.0]\nsize = [0.6, 0.05, 0.2]\n\
             keyframes = [{{ time = 0.0, position = [1.0, 1.0, 1.0], rotation = [0.0, 0.0, {turn}] }}, \
             {{ time = 1.0, position = [1.0, 1.2, 1.0] }}]\n"
        )
    };
    let beside = ball([1.1, 1.15, 1.0], 0.1);
    load(&format!("{}{beside}", paddle(0.0))).unwrap();
    refused(
        &format!("{}{beside}", paddle(90.0)),
        20,
        "rigid_bodies[0].center",
        "inside colliders[0]",
    );
}

#[test]
fn rigid_bodies_need_the_explicit_integrator_and_a_snow_scene() {
    let solver = "[solver]\nintegrator = \"semi-implicit\"\n";
    refused(
        &format!("{solver}{}", ball([1.0, 1.5, 1.0], 0.1)),
        15,
        "rigid_bodies[0]",
        "need solver.integrator = \"explicit\"",
    );
    let flow = Scene::from_toml_str(
        &format!(
            "format = 1\nkind = \"flow\"\n[domain]\nmax = [2.0, 2.0, 2.0]\n[time]\nduration = 1.0\n\
             [[flow.emitters]]\nshape = \"sphere\"\ncenter = [1.0, 1.0, 1.0]\nradius = 0.2\ncount = 100\n{}",
            ball([1.0, 1.5, 1.0], 0.1)
        ),
        "scenes/rigid.toml",
    )
    .expect_err("a flow pushes no solids");
    assert_eq!(flow.key.as_deref(), Some("rigid_bodies"), "{flow}");
    assert!(
        flow.message.contains("[[rigid_bodies]] is for snow scenes"),
        "{flow}"
    );
}

fn snow_in_code() -> firn_core::scene::SceneBuilder {
    Scene::builder("rigid")
        .domain(Vec3::ZERO, Vec3::splat(2.0), 0.05)
        .body(firn_core::scene::Body::sphere(
            Vec3::new(1.0, 0.3, 1.0),
            0.2,
        ))
}

#[test]
fn scenes_built_in_code_get_the_same_checks() {
    let ball = RigidBody::sphere(Vec3::new(1.0, 1.5, 1.0), 0.1);
    snow_in_code().rigid_body(ball.clone()).build().unwrap();

    let light = snow_in_code()
        .rigid_body(ball.clone().mass(-1.0))
        .build()
        .unwrap_err();
    assert_eq!(
        (light.key.as_deref(), light.line),
        (Some("rigid_bodies[0].mass"), None),
        "{light}"
    );
    let unturned = snow_in_code()
        .rigid_body(ball.clone().rotated(Quat::from_xyzw(0.0, 0.0, 0.0, 2.0)))
        .build()
        .unwrap_err();
    assert_eq!(unturned.key.as_deref(), Some("rigid_bodies[0].rotation"));
    let implicit = snow_in_code()
        .integrator(Integrator::SemiImplicit(Default::default()))
        .rigid_body(ball.clone())
        .build()
        .unwrap_err();
    assert_eq!(implicit.key.as_deref(), Some("rigid_bodies[0]"));

    let many = (0..=firn_core::scene::format::MAX_RIGID_BODIES)
        .fold(snow_in_code(), |scene, _| scene.rigid_body(ball.clone()))
        .build()
        .unwrap_err();
    assert_eq!(many.key.as_deref(), Some("rigid_bodies[10000]"), "{many}");
    assert!(many.message.contains("the limit is 10000"), "{many}");
}

#[test]
fn colliders_take_capsules() {
    let scene = load(
        "[[colliders]]
shape = \"capsule\"
center = [1.0, 1.5, 1.0]
radius = 0.1
height = 0.5
rotation = [90.0, 0.0, 0.0]
",
    )
    .unwrap_or_else(|err| panic!("{err}"));
    let collider = &scene.colliders[0];
    assert_eq!(
        collider.geometry,
        ColliderGeometry::Capsule {
            center: Vec3::new(1.0, 1.5, 1.0),
            radius: 0.1,
            height: 0.5
        }
    );
    assert_eq!(
        collider.rotation,
        rotation_from_degrees(Vec3::new(90.0, 0.0, 0.0))
    );
    let capsule = "[[colliders]]\nshape = \"capsule\"\ncenter = [1.0, 1.5, 1.0]\nradius = 0.1\n";
    refused(
        &format!("{capsule}height = 0.1\n"),
        17,
        "colliders[0].height",
        "at least twice the radius",
    );
    refused(
        &format!("{capsule}height = 0.5\nsize = [0.1, 0.1, 0.1]\n"),
        18,
        "colliders[0].size",
        "does not apply to a capsule",
    );
}
