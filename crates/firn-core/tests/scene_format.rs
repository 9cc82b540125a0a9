//! Loading scene files: defaults, presets, overrides and the resolved model.

use std::path::{Path, PathBuf};

use firn_core::scene::{
    Attribute, CacheFormat, ColliderGeometry, ContactMode, Material, Motion, Shape, TimeStep,
    Transfer,
};
use firn_core::{Scene, SceneError};
use glam::Vec3;

fn load(text: &str) -> Scene {
    match Scene::from_toml_str(text, "scenes/test.toml") {
        Ok(scene) => scene,
        Err(err) => panic!("scene should load, but:\n{err}"),
    }
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

const MINIMAL: &str = r#"format = 1

[domain]
max = [1.0, 1.0, 1.0]
cell_size = 0.05

[time]
duration = 1.0

[[bodies]]
shape = "sphere"
center = [0.5, 0.5, 0.5]
radius = 0.2
"#;

#[test]
fn minimal_scene_takes_documented_defaults() {
    let scene = Scene::from_toml_str(MINIMAL, "scenes/minimal.toml").unwrap();

    assert_eq!(scene.name, "minimal");
    assert_eq!(scene.domain.min, Vec3::ZERO);
    assert_eq!(scene.domain.max, Vec3::ONE);
    assert_eq!(scene.domain.cell_size, 0.05);
    assert_eq!(scene.domain.walls.mode, ContactMode::Separate);
    assert_eq!(scene.domain.walls.friction, 0.2);

    assert_eq!(scene.time.duration, 1.0);
    assert_eq!(scene.time.fps, 30.0);
    assert_eq!(
        scene.time.step,
        TimeStep::Adaptive {
            cfl: 0.4,
            max_dt: 1e-3
        }
    );

    assert_eq!(scene.solver.transfer, Transfer::PicFlip);
    assert_eq!(scene.solver.flip_blend, 0.95);
    assert_eq!(scene.solver.gravity, Vec3::new(0.0, -9.81, 0.0));
    assert_eq!(scene.solver.seed, 1);

    assert_eq!(scene.materials, vec![Material::preset("snow").unwrap()]);
    assert_eq!(scene.bodies.len(), 1);
    let body = &scene.bodies[0];
    assert_eq!(
        body.shape,
        Shape::Sphere {
            center: Vec3::splat(0.5),
            radius: 0.2
        }
    );
    assert_eq!(body.velocity, Vec3::ZERO);
    assert_eq!(body.material, 0);
    assert_eq!(body.particles_per_cell, 8);
    assert!(scene.colliders.is_empty());

    assert_eq!(scene.output.directory, Path::new("out").join("minimal"));
    assert_eq!(
        scene.output.formats,
        vec![CacheFormat::Ply, CacheFormat::Vtk]
    );
    assert_eq!(
        scene.output.attributes,
        vec![Attribute::Velocity, Attribute::PlasticJ, Attribute::Density]
    );
    assert_eq!(scene.output.checkpoint_every, 10);
    assert_eq!(scene.validate(), Ok(()));
}

#[test]
fn name_defaults_to_scene_without_a_toml_origin() {
    let scene = Scene::from_toml_str(MINIMAL, "<memory>").unwrap();
    assert_eq!(scene.name, "scene");
    assert_eq!(scene.output.directory, Path::new("out").join("scene"));

    let named = load(&MINIMAL.replace("format = 1\n", "format = 1\nname = \"flurry\"\n"));
    assert_eq!(named.name, "flurry");
    assert_eq!(named.output.directory, Path::new("out").join("flurry"));
}

#[test]
fn load_reads_a_file_and_names_the_scene_after_it() {
    let scene = Scene::load(&fixture("minimal.toml")).unwrap();
    assert_eq!(scene.name, "minimal");
    assert_eq!(
        scene,
        Scene::from_toml_str(MINIMAL, "minimal.toml").unwrap()
    );
}

#[test]
fn load_reports_errors_under_the_file_path() {
    let path = fixture("bad_radius.toml");
    let err: SceneError = Scene::load(&path).unwrap_err();
    assert_eq!(err.file, path.display().to_string());
    assert_eq!((err.line, err.column), (Some(13), Some(10)));
    assert_eq!(err.key.as_deref(), Some("bodies[0].radius"));
    let shown = err.to_string();
    assert!(
        shown.starts_with(&format!(
            "error: {}:13:10: bodies[0].radius must be greater than 0 (got -0.2)\n  fix: ",
            path.display()
        )),
        "{shown}"
    );
}

#[test]
fn every_key_is_read() {
    let scene = load(
        r#"format = 1
name = "full"

[domain]
min = [-1.0, 0.0, -1.0]
max = [1.0, 2.0, 1.0]
cell_size = 0.05
walls = { mode = "slip", friction = 0.4 }

[time]
duration = 3.0
fps = 24
step = "adaptive"
dt = 5e-4
cfl = 0.6

[solver]
transfer = "apic"
flip = 0.9
gravity = [0.0, -3.0, 0.0]
seed = 77

[[bodies]]
shape = "cylinder"
center = [0.0, 1.0, 0.0]
radius = 0.2
height = 0.4
axis = [0.0, 0.0, 2.0]
velocity = [1.0, 2.0, 3.0]
particles_per_cell = 27

[[bodies]]
shape = "box"
center = [0.5, 0.3, 0.5]
size = [0.2, 0.4, 0.6]

[[colliders]]
shape = "plane"
point = [0.0, 0.1, 0.0]
normal = [0.0, 3.0, 4.0]
mode = "sticky"
friction = 1.5

[[colliders]]
shape = "sphere"
center = [0.0, 1.5, 0.0]
radius = 0.1
velocity = [0.0, -1.0, 0.0]

[[colliders]]
shape = "box"
center = [0.5, 1.5, 0.5]
size = [0.1, 0.1, 0.1]
keyframes = [
  { time = 0.0, position = [0.5, 1.5, 0.5] },
  { time = 1.0, position = [0.5, 1.0, 0.5] },
]

[output]
directory = "renders/full"
formats = ["vtk", "vdb"]
attributes = ["mass", "material", "elastic-j"]
checkpoint_every = 0
vdb = { voxel_size = 0.02, level_set = true }
"#,
    );
    assert_eq!(scene.name, "full");
    assert_eq!(scene.domain.min, Vec3::new(-1.0, 0.0, -1.0));
    assert_eq!(scene.domain.walls.mode, ContactMode::Slip);
    assert_eq!(scene.domain.walls.friction, 0.4);
    assert_eq!(scene.time.fps, 24.0);
    assert_eq!(
        scene.time.step,
        TimeStep::Adaptive {
            cfl: 0.6,
            max_dt: 5e-4
        }
    );
    assert_eq!(scene.solver.transfer, Transfer::Apic);
    assert_eq!(scene.solver.flip_blend, 0.9);
    assert_eq!(scene.solver.gravity, Vec3::new(0.0, -3.0, 0.0));
    assert_eq!(scene.solver.seed, 77);

    // The cylinder's axis is normalised.
    assert_eq!(
        scene.bodies[0].shape,
        Shape::Cylinder {
            center: Vec3::new(0.0, 1.0, 0.0),
            axis: Vec3::Z,
            radius: 0.2,
            height: 0.4
        }
    );
    assert_eq!(scene.bodies[0].velocity, Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(scene.bodies[0].particles_per_cell, 27);
    // Both bodies use the default material, so there is one.
    assert_eq!(scene.materials.len(), 1);
    assert_eq!(scene.bodies[1].material, 0);

    let plane = &scene.colliders[0];
    assert_eq!(
        plane.geometry,
        ColliderGeometry::HalfPlane {
            point: Vec3::new(0.0, 0.1, 0.0),
            normal: Vec3::new(0.0, 0.6, 0.8)
        }
    );
    assert_eq!(plane.motion, Motion::Static);
    assert_eq!(plane.contact.mode, ContactMode::Sticky);
    assert_eq!(plane.contact.friction, 1.5);
    assert_eq!(
        scene.colliders[1].motion,
        Motion::Linear {
            velocity: Vec3::new(0.0, -1.0, 0.0),
            angular_velocity: Vec3::ZERO,
        }
    );
    assert_eq!(scene.colliders[1].contact.mode, ContactMode::Separate);
    assert_eq!(scene.colliders[1].contact.friction, 0.2);
    let Motion::Keyframed { keys, .. } = &scene.colliders[2].motion else {
        panic!("keyframed motion expected");
    };
    assert_eq!(keys.len(), 2);
    assert_eq!(keys[1].time, 1.0);
    assert_eq!(keys[1].position, Vec3::new(0.5, 1.0, 0.5));

    assert_eq!(scene.output.directory, PathBuf::from("renders/full"));
    assert_eq!(
        scene.output.formats,
        vec![CacheFormat::Vtk, CacheFormat::Vdb]
    );
    assert_eq!(scene.output.vdb.voxel_size, Some(0.02));
    assert!(scene.output.vdb.level_set);
    assert_eq!(scene.output.mesh, firn_core::scene::MeshSettings::default());
    assert_eq!(
        scene.output.attributes,
        vec![Attribute::Mass, Attribute::Material, Attribute::ElasticJ]
    );
    assert_eq!(scene.output.checkpoint_every, 0);
}

#[test]
fn fixed_step_uses_dt() {
    let scene = load(&MINIMAL.replace(
        "duration = 1.0\n",
        "duration = 1.0\nstep = \"fixed\"\ndt = 2e-4\n",
    ));
    assert_eq!(scene.time.step, TimeStep::Fixed { dt: 2e-4 });
}

#[test]
fn default_largest_step_never_exceeds_a_frame() {
    let scene = load(&MINIMAL.replace("duration = 1.0\n", "duration = 1.0\nfps = 2000\n"));
    assert_eq!(
        scene.time.step,
        TimeStep::Adaptive {
            cfl: 0.4,
            max_dt: 5e-4
        }
    );
}

fn two_bodies(materials: &str, first: &str, second: &str) -> String {
    format!(
        r#"format = 1

[domain]
max = [2.0, 1.0, 1.0]
cell_size = 0.05

[time]
duration = 1.0
{materials}
[[bodies]]
shape = "sphere"
center = [0.5, 0.5, 0.5]
radius = 0.2
material = "{first}"

[[bodies]]
shape = "sphere"
center = [1.5, 0.5, 0.5]
radius = 0.2
material = "{second}"
"#
    )
}

#[test]
fn presets_are_available_by_name() {
    for name in firn_core::scene::material::PRESET_NAMES {
        let scene = load(&two_bodies("", name, "snow"));
        assert_eq!(scene.materials[0], Material::preset(name).unwrap());
    }
}

#[test]
fn materials_are_listed_in_order_of_first_use() {
    let scene = load(&two_bodies("", "icy", "wet"));
    let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["icy", "wet"]);
    assert_eq!(scene.bodies[0].material, 0);
    assert_eq!(scene.bodies[1].material, 1);

    let shared = load(&two_bodies("", "wet", "wet"));
    assert_eq!(shared.materials.len(), 1);
    assert_eq!(shared.bodies[1].material, 0);
}

#[test]
fn overrides_apply_over_the_preset() {
    let materials = r#"
[materials.wet]
density = 600.0

[materials.crust]
preset = "icy"
critical_stretch = 0.002
hardening = 15.0

[materials.soft]
youngs_modulus = 5.0e4
poisson_ratio = 0.25

[materials.unused]
preset = "slush"
"#;
    let scene = load(&two_bodies(materials, "wet", "crust"));
    let wet = Material {
        density: 600.0,
        ..Material::preset("wet").unwrap()
    };
    let crust = Material {
        name: "crust".to_string(),
        critical_stretch: 0.002,
        hardening: 15.0,
        ..Material::preset("icy").unwrap()
    };
    assert_eq!(scene.materials, vec![wet, crust]);

    // Without a preset, a new material starts from snow.
    let scene = load(&two_bodies(materials, "soft", "snow"));
    let soft = Material {
        name: "soft".to_string(),
        youngs_modulus: 5.0e4,
        poisson_ratio: 0.25,
        ..Material::preset("snow").unwrap()
    };
    assert_eq!(scene.materials[0], soft);
    assert_eq!(scene.materials[1], Material::preset("snow").unwrap());
}

#[test]
fn validate_checks_scenes_built_in_code() {
    let mut scene = load(MINIMAL);
    assert_eq!(scene.validate(), Ok(()));

    scene.bodies[0].shape = Shape::Sphere {
        center: Vec3::splat(0.5),
        radius: -1.0,
    };
    let err = scene.validate().unwrap_err();
    assert_eq!(err.key.as_deref(), Some("bodies[0].radius"));
    assert_eq!((err.line, err.column), (None, None));
    assert_eq!(err.file, "");
    assert_eq!(
        err.to_string(),
        "error: bodies[0].radius must be greater than 0 (got -1)\n  fix: set the radius in \
         metres, e.g. radius = 0.1"
    );

    let mut scene = load(MINIMAL);
    scene.bodies[0].shape = Shape::Cylinder {
        center: Vec3::splat(0.5),
        axis: Vec3::new(0.0, 2.0, 0.0),
        radius: 0.1,
        height: 0.2,
    };
    let err = scene.validate().unwrap_err();
    assert_eq!(err.key.as_deref(), Some("bodies[0].axis"));
    assert!(err.message.contains("unit vector"), "{err}");

    let mut scene = load(MINIMAL);
    scene.bodies[0].material = 3;
    let err = scene.validate().unwrap_err();
    assert_eq!(err.key.as_deref(), Some("bodies[0].material"));

    let mut scene = load(MINIMAL);
    scene.materials[0].critical_compression = 1.0;
    let err = scene.validate().unwrap_err();
    assert_eq!(
        err.key.as_deref(),
        Some("materials.snow.critical_compression")
    );

    let mut scene = load(MINIMAL);
    scene.bodies.clear();
    let err = scene.validate().unwrap_err();
    assert_eq!(err.key.as_deref(), Some("bodies"));
    assert!(err.message.contains("no snow"), "{err}");
}

#[test]
fn integers_are_accepted_as_numbers() {
    let scene = load(&MINIMAL.replace("max = [1.0, 1.0, 1.0]", "max = [1, 2, 1]"));
    assert_eq!(scene.domain.max, Vec3::new(1.0, 2.0, 1.0));
}

#[test]
fn inline_body_tables_load_like_headers() {
    let scene = load(
        r#"format = 1
domain = { max = [1.0, 1.0, 1.0], cell_size = 0.05 }
time = { duration = 1.0 }
bodies = [
  { shape = "box", center = [0.5, 0.5, 0.5], size = [0.2, 0.2, 0.2] },
]
"#,
    );
    assert_eq!(scene.bodies.len(), 1);
}

#[test]
fn the_integrator_is_explicit_unless_asked() {
    use firn_core::scene::{ImplicitSettings, Integrator};
    assert_eq!(load(MINIMAL).solver.integrator, Integrator::Explicit);
    let defaults = load(&format!(
        "{MINIMAL}\n[solver]\nintegrator = \"semi-implicit\"\n"
    ));
    assert_eq!(
        defaults.solver.integrator,
        Integrator::SemiImplicit(ImplicitSettings::DEFAULT)
    );
    let chosen = load(&format!(
        "{MINIMAL}\n[solver]\nintegrator = \"semi-implicit\"\nimplicit_beta = 1.0\n\
         solver_tolerance = 1e-4\nsolver_max_iterations = 250\n"
    ));
    assert_eq!(
        chosen.solver.integrator,
        Integrator::SemiImplicit(ImplicitSettings {
            beta: 1.0,
            tolerance: 1e-4,
            max_iterations: 250
        })
    );
}

#[test]
fn the_backend_is_auto_unless_asked() {
    use firn_core::scene::Backend;
    assert_eq!(load(MINIMAL).compute.backend, Backend::Auto);
    for (written, backend) in [
        ("auto", Backend::Auto),
        ("cpu", Backend::Cpu),
        ("gpu", Backend::Gpu),
    ] {
        let scene = load(&format!("{MINIMAL}\n[compute]\nbackend = \"{written}\"\n"));
        assert_eq!(scene.compute.backend, backend);
        assert_eq!(backend.name(), written);
    }
    // An empty table keeps the default.
    assert_eq!(
        load(&format!("{MINIMAL}\n[compute]\n")).compute.backend,
        Backend::Auto
    );
}

#[test]
fn flow_scenes_take_a_compute_table_too() {
    use firn_core::scene::Backend;
    let scene = load(
        r#"format = 1
kind = "flow"

[domain]
max = [10.0, 10.0, 10.0]

[time]
duration = 1.0

[compute]
backend = "cpu"

[[flow.emitters]]
shape = "box"
center = [5.0, 5.0, 5.0]
size = [2.0, 2.0, 2.0]
count = 100
"#,
    );
    assert_eq!(scene.compute.backend, Backend::Cpu);
}

#[test]
fn resolved_scenes_written_before_the_compute_table_still_read() {
    use firn_core::scene::{Backend, ComputeSettings};
    let mut scene = load(&format!("{MINIMAL}\n[compute]\nbackend = \"gpu\"\n"));
    let mut json = serde_json::to_value(&scene).unwrap();
    assert_eq!(json["compute"], serde_json::json!({ "backend": "gpu" }));
    json.as_object_mut().unwrap().remove("compute");
    let old: Scene = serde_json::from_value(json).unwrap();
    scene.compute = ComputeSettings {
        backend: Backend::Auto,
    };
    assert_eq!(old, scene);
}
