//! Flow scenes (`kind = "flow"`, seed 002): defaults, every key, and bad
//! input located by line, column and key with a fix.

use firn_core::scene::{
    Attribute, FlowCurl, FlowEmission, FlowEmitterShape, FlowIntegrator, FlowSettings, SceneKind,
};
use firn_core::{Scene, SceneError};
use glam::Vec3;

/// The head of a valid flow scene, 9 lines long; [flow] keys follow on line 10.
const HEAD: &str = "format = 1
kind = \"flow\"

[domain]
max = [100.0, 100.0, 100.0]

[time]
duration = 2.0
[flow]
";

/// A valid emitter, appended after the [flow] keys.
const EMITTER: &str = "
[[flow.emitters]]
shape = \"box\"
center = [50.0, 50.0, 50.0]
size = [20.0, 20.0, 20.0]
count = 1000
";

fn load(text: &str) -> Scene {
    Scene::from_toml_str(text, "scenes/flow.toml").unwrap_or_else(|err| panic!("{err}"))
}

fn flow(scene: &Scene) -> &FlowSettings {
    scene.kind.flow().expect("a flow scene")
}

/// Parse `text`, which must fail.
fn error(text: &str) -> SceneError {
    match Scene::from_toml_str(text, "scenes/bad.toml") {
        Ok(_) => panic!("scene should not load:\n{text}"),
        Err(err) => err,
    }
}

/// Assert the location and key of an error, and that its hint mentions `hint`.
#[track_caller]
fn check(err: &SceneError, line: usize, column: usize, key: Option<&str>, hint: &str) {
    assert_eq!(
        (err.line, err.column),
        (Some(line), Some(column)),
        "wrong place:\n{err}"
    );
    assert_eq!(err.key.as_deref(), key, "wrong key:\n{err}");
    assert!(
        err.hint.contains(hint),
        "hint should mention {hint:?}:\n{err}"
    );
}

#[test]
fn minimal_flow_scene_takes_documented_defaults() {
    let scene = load(&format!("{HEAD}{EMITTER}"));
    assert_eq!(scene.name, "flow");
    assert!(scene.bodies.is_empty() && scene.materials.is_empty());
    assert_eq!(scene.domain.cell_size, 1.0, "1/100 of the largest extent");
    assert_eq!(scene.output.attributes, vec![Attribute::Velocity]);
    let flow = flow(&scene);
    assert_eq!(flow.noise_share, 0.5);
    assert_eq!(flow.noise_strength, 5.0, "a quarter of the length scale");
    assert_eq!(flow.length_scale, 20.0, "a fifth of the domain");
    assert_eq!(flow.background_direction, Vec3::X);
    assert_eq!(flow.background_strength, 1.0);
    assert_eq!(flow.speed_scale, 1.0);
    assert_eq!(flow.seed, 1);
    assert_eq!(flow.offsets, None);
    assert_eq!(flow.evolution_rate, 0.0);
    assert_eq!(flow.curl, FlowCurl::Analytic);
    assert_eq!(flow.integrator, FlowIntegrator::Rk2);
    assert_eq!(flow.substeps, 2);
    assert!(flow.obstacles.is_empty());
    assert_eq!(flow.emitters.len(), 1);
    let emitter = flow.emitters[0];
    assert_eq!(emitter.emission, FlowEmission::Count(1000));
    assert_eq!(emitter.lifetime, None);
    assert_eq!(emitter.lifetime_spread, 0.0);
    assert_eq!(emitter.velocity, Vec3::ZERO);
}

#[test]
fn every_flow_key_is_read() {
    let scene = load(&format!(
        "{HEAD}noise_share = 0.25
noise_strength = 2.0
length_scale = 15.0
background_direction = [0.0, 2.0, 0.0]
background_strength = 3.0
speed_scale = 0.5
seed = 9
offsets = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]
evolution_rate = 0.1
curl = \"finite-difference\"
curl_step = 0.05
integration = \"rk4\"
substeps = 3

[[flow.obstacles]]
center = [50.0, 50.0, 50.0]
radius = 10.0
influence = 5.0

[[flow.obstacles]]
center = [80.0, 50.0, 50.0]
radius = 4.0

[[flow.emitters]]
shape = \"disc\"
center = [10.0, 50.0, 50.0]
radius = 5.0
normal = [3.0, 0.0, 0.0]
rate = 200.0
lifetime = 4.0
lifetime_spread = 0.5
velocity = [2.0, 0.0, 0.0]
velocity_decay = 0.5

[[flow.emitters]]
shape = \"sphere\"
center = [50.0, 20.0, 50.0]
radius = 5.0
count = 10
"
    ));
    let flow = flow(&scene);
    assert_eq!(flow.noise_share, 0.25);
    assert_eq!(flow.noise_strength, 2.0);
    assert_eq!(flow.length_scale, 15.0);
    assert_eq!(flow.background_direction, Vec3::Y, "normalised");
    assert_eq!(flow.background_strength, 3.0);
    assert_eq!(flow.speed_scale, 0.5);
    assert_eq!(flow.seed, 9);
    assert_eq!(
        flow.offsets,
        Some([
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(4.0, 5.0, 6.0),
            Vec3::new(7.0, 8.0, 9.0)
        ])
    );
    assert_eq!(flow.evolution_rate, 0.1);
    assert_eq!(flow.curl, FlowCurl::FiniteDifference { step: 0.05 });
    assert_eq!(flow.integrator, FlowIntegrator::Rk4);
    assert_eq!(flow.substeps, 3);
    assert_eq!(flow.obstacles.len(), 2);
    assert_eq!(flow.obstacles[0].influence, 5.0);
    assert_eq!(flow.obstacles[1].influence, 4.0, "defaults to the radius");
    let disc = flow.emitters[0];
    assert_eq!(
        disc.shape,
        FlowEmitterShape::Disc {
            center: Vec3::new(10.0, 50.0, 50.0),
            radius: 5.0,
            normal: Vec3::X
        }
    );
    assert_eq!(disc.emission, FlowEmission::Rate(200.0));
    assert_eq!(disc.lifetime, Some(4.0));
    assert_eq!(disc.lifetime_spread, 0.5);
    assert_eq!(disc.velocity, Vec3::new(2.0, 0.0, 0.0));
    assert_eq!(disc.velocity_decay, 0.5);
    assert_eq!(flow.emitters[1].emission, FlowEmission::Count(10));
    // The default finite-difference step is L / 1000.
    let scene = load(&format!("{HEAD}curl = \"finite-difference\"\n{EMITTER}"));
    assert_eq!(
        scene.kind.flow().unwrap().curl,
        FlowCurl::FiniteDifference { step: 0.02 }
    );
}

#[test]
fn snow_scenes_are_snow_by_default_and_by_name() {
    let snow = "format = 1\n\n[domain]\nmax = [1.0, 1.0, 1.0]\ncell_size = 0.05\n\n[time]\n\
                duration = 1.0\n\n[[bodies]]\nshape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\n\
                radius = 0.2\n";
    assert_eq!(load(snow).kind, SceneKind::Snow);
    let named = snow.replace("format = 1\n", "format = 1\nkind = \"snow\"\n");
    assert_eq!(load(&named).kind, SceneKind::Snow);
}

#[test]
fn flow_table_in_a_snow_scene() {
    let err = error(
        "format = 1\n\n[domain]\nmax = [1.0, 1.0, 1.0]\ncell_size = 0.05\n\n[time]\n\
         duration = 1.0\n\n[[bodies]]\nshape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\n\
         radius = 0.2\n\n[flow]\nnoise_share = 0.5\n",
    );
    check(&err, 15, 1, Some("flow"), "kind = \"flow\"");
}

#[test]
fn snow_only_keys_in_a_flow_scene_are_named() {
    // A dotted header ([materials.wet]) is located at its first key.
    let cases = [
        (
            "[[bodies]]\nshape = \"sphere\"\n",
            1,
            "bodies",
            "[[flow.emitters]]",
        ),
        (
            "[[colliders]]\nshape = \"plane\"\n",
            1,
            "colliders",
            "[[flow.obstacles]]",
        ),
        (
            "[materials.wet]\ndensity = 600.0\n",
            2,
            "materials",
            "no material",
        ),
        ("[solver]\nseed = 3\n", 1, "solver", "keys of [flow]"),
    ];
    for (table, column, key, hint) in cases {
        let err = error(&format!("{HEAD}{EMITTER}\n{table}"));
        check(&err, 17, column, Some(key), hint);
        assert!(
            err.message.contains("is for snow scenes") && err.message.contains("kind = \"flow\""),
            "{err}"
        );
    }
    let err = error(&HEAD.replace("duration = 2.0", "duration = 2.0\ndt = 0.01"));
    check(&err, 9, 6, Some("time.dt"), "flow.substeps");
    let err = error(&HEAD.replace(
        "duration = 2.0",
        "duration = 2.0\nmax_substeps_per_frame = 10",
    ));
    check(
        &err,
        9,
        26,
        Some("time.max_substeps_per_frame"),
        "flow.substeps",
    );
    let err = error(&HEAD.replace(
        "max = [100.0, 100.0, 100.0]",
        "max = [100.0, 100.0, 100.0]\nwalls = { mode = \"slip\" }",
    ));
    check(&err, 6, 9, Some("domain.walls"), "born again");
}

#[test]
fn unknown_flow_key_suggests_the_closest() {
    let err = error(&format!("{HEAD}noise_shar = 0.5\n{EMITTER}"));
    check(
        &err,
        10,
        1,
        Some("flow.noise_shar"),
        "did you mean `noise_share`?",
    );
    let err = error(&format!("{HEAD}integrator = \"rk4\"\n{EMITTER}"));
    check(
        &err,
        10,
        1,
        Some("flow.integrator"),
        "did you mean `integration`?",
    );
}

#[test]
fn unknown_kind_lists_the_kinds() {
    let err = error(&HEAD.replace("kind = \"flow\"", "kind = \"flo\""));
    check(&err, 2, 8, Some("kind"), "did you mean \"flow\"?");
    assert!(err.hint.contains("\"snow\""), "{err}");
}

#[test]
fn noise_share_outside_zero_to_one() {
    let err = error(&format!("{HEAD}noise_share = 1.5\n{EMITTER}"));
    check(&err, 10, 15, Some("flow.noise_share"), "noise_share = 0.5");
    assert_eq!(err.message, "flow.noise_share must be in [0, 1] (got 1.5)");
}

#[test]
fn length_scale_must_be_positive() {
    let err = error(&format!("{HEAD}length_scale = 0.0\n{EMITTER}"));
    check(
        &err,
        10,
        16,
        Some("flow.length_scale"),
        "length_scale = 20.0",
    );
}

#[test]
fn zero_background_direction() {
    let err = error(&format!(
        "{HEAD}background_direction = [0.0, 0.0, 0.0]\n{EMITTER}"
    ));
    check(
        &err,
        10,
        24,
        Some("flow.background_direction"),
        "background_direction = [1.0, 0.0, 0.0]",
    );
    assert!(err.message.contains("zero vector"), "{err}");
}

#[test]
fn curl_step_needs_finite_differences_and_a_small_step() {
    let err = error(&format!("{HEAD}curl_step = 0.01\n{EMITTER}"));
    check(
        &err,
        10,
        13,
        Some("flow.curl_step"),
        "curl = \"finite-difference\"",
    );
    let err = error(&format!(
        "{HEAD}curl = \"finite-difference\"\ncurl_step = 5.0\n{EMITTER}"
    ));
    check(&err, 11, 13, Some("flow.curl_step"), "curl_step = 0.02");
    assert!(
        err.message.contains("a tenth of flow.length_scale"),
        "{err}"
    );
}

#[test]
fn substeps_must_be_at_least_one() {
    let err = error(&format!("{HEAD}substeps = 0\n{EMITTER}"));
    check(&err, 10, 12, Some("flow.substeps"), "substeps = 2");
}

#[test]
fn flow_without_emitters_has_no_particles() {
    let err = error(&format!("{HEAD}noise_share = 0.5\n"));
    check(&err, 9, 1, Some("flow.emitters"), "[[flow.emitters]]");
    assert!(err.message.contains("no particles"), "{err}");
    // No [flow] table at all: point at `kind`.
    let err = error(HEAD.trim_end_matches("[flow]\n"));
    check(&err, 2, 8, Some("flow"), "[[flow.emitters]]");
}

#[test]
fn emitter_needs_rate_or_count_but_not_both() {
    let err = error(&format!("{HEAD}{}", EMITTER.replace("count = 1000\n", "")));
    check(&err, 11, 1, Some("flow.emitters[0].count"), "rate = 1000.0");
    let err = error(&format!(
        "{HEAD}{}",
        EMITTER.replace("count = 1000", "count = 1000\nrate = 5.0")
    ));
    check(&err, 15, 9, Some("flow.emitters[0].count"), "remove one");
}

#[test]
fn emitter_key_that_does_not_fit_the_shape() {
    let err = error(&format!(
        "{HEAD}{}",
        EMITTER.replace("count = 1000", "count = 1000\nradius = 3.0")
    ));
    check(
        &err,
        16,
        10,
        Some("flow.emitters[0].radius"),
        "a box takes center and size",
    );
}

#[test]
fn emitter_outside_the_domain_names_emitter_and_axis() {
    let err = error(&format!(
        "{HEAD}{}",
        EMITTER.replace("center = [50.0, 50.0, 50.0]", "center = [50.0, 95.0, 50.0]")
    ));
    check(
        &err,
        13,
        10,
        Some("flow.emitters[0].center"),
        "inside domain.min",
    );
    assert!(
        err.message
            .contains("flow.emitters[0] (box) sticks out of the domain along y"),
        "{err}"
    );
}

#[test]
fn lifetime_spread_needs_a_lifetime_and_stays_below_one() {
    let err = error(&format!(
        "{HEAD}{}",
        EMITTER.replace("count = 1000", "count = 1000\nlifetime_spread = 0.2")
    ));
    check(
        &err,
        16,
        19,
        Some("flow.emitters[0].lifetime_spread"),
        "lifetime = 8.0",
    );
    let err = error(&format!(
        "{HEAD}{}",
        EMITTER.replace(
            "count = 1000",
            "count = 1000\nlifetime = 3.0\nlifetime_spread = 1.0"
        )
    ));
    check(
        &err,
        17,
        19,
        Some("flow.emitters[0].lifetime_spread"),
        "lifetime_spread = 0.25",
    );
}

#[test]
fn too_many_particles_gives_the_count() {
    let err = error(&format!(
        "{HEAD}{}",
        EMITTER.replace("count = 1000", "rate = 1e7\nlifetime = 10.0")
    ));
    check(
        &err,
        15,
        8,
        Some("flow.emitters[0].rate"),
        "rate × lifetime",
    );
    assert!(err.message.contains("100000000 particles"), "{err}");
}

#[test]
fn obstacle_needs_a_positive_radius_and_influence() {
    let err = error(&format!(
        "{HEAD}{EMITTER}\n[[flow.obstacles]]\ncenter = [50.0, 50.0, 50.0]\nradius = -1.0\n"
    ));
    check(
        &err,
        19,
        10,
        Some("flow.obstacles[0].radius"),
        "radius = 15.0",
    );
    let err = error(&format!(
        "{HEAD}{EMITTER}\n[[flow.obstacles]]\ncenter = [50.0, 50.0, 50.0]\n"
    ));
    check(
        &err,
        17,
        1,
        Some("flow.obstacles[0].radius"),
        "radius = 0.1",
    );
    let err = error(&format!(
        "{HEAD}{EMITTER}\n[[flow.obstacles]]\ncenter = [50.0, 50.0, 50.0]\nradius = 5.0\n\
         influence = 0.0\n"
    ));
    check(
        &err,
        20,
        13,
        Some("flow.obstacles[0].influence"),
        "influence = 10.0",
    );
}

#[test]
fn snow_attributes_in_a_flow_scene() {
    let err = error(&format!(
        "{HEAD}{EMITTER}\n[output]\nattributes = [\"velocity\", \"density\"]\n"
    ));
    check(
        &err,
        18,
        27,
        Some("output.attributes[1]"),
        "attributes = [\"velocity\"]",
    );
}

#[test]
fn vdb_volumes_in_a_flow_scene() {
    let err = error(&format!(
        "{HEAD}{EMITTER}\n[output]\nformats = [\"ply\", \"vdb\"]\n"
    ));
    check(
        &err,
        18,
        19,
        Some("output.formats[1]"),
        "remove \"vdb\" from formats",
    );
}

#[test]
fn surface_meshes_and_pictures_in_a_flow_scene() {
    let err = error(&format!(
        "{HEAD}{EMITTER}\n[output]\nformats = [\"mesh\"]\n"
    ));
    check(
        &err,
        18,
        12,
        Some("output.formats[0]"),
        "remove \"mesh\" from formats",
    );
    let err = error(&format!(
        "{HEAD}{EMITTER}\n[render]\nstyles = [\"points\", \"surface\"]\n"
    ));
    check(&err, 18, 21, Some("render.styles[1]"), "\"trails\"");
}

#[test]
fn flow_scenes_built_in_code_are_checked_too() {
    let mut scene = load(&format!("{HEAD}{EMITTER}"));
    scene.validate().unwrap();
    if let SceneKind::Flow(flow) = &mut scene.kind {
        flow.emitters.clear();
    }
    let err = scene.validate().unwrap_err();
    assert_eq!(err.key.as_deref(), Some("flow.emitters"));
    let mut scene = load(&format!("{HEAD}{EMITTER}"));
    scene.bodies.push(firn_core::scene::Body {
        shape: firn_core::scene::Shape::Sphere {
            center: Vec3::splat(50.0),
            radius: 1.0,
        },
        velocity: Vec3::ZERO,
        material: 0,
        particles_per_cell: 8,
        clumps: None,
    });
    let err = scene.validate().unwrap_err();
    assert_eq!(err.key.as_deref(), Some("bodies"), "{err}");
}

#[test]
fn the_bundled_curl_noise_demo_loads() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/curl-noise-demo.toml");
    let scene = Scene::load(&path).unwrap_or_else(|err| panic!("{err}"));
    let flow = scene.kind.flow().expect("a flow scene");
    assert_eq!(flow.obstacles.len(), 1, "one sphere, as in the seed's demo");
    assert_eq!(flow.length_scale, 20.0);
    assert!(flow.noise_share > 0.0 && flow.noise_share < 1.0);
    assert!(flow.background_strength > 0.0);
    assert!(scene.camera.path.len() >= 3, "a camera sweep");
    use firn_core::scene::{ColorBy, RenderStyle};
    assert_eq!(
        scene.render.styles,
        vec![
            RenderStyle::Points,
            RenderStyle::Billboards,
            RenderStyle::Trails
        ]
    );
    assert_eq!(scene.render.color_by, ColorBy::Position);
}
