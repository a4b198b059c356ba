//! The overlay's frame-time graph: the last `HISTORY` frames' wall-clock, GPU and CPU
//! milliseconds as three lines over a common scale (the window's largest value, shown).

use std::collections::VecDeque;

/// Frames the graph shows.
pub const HISTORY: usize = 180;

/// One frame's times, milliseconds.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameTimes {
    /// Between this frame and the one before (what the user sees).
    pub frame: f64,
    /// The GPU's traversal and draws, where the adapter has timestamps.
    pub gpu: Option<f64>,
    /// The CPU in the streaming renderer's frame: streaming bookkeeping, recording, submit
    /// (not waiting for the GPU).
    pub cpu: f64,
}

/// The last `HISTORY` frames, oldest first.
#[derive(Clone, Debug, Default)]
pub struct History(pub VecDeque<FrameTimes>);

impl History {
    pub fn push(&mut self, t: FrameTimes) {
        if self.0.len() == HISTORY {
            self.0.pop_front();
        }
        self.0.push_back(t);
    }

    /// The graph, `size` points wide and high, with its legend.
    pub fn ui(&self, ui: &mut egui::Ui, size: egui::Vec2) {
        let top = self
            .0
            .iter()
            .flat_map(|t| [t.frame, t.gpu.unwrap_or(0.0), t.cpu])
            .fold(1.0f64, f64::max);
        let (response, painter) = ui.allocate_painter(size, egui::Sense::hover());
        let rect = response.rect;
        painter.rect_filled(rect, 2.0, egui::Color32::from_black_alpha(120));
        let point = |i: usize, ms: f64| {
            let x = rect.left() + rect.width() * i as f32 / (HISTORY - 1) as f32;
            let y = rect.bottom() - rect.height() * (ms / top) as f32;
            egui::pos2(x, y)
        };
        let colours = [
            egui::Color32::from_rgb(230, 230, 230),
            egui::Color32::from_rgb(120, 220, 120),
            egui::Color32::from_rgb(240, 170, 80),
        ];
        let series: [fn(&FrameTimes) -> Option<f64>; 3] =
            [|t| Some(t.frame), |t| t.gpu, |t| Some(t.cpu)];
        let first = HISTORY - self.0.len();
        for (get, colour) in series.iter().zip(colours) {
            let line: Vec<egui::Pos2> = (self.0.iter().enumerate())
                .filter_map(|(i, t)| Some(point(first + i, get(t)?)))
                .collect();
            if line.len() > 1 {
                painter.add(egui::Shape::line(line, egui::Stroke::new(1.0, colour)));
            }
        }
        ui.horizontal(|ui| {
            for (name, colour) in ["frame", "GPU", "CPU"].into_iter().zip(colours) {
                ui.colored_label(colour, name);
            }
            ui.label(format!("ms (top {top:.1})"));
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_history_keeps_the_last_frames() {
        let mut h = History::default();
        for i in 0..HISTORY + 10 {
            h.push(FrameTimes {
                frame: i as f64,
                ..Default::default()
            });
        }
        assert_eq!(h.0.len(), HISTORY);
        assert_eq!(h.0.front().unwrap().frame, 10.0);
    }
}
