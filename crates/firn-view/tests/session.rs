//! The viewer's session without a window: the panel's actions change the
//! simulation through the same code path the panel uses, and the
//! fixed-timestep loop makes the result independent of the display rate.

use firn_core::Scene;
use firn_core::scene::SceneKind;
use firn_view::draw::DrawStyle;
use firn_view::session::{Action, Content, Session};
use glam::Vec3;

/// A slab of snow resting on the floor.
const SLAB: &str = r#"
format = 1
name = "slab"

[domain]
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 1.0]
cell_size = 0.05

[time]
duration = 1.0
fps = 24
step = "adaptive"

[solver]
transfer = "apic"

[materials.snow]
preset = "snow"

[[bodies]]
shape = "box"
center = [0.5, 0.1, 0.5]
size = [0.3, 0.2, 0.3]
material = "snow"
"#;

/// A small curl-noise flow with an obstacle.
const FLOW: &str = r#"
format = 1
name = "flow"
kind = "flow"

[domain]
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 1.0]
cell_size = 0.05

[time]
duration = 1.0
fps = 30

[flow]
noise_share = 0.5
noise_strength = 0.05
length_scale = 0.3
background_direction = [1.0, 0.0, 0.0]
background_strength = 0.3
seed = 3

[[flow.obstacles]]
center = [0.5, 0.5, 0.5]
radius = 0.15

[[flow.emitters]]
shape = "box"
center = [0.2, 0.5, 0.5]
size = [0.1, 0.3, 0.3]
count = 400
"#;

fn scene(text: &str) -> Scene {
    Scene::from_toml_str(text, "test scene").expect("the test scene is valid")
}

/// Runs `frames` display frames of 1/`fps` seconds each.
fn play(session: &mut Session, fps: u32, frames: u32) {
    for _ in 0..frames {
        session.advance_frame(1.0 / f64::from(fps));
    }
}

/// The live CPU snow simulation's positions.
fn positions(session: &Session) -> Vec<Vec3> {
    let Content::Live(live) = session.content() else {
        panic!("a live session")
    };
    live.host_particles(session.color_by())
        .expect("on the CPU")
        .positions
        .to_vec()
}

fn mean_height(session: &Session) -> f32 {
    let positions = positions(session);
    positions.iter().map(|x| x.y).sum::<f32>() / positions.len() as f32
}

#[test]
fn lowering_youngs_modulus_through_the_panel_action_makes_snow_sag_more() {
    let mut stiff = Session::live(scene(SLAB), None).unwrap();
    let mut soft = Session::live(scene(SLAB), None).unwrap();
    let mut materials = soft.scene().materials.clone();
    materials[0].youngs_modulus /= 20.0;
    soft.apply(Action::SetMaterials(materials.clone()));
    assert_eq!(soft.rejected(), None);
    assert_eq!(soft.scene().materials, materials);
    play(&mut stiff, 60, 30);
    play(&mut soft, 60, 30);
    let (stiff_height, soft_height) = (mean_height(&stiff), mean_height(&soft));
    println!("mean height after 0.5 s: stiff {stiff_height:.4} m, soft {soft_height:.4} m");
    assert!(
        soft_height < stiff_height - 0.002,
        "soft {soft_height} against stiff {stiff_height}"
    );
}

#[test]
fn a_bad_material_from_the_panel_is_refused_and_changes_nothing() {
    let mut session = Session::live(scene(SLAB), None).unwrap();
    let before = session.scene().materials.clone();
    let mut materials = before.clone();
    materials[0].poisson_ratio = 0.7;
    session.apply(Action::SetMaterials(materials));
    let reason = session.rejected().expect("refused");
    assert!(reason.contains("poisson"), "{reason}");
    assert_eq!(session.scene().materials, before);
}

#[test]
fn simulated_time_and_state_do_not_depend_on_the_display_rate() {
    let mut at_30 = Session::live(scene(FLOW), None).unwrap();
    let mut at_144 = Session::live(scene(FLOW), None).unwrap();
    play(&mut at_30, 30, 30);
    play(&mut at_144, 144, 144);
    // One tick per flow substep: 30 frames per second, two substeps each.
    assert_eq!(at_30.clock().ticks(), 60);
    assert_eq!(at_30.clock().ticks(), at_144.clock().ticks());
    assert_eq!(at_30.time(), at_144.time());
    assert!((at_30.time() - 1.0).abs() < 1e-9, "{}", at_30.time());
    let bits = |session: &Session| -> Vec<[u32; 3]> {
        positions(session)
            .iter()
            .map(|x| x.to_array().map(f32::to_bits))
            .collect()
    };
    assert_eq!(bits(&at_30), bits(&at_144));
}

#[test]
fn flow_parameters_from_the_panel_change_the_flow() {
    let mut steady = Session::live(scene(FLOW), None).unwrap();
    let mut changed = Session::live(scene(FLOW), None).unwrap();
    let SceneKind::Flow(settings) = &changed.scene().kind else {
        panic!("a flow scene")
    };
    let mut settings = (**settings).clone();
    settings.background_direction = Vec3::Y;
    settings.obstacles[0].radius = 0.05;
    changed.apply(Action::SetFlow(Box::new(settings.clone())));
    assert_eq!(changed.rejected(), None);
    assert_eq!(changed.scene().kind, SceneKind::Flow(Box::new(settings)));
    play(&mut steady, 30, 15);
    play(&mut changed, 30, 15);
    let mean = |session: &Session| {
        let positions = positions(session);
        positions.iter().copied().sum::<Vec3>() / positions.len() as f32
    };
    let (before, after) = (mean(&steady), mean(&changed));
    println!("mean position after 0.5 s: {before} with the background along x, {after} along y");
    assert!(after.y > before.y + 0.05, "{before} against {after}");
}

#[test]
fn pause_step_and_restart() {
    let mut session = Session::live(scene(FLOW), None).unwrap();
    session.apply(Action::Pause);
    play(&mut session, 60, 10);
    assert_eq!(session.time(), 0.0);
    session.apply(Action::Step);
    assert_eq!(session.clock().ticks(), 1);
    assert!((session.time() - session.clock().tick()).abs() < 1e-12);
    let first = positions(&session);
    session.apply(Action::Restart);
    assert_eq!(session.time(), 0.0);
    session.apply(Action::Step);
    assert_eq!(positions(&session), first);
    session.apply(Action::SetStyle(DrawStyle::Billboards));
    assert_eq!(session.style(), DrawStyle::Billboards);
}

/// A live run of powder in a gale with spindrift on the GPU is read back
/// each frame, so its snow and its drift are drawn apart (the device
/// buffers hold both).
#[test]
fn live_spindrift_on_the_gpu_draws_the_drift_apart() {
    let Some(context) = firn_gpu::context_for_tests() else {
        return;
    };
    let text = format!(
        "{SLAB}\n[wind]\nbackground_direction = [1.0, 0.0, 0.0]\nbackground_strength = 8.0\n\
         noise_share = 0.0\n[wind.spindrift]\nrate = 40.0\n"
    )
    .replace("preset = \"snow\"", "preset = \"snow\"\ndensity = 100.0");
    let mut session = Session::live(scene(&text), Some(context)).unwrap();
    assert!(session.draws_read_back());
    let Content::Live(live) = session.content() else {
        panic!("a live session")
    };
    let start = live.particle_count();
    for _ in 0..4 {
        session.apply(Action::Step);
    }
    let Content::Live(live) = session.content() else {
        panic!("a live session")
    };
    let drawn = live
        .host_particles(session.color_by())
        .expect("read back from the GPU");
    let drift = drawn
        .drift
        .expect("a scene with spindrift has a drift layer");
    assert!(!drift.is_empty(), "no drift after {} s", session.time());
    assert!(
        drawn.positions.len() + drift.len() <= start,
        "{} snow and {} drift particles of {start}",
        drawn.positions.len(),
        drift.len()
    );
}

/// The live rigid bodies' poses.
fn bodies(session: &Session) -> Vec<firn_io::BodyPose> {
    let Content::Live(live) = session.content() else {
        panic!("a live session")
    };
    live.host_particles(session.color_by())
        .expect("on the CPU")
        .rigid_bodies
}

#[test]
fn a_ball_thrown_along_the_view_flies_into_the_snow() {
    let mut session = Session::live(scene(SLAB), None).unwrap();
    let (eye, target) = (Vec3::new(0.5, 0.9, 1.6), Vec3::new(0.5, 0.1, 0.5));
    session.apply(Action::Throw { eye, target });
    assert_eq!(session.rejected(), None);
    assert_eq!(session.scene().rigid_bodies.len(), 1);
    let start = Vec3::from(bodies(&session)[0].position);
    assert!(
        start.z < 1.0 && start.y < 1.0,
        "thrown from inside the domain: {start}"
    );
    play(&mut session, 24, 3);
    let flown = Vec3::from(bodies(&session)[0].position);
    let along = (flown - start).dot((target - eye).normalize());
    assert!(along > 0.05, "the ball flew {along} m along the view");
    session.apply(Action::Throw {
        eye,
        target: eye + Vec3::Z,
    });
    assert!(session.rejected().is_some(), "looking away throws nothing");
    assert_eq!(session.scene().rigid_bodies.len(), 1);
}
