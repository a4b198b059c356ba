//! Mouse and keyboard events from the window, not taken by the overlay, to navigation and
//! the actions (the script's mouse actions take the same paths).

use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::keyboard::Key;

use super::app::App;
use super::pointer::Button;

impl App {
    /// Mouse and keyboard not taken by the overlay.
    pub(super) fn input(&mut self, event: &WindowEvent) {
        let height = self.window_size().1;
        match event {
            WindowEvent::MouseInput { state, button, .. } => {
                let down = *state == ElementState::Pressed;
                match button {
                    MouseButton::Left => {
                        self.pointer.button(Button::Left, down);
                        if down {
                            self.left_pressed();
                        }
                    }
                    MouseButton::Right => self.pointer.button(Button::Right, down),
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                self.pointer
                    .moved(position.x, position.y, &mut self.navigation, height)
            }
            WindowEvent::CursorLeft { .. } => self.pointer.left_window(),
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => *y as f64,
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.wheel_at(self.pointer.cursor(), lines);
            }
            WindowEvent::KeyboardInput { event, .. } => {
                if let Key::Character(s) = &event.logical_key {
                    if let Some(c) = s.chars().next().map(|c| c.to_ascii_lowercase()) {
                        match event.state {
                            ElementState::Pressed if !event.repeat => self.key(c),
                            ElementState::Pressed => {}
                            ElementState::Released => self.key_released(c),
                        }
                    }
                }
            }
            _ => {}
        }
    }
}
