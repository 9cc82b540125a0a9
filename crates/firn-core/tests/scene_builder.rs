//! Scenes built in code with `Scene::builder` equal the scene files that say
//! the same, so the defaults of the two cannot drift apart; and `build`
//! refuses what a file would refuse, naming the key.

use firn_core::scene::{
    Attribute, Body, CacheFormat, Collider, ColliderGeometry, Contact, ContactMode, Domain,
    FlowEmitter, FlowEmitterShape, FlowObstacle, FlowSettings, ImplicitSettings, Integrator,
    Keyframe, Motion, OutputSettings, SceneKind, Shape, SolverSettings, TimeSettings, TimeStep,
    Transfer,
};
use firn_core::{Material, Scene, SceneError};
use glam::Vec3;

fn load(text: &str, origin: &str) -> Scene {
    Scene::from_toml_str(text, origin).unwrap_or_else(|err| panic!("{err}"))
}

fn build(builder: firn_core::scene::SceneBuilder) -> Scene {
    builder.build().unwrap_or_else(|err| panic!("{err}"))
}

/// Only the required keys: the builder with only the required inputs gives
/// exactly the same scene, every default included.
#[test]
fn minimal_file_equals_minimal_builder() {
    let file = load(
        "format = 1

[domain]
max = [1.0, 2.0, 1.0]
cell_size = 0.05

[time]
duration = 1.5

[[bodies]]
shape = \"box\"
center = [0.5, 0.3, 0.5]
size = [0.4, 0.4, 0.4]
",
        "scenes/minimal.toml",
    );
    let built = build(
        Scene::builder("minimal")
            .domain(Vec3::ZERO, Vec3::new(1.0, 2.0, 1.0), 0.05)
            .duration(1.5)
            .body(Body::cuboid(Vec3::new(0.5, 0.3, 0.5), Vec3::splat(0.4))),
    );
    assert_eq!(built, file);

    // And the defaults are the documented ones.
    assert_eq!(built.domain.walls, Contact::separate(0.2));
    assert_eq!(built.time.fps, 30.0);
    assert_eq!(
        built.time.step,
        TimeStep::Adaptive {
            cfl: 0.4,
            max_dt: 1e-3
        }
    );
    assert_eq!(
        built.solver,
        SolverSettings {
            transfer: Transfer::PicFlip,
            flip_blend: 0.95,
            gravity: Vec3::new(0.0, -9.81, 0.0),
            seed: 1,
            integrator: Integrator::Explicit,
        }
    );
    assert_eq!(built.materials, vec![Material::preset("snow").unwrap()]);
    assert_eq!(built.bodies[0].particles_per_cell, 8);
    assert_eq!(built.output.directory, std::path::Path::new("out/minimal"));
    assert_eq!(
        built.output.formats,
        vec![CacheFormat::Ply, CacheFormat::Vtk]
    );
    assert_eq!(
        built.output.attributes,
        vec![Attribute::Velocity, Attribute::PlasticJ, Attribute::Density]
    );
    assert_eq!(built.output.checkpoint_every, 10);
    assert_eq!(built.kind, SceneKind::Snow);
}

/// Optional keys set in both, and the defaults that depend on them (the
/// bound on Δt follows fps; a cylinder's axis is normalised).
#[test]
fn file_with_options_equals_builder() {
    let file = load(
        "format = 1
name = \"options\"

[domain]
min = [-1.0, 0.0, -1.0]
max = [1.0, 1.0, 1.0]
cell_size = 0.04
walls = { mode = \"sticky\" }

[time]
duration = 0.5
fps = 2000
cfl = 0.3

[solver]
transfer = \"apic\"
gravity = [0.0, -5.0, 0.0]
seed = 7
integrator = \"semi-implicit\"

[materials.heavy]
preset = \"wet\"
density = 600.0

[[bodies]]
shape = \"sphere\"
center = [0.0, 0.6, 0.0]
radius = 0.2
velocity = [1.0, 0.0, 0.0]
material = \"heavy\"
particles_per_cell = 27

[[bodies]]
shape = \"cylinder\"
center = [0.5, 0.2, 0.0]
axis = [2.0, 0.0, 0.0]
radius = 0.1
height = 0.4

[[colliders]]
shape = \"plane\"
point = [0.0, 0.05, 0.0]
normal = [0.0, 1.0, 0.0]

[[colliders]]
shape = \"sphere\"
center = [-0.5, 0.3, 0.0]
radius = 0.1
velocity = [0.3, 0.0, 0.0]
friction = 0.5

[[colliders]]
shape = \"box\"
center = [0.5, 0.6, 0.5]
size = [0.2, 0.1, 0.2]
mode = \"slip\"
keyframes = [{ time = 0.0, position = [0.5, 0.6, 0.5] }, { time = 0.5, position = [0.5, 0.4, 0.5] }]

[output]
directory = \"elsewhere\"
formats = [\"ply\"]
attributes = []
checkpoint_every = 0
",
        "inline",
    );

    let mut builder = Scene::builder("options")
        .domain(Vec3::new(-1.0, 0.0, -1.0), Vec3::ONE, 0.04)
        .walls(Contact::sticky())
        .duration(0.5)
        .cfl(0.3)
        // Set after the CFL: the default bound on Δt follows the final fps.
        .fps(2000.0)
        .transfer(Transfer::Apic)
        .gravity(Vec3::new(0.0, -5.0, 0.0))
        .seed(7)
        .integrator(Integrator::SemiImplicit(ImplicitSettings::default()));
    let heavy = builder.add_material(Material {
        name: "heavy".into(),
        density: 600.0,
        ..Material::preset("wet").unwrap()
    });
    let snow = builder.add_material(Material::default());
    let built = build(
        builder
            .body(
                Body::sphere(Vec3::new(0.0, 0.6, 0.0), 0.2)
                    .velocity(Vec3::X)
                    .material(heavy)
                    .particles_per_cell(27),
            )
            .body(Body::cylinder(Vec3::new(0.5, 0.2, 0.0), Vec3::X * 2.0, 0.1, 0.4).material(snow))
            .collider(Collider::plane(Vec3::new(0.0, 0.05, 0.0), Vec3::Y))
            .collider(
                Collider::sphere(Vec3::new(-0.5, 0.3, 0.0), 0.1)
                    .moving(Vec3::new(0.3, 0.0, 0.0))
                    .friction(0.5),
            )
            .collider(
                Collider::cuboid(Vec3::new(0.5, 0.6, 0.5), Vec3::new(0.2, 0.1, 0.2))
                    .mode(ContactMode::Slip)
                    .keyframed([
                        Keyframe::new(0.0, Vec3::new(0.5, 0.6, 0.5)),
                        Keyframe::new(0.5, Vec3::new(0.5, 0.4, 0.5)),
                    ]),
            )
            .output_dir("elsewhere")
            .formats([CacheFormat::Ply])
            .attributes([])
            .checkpoint_every(0),
    );
    assert_eq!(built, file);
    assert_eq!(
        built.time.step,
        TimeStep::Adaptive {
            cfl: 0.3,
            max_dt: (1.0 / 2000.0_f64) as f32
        }
    );
    assert!(matches!(
        built.colliders[1].motion,
        Motion::Linear { velocity, .. } if velocity == Vec3::new(0.3, 0.0, 0.0)
    ));
    assert!(matches!(
        built.colliders[0].geometry,
        ColliderGeometry::HalfPlane { .. }
    ));
    assert!(matches!(
        built.bodies[1].shape,
        Shape::Cylinder { axis, .. } if axis == Vec3::X
    ));
}

#[test]
fn fixed_step_equals_file() {
    let text = "format = 1
[domain]
max = [1.0, 1.0, 1.0]
cell_size = 0.05
[time]
duration = 1.0
fps = 24
step = \"fixed\"
dt = 5e-4
[[bodies]]
shape = \"sphere\"
center = [0.5, 0.5, 0.5]
radius = 0.2
";
    let built = build(
        Scene::builder(Scene::DEFAULT_NAME)
            .unit_box(0.05)
            .fps(24.0)
            .fixed_dt(5e-4)
            .body(Body::sphere(Vec3::splat(0.5), 0.2)),
    );
    assert_eq!(built, load(text, "not-a-toml-file"));
    // An explicit adaptive step is kept as given, whatever the fps.
    let adaptive = Scene::builder("a")
        .adaptive(0.5, 2e-3)
        .fps(1000.0)
        .build_unchecked();
    assert_eq!(
        adaptive.time.step,
        TimeStep::Adaptive {
            cfl: 0.5,
            max_dt: 2e-3
        }
    );
}

/// The smallest flow file and the builder with an emitter: the defaults that
/// depend on the domain (L = extent / 5, M = L / 4) and the flow's output
/// attributes agree.
#[test]
fn minimal_flow_file_equals_builder() {
    let file = load(
        "format = 1
kind = \"flow\"

[domain]
max = [50.0, 50.0, 50.0]

[time]
duration = 2.0

[[flow.obstacles]]
center = [25.0, 25.0, 25.0]
radius = 5.0

[[flow.emitters]]
shape = \"box\"
center = [10.0, 25.0, 25.0]
size = [5.0, 5.0, 5.0]
count = 1000
lifetime = 4.0
",
        "scenes/curl.toml",
    );
    let built = build(
        Scene::builder("curl")
            // The file's default spacing for a flow: a hundredth of the extent.
            .domain(Vec3::ZERO, Vec3::splat(50.0), 0.5)
            .duration(2.0)
            .obstacle(FlowObstacle::new(Vec3::splat(25.0), 5.0))
            .emitter(
                FlowEmitter::count(
                    FlowEmitterShape::Box {
                        center: Vec3::new(10.0, 25.0, 25.0),
                        size: Vec3::splat(5.0),
                    },
                    1000,
                )
                .lifetime(4.0),
            ),
    );
    assert_eq!(built, file);
    let flow = built.kind.flow().unwrap();
    assert_eq!(flow.length_scale, 10.0);
    assert_eq!(flow.noise_strength, 2.5);
    assert_eq!(built.output.attributes, vec![Attribute::Velocity]);

    // Explicit settings are kept as given.
    let explicit = Scene::builder("curl")
        .flow(FlowSettings {
            substeps: 4,
            ..FlowSettings::default()
        })
        .build_unchecked();
    assert_eq!(explicit.kind.flow().unwrap().length_scale, 20.0);
    assert_eq!(explicit.kind.flow().unwrap().substeps, 4);
}

/// `Scene::default()` is the builder's starting point: the documented unit
/// box with 0.05 m cells, the format's defaults, and no snow (so it does
/// not validate until bodies are added).
#[test]
fn scene_default_is_the_builders_start() {
    let scene = Scene::default();
    assert_eq!(scene, Scene::builder("scene").build_unchecked());
    assert_eq!(scene.name, "scene");
    assert_eq!(scene.domain, Domain::unit_box(0.05));
    assert_eq!(scene.domain.cells(), [20, 20, 20]);
    assert_eq!(scene.time, TimeSettings::new(1.0));
    assert_eq!(scene.solver, SolverSettings::default());
    assert!(scene.materials.is_empty() && scene.bodies.is_empty());
    assert_eq!(scene.output, OutputSettings::for_scene("scene"));
    let err = scene.validate().unwrap_err();
    assert_eq!(err.key.as_deref(), Some("bodies"));

    // Adding a body (and its material) makes it a valid scene.
    let snow = Scene {
        materials: vec![Material::default()],
        bodies: vec![Body::sphere(Vec3::splat(0.5), 0.2)],
        ..Scene::default()
    };
    snow.validate().unwrap();
}

/// `build` applies the file's checks; the error names the key and carries
/// the same message and fix as the file's, without a line.
#[test]
fn build_refuses_an_invalid_scene_with_the_key_path() {
    let err = Scene::builder("bad")
        .body(Body::sphere(Vec3::splat(0.5), 0.2))
        .body(Body::sphere(Vec3::splat(0.5), -0.1))
        .build()
        .unwrap_err();
    assert_eq!(err.key.as_deref(), Some("bodies[1].radius"), "{err}");
    assert_eq!((err.line, err.column), (None, None));
    assert!(err.file.is_empty());
    assert!(
        err.message
            .starts_with("bodies[1].radius must be greater than 0"),
        "{err}"
    );

    let file_err: SceneError = Scene::from_toml_str(
        "format = 1
[domain]
max = [1.0, 1.0, 1.0]
cell_size = 0.05
[time]
duration = 1.0
[[bodies]]
shape = \"sphere\"
center = [0.5, 0.5, 0.5]
radius = 0.2
[[bodies]]
shape = \"sphere\"
center = [0.5, 0.5, 0.5]
radius = -0.1
",
        "bad.toml",
    )
    .unwrap_err();
    assert_eq!(
        (&err.key, &err.message, &err.hint),
        (&file_err.key, &file_err.message, &file_err.hint)
    );
    assert_eq!(
        err.to_string(),
        format!("error: {}\n  fix: {}", err.message, err.hint)
    );
}

#[test]
fn build_refuses_other_mistakes_by_key() {
    let key = |builder: firn_core::scene::SceneBuilder| builder.build().unwrap_err().key;
    let ball = || Body::sphere(Vec3::splat(0.5), 0.2);

    // A material index past the materials added.
    assert_eq!(
        key(Scene::builder("m").body(ball().material(1))).as_deref(),
        Some("bodies[0].material")
    );
    // No snow at all.
    assert_eq!(key(Scene::builder("empty")).as_deref(), Some("bodies"));
    // A body outside the domain.
    assert_eq!(
        key(Scene::builder("out").body(Body::sphere(Vec3::splat(2.0), 0.2))).as_deref(),
        Some("bodies[0].center")
    );
    // A fixed step longer than a frame.
    assert_eq!(
        key(Scene::builder("dt").fixed_dt(0.1).body(ball())).as_deref(),
        Some("time.dt")
    );
    // Negative friction on a collider.
    assert_eq!(
        key(Scene::builder("c")
            .body(ball())
            .collider(Collider::sphere(Vec3::ZERO, 0.1).friction(-1.0)))
        .as_deref(),
        Some("colliders[0].friction")
    );
    // An empty name.
    assert_eq!(
        key(Scene::builder(" ").body(ball())).as_deref(),
        Some("name")
    );
    // A flow without emitters.
    assert_eq!(
        key(Scene::builder("f").flow(FlowSettings::default())).as_deref(),
        Some("flow.emitters")
    );
}

/// The builder example of docs/scene-format.md is the scene of the TOML
/// example above it.
#[test]
fn documented_two_snowballs_match() {
    let file = load(
        "format = 1
name = \"two-snowballs\"

[domain]
max = [2.0, 1.0, 1.0]
cell_size = 0.02

[time]
duration = 1.0
fps = 30

[solver]
transfer = \"apic\"

[[bodies]]
shape = \"sphere\"
center = [0.5, 0.5, 0.5]
radius = 0.1
velocity = [4.0, 0.5, 0.0]
material = \"snow\"

[[bodies]]
shape = \"sphere\"
center = [1.5, 0.5, 0.5]
radius = 0.1
velocity = [-4.0, 0.5, 0.0]
material = \"icy\"
",
        "docs",
    );
    let built = build(
        Scene::builder("two-snowballs")
            .domain(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0), 0.02)
            .duration(1.0)
            .transfer(Transfer::Apic)
            .material(Material::preset("snow").unwrap())
            .material(Material::preset("icy").unwrap())
            .body(Body::sphere(Vec3::new(0.5, 0.5, 0.5), 0.1).velocity(Vec3::new(4.0, 0.5, 0.0)))
            .body(
                Body::sphere(Vec3::new(1.5, 0.5, 0.5), 0.1)
                    .velocity(Vec3::new(-4.0, 0.5, 0.0))
                    .material(1),
            ),
    );
    assert_eq!(built, file);
}
