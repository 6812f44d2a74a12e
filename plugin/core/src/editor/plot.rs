//! A minimal plot on an egui painter: linear or log axes, decade grid, lines, dots and bars.

use egui::{self, Align2, Color32, FontId, Pos2, Rect, Sense, Stroke, Ui, Vec2};

/// One axis: the value range and whether it is logarithmic.
#[derive(Clone, Copy, Debug)]
pub struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub log: bool,
}

impl Axis {
    pub fn log(lo: f64, hi: f64) -> Self {
        Axis { lo, hi, log: true }
    }
    pub fn lin(lo: f64, hi: f64) -> Self {
        Axis { lo, hi, log: false }
    }
    /// 0..1 along the axis (outside for values out of range; NaN for non-positive on log).
    pub fn frac(&self, v: f64) -> f64 {
        if self.log {
            if v <= 0.0 {
                return f64::NAN;
            }
            (v.ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }
    /// Grid values: decades (log) or 5 divisions (linear).
    fn ticks(&self) -> Vec<f64> {
        if self.log {
            let (a, b) = (self.lo.log10().floor() as i32, self.hi.log10().ceil() as i32);
            (a..=b).map(|k| 10f64.powi(k)).filter(|v| *v >= self.lo * 0.999 && *v <= self.hi * 1.001).collect()
        } else {
            (0..=4).map(|i| self.lo + (self.hi - self.lo) * f64::from(i) / 4.0).collect()
        }
    }
}

/// Short label: 20, 1k, 10k, 0.01, 1e-5.
pub fn fmt_value(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e6).contains(&a) {
        format!("{v:.0e}")
    } else if a >= 1000.0 {
        format!("{}k", v / 1000.0)
    } else if a >= 1.0 {
        format!("{}", (v * 100.0).round() / 100.0)
    } else {
        format!("{}", (v * 1000.0).round() / 1000.0)
    }
}

/// A plot area with its axes.
pub struct Plot {
    pub rect: Rect,
    pub x: Axis,
    pub y: Axis,
}

impl Plot {
    /// Allocates a plot of `height` points across the available width, draws the frame, grid
    /// and labels, and returns it with the response (hover). `label` names it for screen
    /// readers and tests.
    pub fn show(
        ui: &mut Ui,
        height: f32,
        x: Axis,
        y: Axis,
        x_label: &str,
        y_label: &str,
        label: &str,
    ) -> (Plot, egui::Response, egui::Painter) {
        let width = ui.available_width().max(120.0);
        let (outer, response) = ui.allocate_exact_size(Vec2::new(width, height), Sense::hover());
        let response = response.accessible_name(label);
        let painter = ui.painter_at(outer);
        let rect = Rect::from_min_max(outer.min + Vec2::new(44.0, 8.0), outer.max - Vec2::new(8.0, 30.0));
        let plot = Plot { rect, x, y };
        let visuals = ui.visuals();
        painter.rect_filled(rect, 2.0, visuals.extreme_bg_color);
        let grid = Stroke::new(1.0, visuals.weak_text_color().gamma_multiply(0.35));
        let text = visuals.weak_text_color();
        let font = FontId::proportional(10.0);
        for v in x.ticks() {
            let px = plot.px(v);
            painter.line_segment([Pos2::new(px, rect.top()), Pos2::new(px, rect.bottom())], grid);
            painter.text(Pos2::new(px, rect.bottom() + 2.0), Align2::CENTER_TOP, fmt_value(v), font.clone(), text);
        }
        for v in y.ticks() {
            let py = plot.py(v);
            painter.line_segment([Pos2::new(rect.left(), py), Pos2::new(rect.right(), py)], grid);
            painter.text(Pos2::new(rect.left() - 3.0, py), Align2::RIGHT_CENTER, fmt_value(v), font.clone(), text);
        }
        painter.text(Pos2::new(rect.center().x, rect.bottom() + 14.0), Align2::CENTER_TOP, x_label, font.clone(), text);
        painter.text(rect.left_top() + Vec2::new(4.0, 2.0), Align2::LEFT_TOP, y_label, font, text);
        (plot, response, painter)
    }

    pub fn px(&self, x: f64) -> f32 {
        self.rect.left() + self.rect.width() * self.x.frac(x) as f32
    }
    pub fn py(&self, y: f64) -> f32 {
        self.rect.bottom() - self.rect.height() * self.y.frac(y) as f32
    }
    pub fn pos(&self, x: f64, y: f64) -> Option<Pos2> {
        let p = Pos2::new(self.px(x), self.py(y));
        (p.x.is_finite() && p.y.is_finite()).then_some(p)
    }
    fn inside(&self, p: Pos2) -> bool {
        self.rect.expand(0.5).contains(p)
    }

    /// A polyline through the points inside the plot (broken where points fall outside).
    pub fn line(&self, painter: &egui::Painter, pts: &[(f64, f64)], stroke: Stroke) {
        let mut run: Vec<Pos2> = Vec::new();
        for &(x, y) in pts {
            match self.pos(x, y.clamp(self.y.lo.min(self.y.hi), self.y.lo.max(self.y.hi))) {
                Some(p) if self.inside(p) => run.push(p),
                _ => {
                    if run.len() > 1 {
                        painter.add(egui::Shape::line(std::mem::take(&mut run), stroke));
                    }
                    run.clear();
                }
            }
        }
        if run.len() > 1 {
            painter.add(egui::Shape::line(run, stroke));
        }
    }

    /// A dot, if inside the plot.
    pub fn dot(&self, painter: &egui::Painter, x: f64, y: f64, r: f32, color: Color32) {
        if let Some(p) = self.pos(x, y).filter(|p| self.inside(*p)) {
            painter.circle_filled(p, r, color);
        }
    }

    /// A vertical bar from the bottom to `y`, if `x` is inside the plot.
    pub fn bar(&self, painter: &egui::Painter, x: f64, y: f64, stroke: Stroke) {
        let px = self.px(x);
        if !(px >= self.rect.left() && px <= self.rect.right()) {
            return;
        }
        let top = self.py(y).clamp(self.rect.top(), self.rect.bottom());
        painter.line_segment([Pos2::new(px, self.rect.bottom()), Pos2::new(px, top)], stroke);
    }
}

/// A colour per series index (impacts in the scatter), evenly spread in hue.
pub fn series_color(i: usize, n: usize) -> Color32 {
    let h = (i as f32 * 0.618_034).fract();
    let _ = n;
    egui::ecolor::Hsva::new(h, 0.65, 0.95, 1.0).into()
}
