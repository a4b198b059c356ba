//! The mouse as navigation sees it: which buttons are down and where the cursor was, turned
//! into orbit (left drag), pan (right drag) and zoom (wheel). The window's events and the
//! script's `drag` and `wheel` actions go through the same calls.

use super::navigation::Navigation;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Button {
    /// Orbit.
    Left,
    /// Pan.
    Right,
}

#[derive(Clone, Debug, Default)]
pub struct Pointer {
    cursor: Option<(f64, f64)>,
    left: bool,
    right: bool,
}

impl Pointer {
    pub fn button(&mut self, button: Button, down: bool) {
        match button {
            Button::Left => self.left = down,
            Button::Right => self.right = down,
        }
    }

    /// The cursor moved to (x, y), window pixels (`height`: the window's).
    pub fn moved(&mut self, x: f64, y: f64, navigation: &mut Navigation, height: u32) {
        if let Some((x0, y0)) = self.cursor {
            let (dx, dy) = (x - x0, y - y0);
            if self.left {
                navigation.rotate(dx, dy);
            } else if self.right {
                navigation.pan_by(dx, dy, height);
            }
        }
        self.cursor = Some((x, y));
    }

    /// Where the cursor is, window pixels (`None` outside the window).
    pub fn cursor(&self) -> Option<(f64, f64)> {
        self.cursor
    }

    /// The cursor left the window.
    pub fn left_window(&mut self) {
        self.cursor = None;
    }

    /// A drag from (x0, y0) to (x1, y1) in `steps` moves, as a user's.
    pub fn drag(
        &mut self,
        button: Button,
        [x0, y0, x1, y1]: [f64; 4],
        steps: u32,
        navigation: &mut Navigation,
        height: u32,
    ) {
        self.moved(x0, y0, navigation, height);
        self.button(button, true);
        for i in 1..=steps.max(1) {
            let t = i as f64 / steps.max(1) as f64;
            self.moved(x0 + t * (x1 - x0), y0 + t * (y1 - y0), navigation, height);
        }
        self.button(button, false);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drags_orbit_and_pan_only_while_a_button_is_down() {
        let mut nav = Navigation::new(
            [-1.0; 3],
            [1.0; 3],
            [0.0, 1.0, 0.0],
            60.0,
            [30.0, 20.0, 2.5],
        );
        let mut p = Pointer::default();
        p.moved(10.0, 10.0, &mut nav, 480);
        p.moved(100.0, 50.0, &mut nav, 480);
        assert_eq!((nav.orbit, nav.pan), ([30.0, 20.0, 2.5], [0.0; 3]));
        p.drag(Button::Left, [0.0, 0.0, 100.0, 0.0], 4, &mut nav, 480);
        assert!((nav.orbit[0] - 0.0).abs() < 1e-9, "{:?}", nav.orbit); // 100 px × 0.3°
        p.drag(Button::Right, [0.0, 0.0, 100.0, 0.0], 4, &mut nav, 480);
        assert_ne!(nav.pan, [0.0; 3]);
        let pan = nav.pan;
        p.moved(300.0, 300.0, &mut nav, 480);
        assert_eq!(nav.pan, pan, "released");
    }
}
