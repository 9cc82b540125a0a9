//! The parameter panel (egui; the run-time panel of seed 002 §2.4):
//! play, pause, single step and restart; the snow material (E, ν, ξ, θc,
//! θs) or the flow (γ, M, L, background direction, obstacle size), live;
//! render mode and colour quantity; the camera; and the live figures.
//!
//! The panel never touches the simulation: it returns [`Action`]s, which
//! the session carries out before the next step.

use firn_core::scene::{ColorBy, FlowSettings, Material, SceneKind, Wind};

use crate::draw::DrawStyle;
use crate::session::{Action, Content, Session};

/// Width of the panel in logical pixels.
pub const PANEL_WIDTH: f32 = 270.0;

/// The keys and mouse gestures (see `input`), as the panel lists them.
const KEY_HELP: &[&str] = &[
    "left drag: orbit · right drag: pan · wheel: zoom",
    "arrows: orbit · + / -: zoom · F: frame all",
    "C: scene camera · space: play / pause",
    ". or N: step · R: restart · P or F12: screenshot",
    "1 2 3: points, billboards, trails",
];

/// View choices the panel makes that are not the session's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ViewToggles {
    /// The camera follows the scene's camera (path, orbit or fixed eye).
    pub scene_camera: bool,
    /// Frame the whole domain now.
    pub frame_all: bool,
    /// Write a screenshot of this frame.
    pub screenshot: bool,
}

/// What the panel asked for in one frame, and the room it took.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PanelOutput {
    /// The session changes asked for.
    pub actions: Vec<Action>,
    /// Width of the panel in logical pixels (the scene is framed beside it).
    pub width: f32,
}

/// Draws the panel on the left of `ui`, with `note` (e.g. where a
/// screenshot went) at the bottom; returns what it asks for.
pub fn show(
    ui: &mut egui::Ui,
    session: &Session,
    toggles: &mut ViewToggles,
    note: Option<&str>,
) -> PanelOutput {
    let mut actions = Vec::new();
    let response = egui::Panel::left("firn-panel")
        .exact_size(PANEL_WIDTH)
        .resizable(false)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                ui.heading(format!("firn · {}", session.scene().name));
                transport(ui, session, &mut actions);
                figures(ui, session);
                ui.separator();
                look(ui, session, toggles, &mut actions);
                ui.separator();
                parameters(ui, session, &mut actions);
                ui.separator();
                ui.collapsing("keys and mouse", |ui| {
                    for line in KEY_HELP {
                        ui.label(*line);
                    }
                });
                if let Some(note) = note {
                    ui.separator();
                    ui.label(note);
                }
            });
        });
    PanelOutput {
        actions,
        width: response.response.rect.max.x,
    }
}

/// Play, pause, step, restart, time scale, and the timeline of a playback.
fn transport(ui: &mut egui::Ui, session: &Session, actions: &mut Vec<Action>) {
    ui.horizontal(|ui| {
        let (label, action) = if session.is_playing() {
            ("Pause", Action::Pause)
        } else {
            ("Play", Action::Play)
        };
        if ui.button(label).clicked() {
            actions.push(action);
        }
        if ui.button("Step").clicked() {
            actions.push(Action::Step);
        }
        if ui.button("Restart").clicked() {
            actions.push(Action::Restart);
        }
    });
    let mut scale = session.clock().time_scale();
    let slider = egui::Slider::new(&mut scale, 0.01..=4.0)
        .logarithmic(true)
        .text("× real time");
    if ui.add(slider).changed() {
        actions.push(Action::SetTimeScale(scale));
    }
    if let Some(end) = session.timeline_end() {
        let mut t = session.time();
        let scrubber = egui::Slider::new(&mut t, 0.0..=end)
            .text("s")
            .max_decimals(3);
        if ui.add(scrubber).changed() {
            actions.push(Action::Seek(t));
        }
    }
}

/// The live figures, and any warning or failure.
fn figures(ui: &mut egui::Ui, session: &Session) {
    let figures = session.figures();
    let backend = match session.content() {
        Content::Live(_) if session.on_gpu() => "live on the GPU",
        Content::Live(_) => "live on the CPU",
        Content::Playback(_) => "playback of a run",
    };
    egui::Grid::new("figures").num_columns(2).show(ui, |ui| {
        let mut row = |name: &str, value: String| {
            ui.label(name);
            ui.label(value);
            ui.end_row();
        };
        row("shows", backend.to_string());
        row("display", format!("{:.1} FPS", figures.fps));
        row("substeps", format!("{:.0} /s", figures.substeps_per_second));
        row("sim time", format!("{:.4} s", session.time()));
        row("particles", session.particle_count().to_string());
    });
    let clock = session.clock();
    let live = matches!(session.content(), Content::Live(_)) && session.is_playing();
    if let Some(factor) = clock
        .real_time_factor()
        .filter(|_| live && clock.is_behind())
    {
        ui.colored_label(
            egui::Color32::from_rgb(240, 180, 60),
            format!(
                "the simulation cannot keep up: it runs at {factor:.2}× the requested speed; \
                 lower the time scale for smooth motion"
            ),
        );
    }
    if let Some(failure) = session.failure() {
        ui.colored_label(egui::Color32::from_rgb(240, 90, 80), failure);
    }
    if let Some(rejected) = session.rejected() {
        ui.colored_label(egui::Color32::from_rgb(240, 180, 60), rejected);
    }
}

/// Render mode, colour quantity and camera.
fn look(
    ui: &mut egui::Ui,
    session: &Session,
    toggles: &mut ViewToggles,
    actions: &mut Vec<Action>,
) {
    ui.label("render mode");
    ui.horizontal(|ui| {
        let mut style = session.style();
        for (value, name) in [
            (DrawStyle::Points, "points"),
            (DrawStyle::Billboards, "billboards"),
            (DrawStyle::Trails, "trails"),
        ] {
            ui.selectable_value(&mut style, value, name);
        }
        if style != session.style() {
            actions.push(Action::SetStyle(style));
        }
    });
    let mut color_by = session.color_by();
    egui::ComboBox::from_label("colour by")
        .selected_text(color_name(color_by))
        .show_ui(ui, |ui| {
            for value in [
                ColorBy::Density,
                ColorBy::PlasticJ,
                ColorBy::Speed,
                ColorBy::Position,
                ColorBy::Uniform,
            ] {
                ui.selectable_value(&mut color_by, value, color_name(value));
            }
        });
    if color_by != session.color_by() {
        actions.push(Action::SetColorBy(color_by));
    }
    ui.horizontal(|ui| {
        ui.checkbox(&mut toggles.scene_camera, "scene camera");
        toggles.frame_all |= ui.button("Frame all").clicked();
        toggles.screenshot |= ui.button("Screenshot").clicked();
    });
}

/// The panel's name of a colour quantity.
fn color_name(color_by: ColorBy) -> &'static str {
    match color_by {
        ColorBy::Density => "density",
        ColorBy::PlasticJ => "plastic J",
        ColorBy::Speed => "speed",
        ColorBy::Position => "position",
        ColorBy::Uniform => "uniform",
    }
}

/// The material or flow parameters of a live scene.
fn parameters(ui: &mut egui::Ui, session: &Session, actions: &mut Vec<Action>) {
    if !matches!(session.content(), Content::Live(_)) {
        ui.label("parameters are those of the recorded run");
        return;
    }
    match &session.scene().kind {
        SceneKind::Snow => {
            let mut materials = session.scene().materials.clone();
            if materials
                .iter_mut()
                .any(|material| material_editor(ui, material))
            {
                actions.push(Action::SetMaterials(materials));
            }
            if let Some(wind) = &session.scene().wind {
                let mut edited = wind.clone();
                let domain = &session.scene().domain;
                let largest_radius = 0.5 * (domain.max - domain.min).min_element();
                if wind_editor(ui, &mut edited, largest_radius) {
                    actions.push(Action::SetWind(Box::new(edited)));
                }
            }
        }
        SceneKind::Flow(settings) => {
            let mut edited = (**settings).clone();
            let domain = &session.scene().domain;
            let largest_radius = 0.5 * (domain.max - domain.min).min_element();
            if flow_editor(ui, &mut edited, largest_radius) {
                actions.push(Action::SetFlow(Box::new(edited)));
            }
        }
    }
}

/// Sliders for one material (thesis eq. 34-43); true when one moved.
fn material_editor(ui: &mut egui::Ui, material: &mut Material) -> bool {
    ui.label(format!("material \"{}\"", material.name));
    let sliders = [
        egui::Slider::new(&mut material.youngs_modulus, 1.0e3..=1.0e7)
            .logarithmic(true)
            .text("E (Pa)"),
        egui::Slider::new(&mut material.poisson_ratio, 0.0..=0.45).text("ν"),
        egui::Slider::new(&mut material.hardening, 0.0..=30.0).text("ξ"),
        egui::Slider::new(&mut material.critical_compression, 1.0e-3..=0.1)
            .logarithmic(true)
            .text("θc"),
        egui::Slider::new(&mut material.critical_stretch, 1.0e-4..=0.05)
            .logarithmic(true)
            .text("θs"),
    ];
    sliders
        .into_iter()
        .fold(false, |changed, slider| ui.add(slider).changed() | changed)
}

/// Controls for the wind over the snow: its drag (`[wind]`, equations W1
/// to W3), its speed and its field; true when one moved.
fn wind_editor(ui: &mut egui::Ui, wind: &mut Wind, largest_radius: f32) -> bool {
    ui.label("wind");
    let mut changed = false;
    changed |= ui
        .add(
            egui::Slider::new(&mut wind.drag, 0.0..=200.0)
                .logarithmic(true)
                .text("c_d (kg/m² s)"),
        )
        .changed();
    changed |= ui
        .add(
            egui::Slider::new(&mut wind.packed_density, 50.0..=1000.0)
                .logarithmic(true)
                .text("ρ packed (kg/m³)"),
        )
        .changed();
    changed |= ui
        .add(
            egui::Slider::new(&mut wind.field.background_strength, 0.0..=100.0)
                .text("M_f (background)"),
        )
        .changed();
    flow_editor(ui, &mut wind.field, largest_radius) | changed
}

/// Controls for the flow (seed 002 eq. 1-4), obstacle radii up to
/// `largest_radius`; true when one moved.
fn flow_editor(ui: &mut egui::Ui, settings: &mut FlowSettings, largest_radius: f32) -> bool {
    ui.label("curl-noise flow");
    let mut changed = false;
    changed |= ui
        .add(egui::Slider::new(&mut settings.noise_share, 0.0..=1.0).text("γ (noise share)"))
        .changed();
    changed |= ui
        .add(
            egui::Slider::new(&mut settings.noise_strength, 0.01..=100.0)
                .logarithmic(true)
                .text("M (noise strength)"),
        )
        .changed();
    changed |= ui
        .add(
            egui::Slider::new(&mut settings.length_scale, 0.01..=100.0)
                .logarithmic(true)
                .text("L (m)"),
        )
        .changed();
    ui.label("background direction");
    let direction = &mut settings.background_direction;
    let before = *direction;
    ui.horizontal(|ui| {
        for value in [&mut direction.x, &mut direction.y, &mut direction.z] {
            ui.add(egui::DragValue::new(value).speed(0.02).range(-1.0..=1.0));
        }
    });
    if *direction != before {
        if direction.length() > 1e-3 {
            *direction = direction.normalize();
            changed = true;
        } else {
            *direction = before;
        }
    }
    for (index, obstacle) in settings.obstacles.iter_mut().enumerate() {
        let smallest = 0.01 * largest_radius;
        changed |= ui
            .add(
                egui::Slider::new(&mut obstacle.radius, smallest..=largest_radius)
                    .text(format!("obstacle {} (m)", index + 1)),
            )
            .changed();
    }
    changed
}
