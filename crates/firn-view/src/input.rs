//! Mouse and keyboard: the camera and the viewer's keys.
//!
//! | input | does |
//! |---|---|
//! | left drag | orbit |
//! | right or middle drag, shift + left drag | pan |
//! | wheel, `+` / `-` | zoom |
//! | arrow keys (held) | orbit |
//! | `F` | frame all |
//! | `C` | follow the scene's camera (path, orbit or fixed eye) |
//! | space | play / pause |
//! | `.` or `N` | single step |
//! | `R` | restart |
//! | `1` `2` `3` | points, billboards, trails |
//! | `P` or F12 | screenshot (PNG in the working directory) |
//! | `T` | throw a stone ball along the view into the snow (live, CPU) |

use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::keyboard::{Key, NamedKey};

use crate::camera::OrbitCamera;
use crate::draw::DrawStyle;
use crate::session::Action;

/// Zoom steps per line of wheel scrolling.
const ZOOM_STEPS_PER_LINE: f32 = 1.0;
/// Pixels of touchpad scrolling per zoom step.
const PIXELS_PER_ZOOM_STEP: f32 = 40.0;

/// What a key asks the viewer to do.
#[derive(Clone, Debug, PartialEq)]
pub enum KeyCommand {
    /// Something for the session.
    Session(Action),
    /// Play if paused, pause if playing.
    TogglePlay,
    /// Frame the whole domain.
    FrameAll,
    /// Follow the scene's camera, or stop following it.
    ToggleSceneCamera,
    /// The user moved the camera: stop following the scene's.
    ManualCamera,
    /// Write a screenshot.
    Screenshot,
    /// Throw a rigid ball along the view.
    Throw,
}

/// The mouse buttons and keys held.
#[derive(Clone, Copy, Debug, Default)]
pub struct Input {
    cursor: Option<(f32, f32)>,
    orbiting: bool,
    panning: bool,
    shift: bool,
    /// Arrow keys held: yaw (left −, right +) and pitch (down −, up +).
    yaw_keys: f32,
    pitch_keys: f32,
}

impl Input {
    /// Handles a window event not taken by the panel; moves `camera` (in a
    /// view `height` pixels tall) or returns a command. `panel_has_pointer`:
    /// the pointer is over the panel, so clicks and the wheel are its.
    pub fn handle(
        &mut self,
        event: &WindowEvent,
        camera: &mut OrbitCamera,
        height: f32,
        panel_has_pointer: bool,
    ) -> Option<KeyCommand> {
        match event {
            WindowEvent::ModifiersChanged(modifiers) => {
                self.shift = modifiers.state().shift_key();
                None
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let pressed = *state == ElementState::Pressed && !panel_has_pointer;
                match button {
                    MouseButton::Left if self.shift => self.panning = pressed,
                    MouseButton::Left => self.orbiting = pressed,
                    MouseButton::Right | MouseButton::Middle => self.panning = pressed,
                    _ => {}
                }
                None
            }
            WindowEvent::CursorMoved { position, .. } => {
                let now = (position.x as f32, position.y as f32);
                let moved = self.cursor.map(|(x, y)| (now.0 - x, now.1 - y));
                self.cursor = Some(now);
                let (dx, dy) = moved?;
                if self.orbiting {
                    camera.orbit_by_pixels(dx, dy);
                } else if self.panning {
                    camera.pan_by_pixels(dx, dy, height);
                } else {
                    return None;
                }
                Some(KeyCommand::ManualCamera)
            }
            WindowEvent::MouseWheel { delta, .. } if !panel_has_pointer => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, lines) => lines * ZOOM_STEPS_PER_LINE,
                    MouseScrollDelta::PixelDelta(pixels) => pixels.y as f32 / PIXELS_PER_ZOOM_STEP,
                };
                camera.zoom(steps);
                Some(KeyCommand::ManualCamera)
            }
            WindowEvent::KeyboardInput { event, .. } => {
                let pressed = event.state == ElementState::Pressed;
                self.track_arrows(&event.logical_key, pressed);
                if pressed && !event.repeat {
                    self.key_command(&event.logical_key, camera)
                } else {
                    None
                }
            }
            _ => None,
        }
    }

    /// Orbits for the arrow keys held over `seconds`.
    pub fn hold_keys(&self, camera: &mut OrbitCamera, seconds: f32) {
        if self.yaw_keys != 0.0 || self.pitch_keys != 0.0 {
            camera.orbit_by_keys(self.yaw_keys, self.pitch_keys, seconds);
        }
    }

    fn track_arrows(&mut self, key: &Key, pressed: bool) {
        let value = if pressed { 1.0 } else { 0.0 };
        match key {
            Key::Named(NamedKey::ArrowLeft) => self.yaw_keys = -value,
            Key::Named(NamedKey::ArrowRight) => self.yaw_keys = value,
            Key::Named(NamedKey::ArrowUp) => self.pitch_keys = value,
            Key::Named(NamedKey::ArrowDown) => self.pitch_keys = -value,
            _ => {}
        }
    }

    fn key_command(&self, key: &Key, camera: &mut OrbitCamera) -> Option<KeyCommand> {
        match key {
            Key::Named(NamedKey::Space) => Some(KeyCommand::TogglePlay),
            Key::Named(NamedKey::F12) => Some(KeyCommand::Screenshot),
            Key::Named(
                NamedKey::ArrowLeft
                | NamedKey::ArrowRight
                | NamedKey::ArrowUp
                | NamedKey::ArrowDown,
            ) => Some(KeyCommand::ManualCamera),
            Key::Character(text) => self.character_command(text.as_str(), camera),
            _ => None,
        }
    }

    fn character_command(&self, text: &str, camera: &mut OrbitCamera) -> Option<KeyCommand> {
        let session = |action| Some(KeyCommand::Session(action));
        match text.to_ascii_lowercase().as_str() {
            "f" => Some(KeyCommand::FrameAll),
            "c" => Some(KeyCommand::ToggleSceneCamera),
            "p" => Some(KeyCommand::Screenshot),
            "t" => Some(KeyCommand::Throw),
            "." | "n" => session(Action::Step),
            "r" => session(Action::Restart),
            "1" => session(Action::SetStyle(DrawStyle::Points)),
            "2" => session(Action::SetStyle(DrawStyle::Billboards)),
            "3" => session(Action::SetStyle(DrawStyle::Trails)),
            "+" | "=" => {
                camera.zoom(1.0);
                Some(KeyCommand::ManualCamera)
            }
            "-" => {
                camera.zoom(-1.0);
                Some(KeyCommand::ManualCamera)
            }
            _ => None,
        }
    }
}
