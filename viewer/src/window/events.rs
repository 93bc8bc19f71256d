//! Input mapping: winit's events become [`Input`]s (as a script's commands do),
//! and each input becomes what it does — the mouse orbits, pans or edits guides,
//! the keys run the viewer's commands.

use super::App;
use crate::guided::worker::Preempt;
use crate::input::{Button, Input, Key, Modifiers};
use glam::DVec2;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::ActiveEventLoop;
use winit::keyboard::{Key as WinitKey, NamedKey};

/// The window's input from a winit event, if it is one the window handles.
pub(super) fn input_of(event: &WindowEvent) -> Option<Input> {
    Some(match event {
        WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
            Input::Key(key_of(&event.logical_key)?)
        }
        WindowEvent::ModifiersChanged(m) => {
            Input::Modifiers(Modifiers { shift: m.state().shift_key(), ctrl: m.state().control_key() })
        }
        WindowEvent::MouseInput { state, button, .. } => Input::Button {
            button: match button {
                MouseButton::Left => Button::Left,
                MouseButton::Right => Button::Right,
                MouseButton::Middle => Button::Middle,
                _ => return None,
            },
            pressed: *state == ElementState::Pressed,
        },
        WindowEvent::CursorMoved { position, .. } => Input::CursorMoved(position.x, position.y),
        WindowEvent::MouseWheel { delta, .. } => Input::Wheel(match delta {
            MouseScrollDelta::LineDelta(_, y) => *y,
            MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
        }),
        _ => return None,
    })
}

/// The window's name for a winit key.
pub(super) fn key_of(key: &WinitKey) -> Option<Key> {
    Some(match key {
        WinitKey::Named(NamedKey::Escape) => Key::Escape,
        WinitKey::Named(NamedKey::Tab) => Key::Tab,
        WinitKey::Named(NamedKey::Delete) => Key::Delete,
        WinitKey::Named(NamedKey::Backspace) => Key::Backspace,
        WinitKey::Named(NamedKey::Home) => Key::Home,
        WinitKey::Named(NamedKey::ArrowLeft) => Key::ArrowLeft,
        WinitKey::Named(NamedKey::ArrowRight) => Key::ArrowRight,
        WinitKey::Named(NamedKey::ArrowUp) => Key::ArrowUp,
        WinitKey::Named(NamedKey::ArrowDown) => Key::ArrowDown,
        WinitKey::Named(NamedKey::PageUp) => Key::PageUp,
        WinitKey::Named(NamedKey::PageDown) => Key::PageDown,
        WinitKey::Named(NamedKey::Space) => Key::Char(" ".into()),
        WinitKey::Character(c) => Key::Char(c.to_string()),
        _ => return None,
    })
}

impl App {
    /// Every input, from winit or from the script.
    pub(super) fn input(&mut self, event_loop: &ActiveEventLoop, input: Input) {
        match input {
            Input::Modifiers(m) => self.modifiers = m,
            Input::Key(k) => self.key(event_loop, &k),
            Input::Wheel(lines) => self.zoom(0.9f32.powf(lines)),
            Input::Button { button, pressed } => self.button(button, pressed),
            Input::CursorMoved(x, y) => self.cursor_moved(x, y),
        }
    }

    pub(super) fn button(&mut self, button: Button, pressed: bool) {
        if !pressed {
            if button == Button::Left {
                self.guided_release();
            }
            self.mouse.orbit = false;
            self.mouse.pan = false;
            return;
        }
        match button {
            Button::Left if self.modifiers.shift => self.mouse.pan = true,
            Button::Left => {
                if !self.guided_press() {
                    self.mouse.orbit = true;
                }
            }
            Button::Right | Button::Middle => self.mouse.pan = true,
        }
    }

    pub(super) fn cursor_moved(&mut self, x: f64, y: f64) {
        let previous = self.mouse.pos.replace((x, y));
        if self.guided.as_ref().is_some_and(|s| s.editor.is_dragging() || s.editor.is_drawing()) {
            let Some(view) = self.screen_view() else { return };
            let Some(s) = &mut self.guided else { return };
            let px = DVec2::new(x, y);
            if s.editor.is_dragging() {
                if s.editor.drag_to(&view, px) {
                    // A search per move; one running is let finish (Preempt::Wait), so
                    // models keep coming while the point moves.
                    s.request(Preempt::Wait);
                    self.scene_changed();
                }
            } else if s.editor.extend_stroke(&view, px) {
                self.scene_changed();
            }
            return;
        }
        let Some((px, py)) = previous else { return };
        let h = self.gpu.as_ref().map(|g| g.swapchain.extent.height.max(1) as f64).unwrap_or(1.0);
        let (dx, dy) = (((x - px) / h) as f32, ((y - py) / h) as f32);
        if self.mouse.orbit {
            self.orbit(dx * std::f32::consts::PI, dy * std::f32::consts::PI);
        } else if self.mouse.pan {
            if let Some(c) = &mut self.camera {
                c.pan(dx, dy);
                self.redraw();
            }
        }
    }

    pub(super) fn key(&mut self, event_loop: &ActiveEventLoop, key: &Key) {
        if self.guided_key(key) {
            return;
        }
        let step = 10f32.to_radians();
        match key {
            Key::Escape => event_loop.exit(),
            Key::ArrowLeft => self.orbit(-step, 0.0),
            Key::ArrowRight => self.orbit(step, 0.0),
            Key::ArrowUp => self.orbit(0.0, step),
            Key::ArrowDown => self.orbit(0.0, -step),
            Key::Home => self.frame_model(true),
            Key::Char(c) => match c.to_lowercase().as_str() {
                "q" => event_loop.exit(),
                "f" => self.frame_model(false),
                "h" => self.frame_model(true),
                "w" => {
                    let supported = self.gpu.as_ref().is_some_and(|g| g.ctx.wireframe);
                    if supported {
                        self.wireframe = !self.wireframe;
                        self.redraw();
                    } else {
                        (self.opts.log)("mdg-view: this device cannot draw wireframes (no fillModeNonSolid)");
                    }
                }
                "+" | "=" => self.zoom(0.9),
                "-" | "_" => self.zoom(1.0 / 0.9),
                "c" => {
                    let has = self.gpu.as_ref().and_then(|g| g.renderer.info()).is_some_and(|i| i.has_camera_rule);
                    if has {
                        self.camera_rule = !self.camera_rule;
                        self.redraw();
                    }
                }
                "g" => {
                    if let Some(g) = &mut self.gpu {
                        g.renderer.show_overlays = !g.renderer.show_overlays;
                        self.redraw();
                    }
                }
                "p" => self.select_param(),
                "[" => self.change_param(-1.0),
                "]" => self.change_param(1.0),
                "{" => self.change_param(-10.0),
                "}" => self.change_param(10.0),
                "," | "<" => self.step(-1.0),
                "." | ">" => self.step(1.0),
                " " => {
                    self.playing = !self.playing;
                    self.last_tick = None;
                    self.redraw();
                }
                _ => {}
            },
            _ => {}
        }
    }
}
