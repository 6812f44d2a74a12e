//! Object view: the object drawn with its strike path (see `drawing`); click or drag to
//! strike there, right-click to hold the object there (its support). Below, the mode gains at
//! the current strike position.

use super::drawing;
use super::logic::{self, F_MAX_HZ, F_MIN_HZ};
use super::panel::{set_param, PanelCtx};
use super::plot::{Axis, Plot};
use crate::params::SupportMode;
use crate::shared::{Audition, EditorShared};
use egui::{self, Color32, Pos2, Rect, Sense, Stroke, Vec2};
use std::sync::Arc;

/// Object view state: the velocity and key of its strikes, the click or drag in progress and
/// the cached picture of the object.
pub(super) struct ObjectPanel {
    /// Velocity of strikes from the object view, 0..=1.
    pub velocity: f32,
    /// Key whose tuning object-view strikes use.
    pub key: u8,
    /// Serial number of the last audition sent.
    serial: u32,
    /// Strike point under the pointer while a click or drag on the view lasts.
    gesture: Option<usize>,
    /// The picture of the selected bank (rebuilt when the object changes).
    drawing: Option<Arc<drawing::ObjectDrawing>>,
}

impl Default for ObjectPanel {
    fn default() -> Self {
        ObjectPanel { velocity: 0.8, key: 60, serial: 0, gesture: None, drawing: None }
    }
}

impl ObjectPanel {
    /// Whether a click or drag on the view is in progress (the editor repaints every frame then).
    pub fn is_active(&self) -> bool {
        self.gesture.is_some()
    }

    /// Queues a strike at `position` for the audio thread.
    fn audition(&mut self, shared: &EditorShared, position: f32) {
        self.serial = self.serial.wrapping_add(1);
        let a =
            Audition { key: self.key.min(127), velocity: self.velocity.clamp(0.0, 1.0), position, serial: self.serial };
        let _ = shared.audition(a);
    }

    /// Draws the panel: object choice, audition controls, the object view, the mode gains.
    pub fn show(&mut self, ui: &mut egui::Ui, cx: &PanelCtx) {
        ui.heading("Object");
        let lib = cx.library.clone();
        let Some(obj) = logic::object_index(cx.params, &lib) else {
            ui.label("No objects in the library.");
            return;
        };
        let bank = &lib.banks[obj];
        object_choice(ui, cx, obj);
        ui.horizontal(|ui| {
            ui.add(egui::Slider::new(&mut self.velocity, 0.05..=1.0).text("Velocity"));
            ui.add(egui::DragValue::new(&mut self.key).range(0..=127).prefix("Key "));
        });
        // The picture: the object's surface seen from a fixed camera, the strike path on it
        // (see `drawing`); cached per bank.
        if self.drawing.as_ref().is_none_or(|d| d.bank_id != bank.id || d.points.len() != bank.points.len()) {
            self.drawing = Some(Arc::new(drawing::object_drawing(bank)));
        }
        let Some(pic) = self.drawing.clone() else { return };
        let width = ui.available_width();
        let aspect = pic.size[1] / pic.size[0].max(1e-3);
        let height = ((width - 24.0) * aspect + 40.0).clamp(110.0, 280.0);
        let (rect, response) = ui.allocate_exact_size(Vec2::new(width, height), Sense::click_and_drag());
        let response = response.accessible_name("Object view");
        let view = View::new(&pic, rect);
        self.interact(&response, &view, cx);
        paint_view(ui, &response, &view, bank, cx);
        ui.add_space(6.0);
        self.mode_gains(ui, cx, bank);
    }

    /// Press (or drag onto) a point → one gesture on the strike position, released when the
    /// button is; each new point also strikes. A right click holds the object there instead
    /// (*Support point*, *Held at a point* on). Only points the camera sees are picked.
    fn interact(&mut self, response: &egui::Response, view: &View, cx: &PanelCtx) {
        let setter = cx.setter;
        let n = view.pic.points.len();
        let pointer = response.interact_pointer_pos().or_else(|| response.hover_pos());
        let picked = |p: Pos2| drawing::nearest_seen(view.pic, view.to_drawing(p));
        if response.secondary_clicked() {
            if let Some(i) = pointer.and_then(picked) {
                let p = cx.params;
                set_param(setter, &p.support_point, logic::position_of_point(i, n));
                set_param(setter, &p.support_at_point, true);
                // Holding needs some support damping: with none in use (Off, or a material
                // that records none), *Support amount* applies.
                let material = p.material.value().max(0) as usize;
                let recorded = cx
                    .library
                    .materials
                    .get(material)
                    .map_or_else(|| f64::from(p.custom_support_per_s.value()), presets::Material::support_c);
                let none = match p.support_mode.value() {
                    SupportMode::Off => true,
                    SupportMode::AsRecorded => recorded <= 0.0,
                    SupportMode::Amount => false,
                };
                if none {
                    set_param(setter, &p.support_mode, SupportMode::Amount);
                }
            }
            return;
        }
        let primary = response.ctx.input(|i| i.pointer.primary_down());
        if response.is_pointer_button_down_on() && primary {
            if let Some(i) = pointer.and_then(picked) {
                let pos = logic::position_of_point(i, n);
                match self.gesture {
                    None => {
                        setter.begin_set_parameter(&cx.params.strike_position);
                        setter.set_parameter(&cx.params.strike_position, pos);
                        self.gesture = Some(i);
                        self.audition(cx.shared, pos);
                    }
                    Some(j) if j != i => {
                        setter.set_parameter(&cx.params.strike_position, pos);
                        self.gesture = Some(i);
                        self.audition(cx.shared, pos);
                    }
                    Some(_) => {}
                }
            }
        } else if self.gesture.take().is_some() {
            setter.end_set_parameter(&cx.params.strike_position);
        } else if response.clicked() {
            // Press and release within one frame.
            if let Some(i) = pointer.and_then(picked) {
                let pos = logic::position_of_point(i, n);
                set_param(setter, &cx.params.strike_position, pos);
                self.audition(cx.shared, pos);
            }
        }
    }

    /// The mode gains at the strike position, at the audition key's pitch (bars above the
    /// quality threshold in colour).
    fn mode_gains(&self, ui: &mut egui::Ui, cx: &PanelCtx, bank: &presets::Bank) {
        ui.label("Mode gains at the strike position (mode shapes at key's pitch, before the mallet)");
        let position = cx.params.strike_position.value();
        let scale = logic::lambda_scale(cx.params, cx.library, self.key);
        let bars = logic::mode_bars(bank, position, scale);
        let peak = bars.iter().fold(0.0f32, |m, b| m.max(b.gain.abs())).max(1e-6);
        let threshold = peak * 10f32.powf(-cx.params.quality_db.value() / 20.0);
        let (plot, _, painter) = Plot::show(
            ui,
            170.0,
            Axis::log(F_MIN_HZ, F_MAX_HZ),
            Axis::lin(0.0, f64::from(peak)),
            "frequency (Hz)",
            "|gain|",
            "Mode gains",
        );
        for b in &bars {
            let strong = b.gain.abs() >= threshold && b.gain != 0.0;
            let color = if strong { Color32::from_rgb(90, 170, 255) } else { Color32::from_gray(90) };
            plot.bar(&painter, b.freq_hz, f64::from(b.gain.abs()), Stroke::new(2.0, color));
        }
    }
}

/// The object list; choosing one sets the *Object* parameter (one gesture).
fn object_choice(ui: &mut egui::Ui, cx: &PanelCtx, selected: usize) {
    let lib = cx.library;
    egui::ComboBox::from_label("Object").selected_text(lib.banks[selected].name.as_str()).show_ui(ui, |ui| {
        for (i, b) in lib.banks.iter().enumerate() {
            let r = ui
                .selectable_label(i == selected, b.name.as_str())
                .on_hover_text(format!("{}\n\n{}", b.description, b.provenance));
            if r.clicked() && i != selected {
                set_param(cx.setter, &cx.params.object, i as i32);
            }
        }
    });
}

/// The object view's rectangle and the map between the drawing's plane and the screen.
struct View<'a> {
    pic: &'a drawing::ObjectDrawing,
    rect: Rect,
    centre: Pos2,
    /// Points per drawing unit.
    scale: f32,
}

impl<'a> View<'a> {
    /// The drawing fitted into `rect` with margins for the label.
    fn new(pic: &'a drawing::ObjectDrawing, rect: Rect) -> Self {
        let area = Rect::from_min_max(rect.min + Vec2::new(12.0, 22.0), rect.max - Vec2::new(12.0, 12.0));
        let scale = (area.width() / pic.size[0].max(1e-3)).min(area.height() / pic.size[1].max(1e-3));
        View { pic, rect, centre: area.center(), scale }
    }

    fn to_screen(&self, q: [f32; 2]) -> Pos2 {
        let (c, s, size) = (self.centre, self.scale, self.pic.size);
        Pos2::new(c.x + (q[0] - 0.5 * size[0]) * s, c.y - (q[1] - 0.5 * size[1]) * s)
    }

    fn to_drawing(&self, p: Pos2) -> [f32; 2] {
        let (c, s, size) = (self.centre, self.scale, self.pic.size);
        [(p.x - c.x) / s + 0.5 * size[0], (c.y - p.y) / s + 0.5 * size[1]]
    }
}

/// Paints the shaded object, the strike path (hidden parts dimmed), the points, the current
/// strike position and the hovered point.
fn paint_view(ui: &egui::Ui, response: &egui::Response, view: &View, bank: &presets::Bank, cx: &PanelCtx) {
    let pic = view.pic;
    let rect = view.rect;
    let points = &pic.points;
    let n = points.len();
    let painter = ui.painter_at(rect);
    let visuals = ui.visuals();
    painter.rect_filled(rect, 4.0, visuals.extreme_bg_color);
    let mut mesh = egui::Mesh::default();
    for f in &pic.facets {
        let g = |c: f32| (c * (0.15 + 0.85 * f.shade)).round().clamp(0.0, 255.0) as u8;
        let color = Color32::from_rgb(g(150.0), g(165.0), g(185.0));
        let base = mesh.vertices.len() as u32;
        for &c in &f.corners {
            mesh.colored_vertex(view.to_screen(c), color);
        }
        mesh.add_triangle(base, base + 1, base + 2);
    }
    if !mesh.is_empty() {
        painter.add(egui::Shape::mesh(mesh));
    }
    let path: Vec<Pos2> = points.iter().map(|&p| view.to_screen(p)).collect();
    let seen = |i: usize| pic.visible.get(i).copied().unwrap_or(true);
    let hidden_color = visuals.weak_text_color().gamma_multiply(0.6);
    for i in 1..path.len() {
        let stroke = if seen(i - 1) && seen(i) {
            Stroke::new(1.0, visuals.text_color().gamma_multiply(0.7))
        } else {
            Stroke::new(1.0, hidden_color)
        };
        painter.line_segment([path[i - 1], path[i]], stroke);
    }
    let position = cx.params.strike_position.value();
    // The strike point nearest along the path (on screen, points in front and behind can
    // overlap).
    let current = (n > 0).then(|| {
        let p = if position.is_finite() { position.clamp(0.0, 1.0) } else { 0.0 };
        ((p * (n - 1) as f32).round() as usize).min(n - 1)
    });
    for (i, p) in path.iter().enumerate() {
        let (color, radius) = if Some(i) == current {
            (Color32::from_rgb(255, 190, 60), 5.0)
        } else if seen(i) {
            (visuals.strong_text_color(), 2.5)
        } else {
            (hidden_color, 1.5)
        };
        painter.circle_filled(*p, radius, color);
    }
    if let Some(xy) = logic::point_at_position(points, position) {
        let alpha = if current.is_none_or(seen) { 1.0 } else { 0.4 };
        painter.circle_stroke(
            view.to_screen(xy),
            9.0,
            Stroke::new(2.0, Color32::from_rgb(255, 150, 40).gamma_multiply(alpha)),
        );
    }
    // Where the object is held (*Held at a point*): a support under it.
    let p = cx.params;
    if p.support_at_point.value() && p.support_mode.value() != SupportMode::Off {
        if let Some(xy) = logic::point_at_position(points, p.support_point.value()) {
            let at = view.to_screen(xy);
            let color = Color32::from_rgb(150, 220, 120);
            painter.add(egui::Shape::convex_polygon(
                vec![at, at + Vec2::new(-7.0, 12.0), at + Vec2::new(7.0, 12.0)],
                color,
                Stroke::NONE,
            ));
        }
    }
    // A sounding lasting contact, where it is now.
    if let Some(xy) = cx.shared.contact().and_then(|c| logic::point_at_position(points, c)) {
        let at = view.to_screen(xy);
        painter.circle_filled(at, 5.0, Color32::from_rgb(80, 200, 255));
        painter.circle_stroke(at, 8.0, Stroke::new(1.5, Color32::from_rgb(80, 200, 255)));
    }
    let label = current.and_then(|i| bank.points.get(i)).map_or("", |p| p.label.as_str());
    painter.text(
        rect.left_top() + Vec2::new(6.0, 4.0),
        egui::Align2::LEFT_TOP,
        format!("{} · {label}", cx.params.strike_position),
        egui::FontId::proportional(11.0),
        visuals.text_color(),
    );
    if let Some(p) = response.hover_pos() {
        if let Some(i) = drawing::nearest_seen(pic, view.to_drawing(p)) {
            painter.circle_stroke(path[i], 6.0, Stroke::new(1.0, visuals.strong_text_color()));
        }
    }
}
