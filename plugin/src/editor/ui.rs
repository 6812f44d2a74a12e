//! The editor's state and top-level layout; the panels are in `object`, `material` and
//! `capture`.

use super::capture::CaptureUi;
use super::material::MaterialUi;
use super::EditorShared;
use crate::library::Library;
use crate::params::StruckParams;
use nice_plug::prelude::{Param, ParamSetter};
use std::sync::Arc;

/// Which view the editor shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tab {
    /// Object view and material panel side by side.
    Play,
    /// The estimator: recordings in, material out.
    Capture,
}

/// Everything the editor shows and remembers between frames (and between openings of the
/// window). Draw it with [`EditorUi::ui`].
pub struct EditorUi {
    pub(super) params: Arc<StruckParams>,
    pub(super) library: Arc<Library>,
    pub(super) shared: Arc<EditorShared>,
    /// The visible tab.
    pub tab: Tab,
    /// Velocity of strikes from the object view, 0..=1.
    pub audition_velocity: f32,
    /// Key whose tuning object-view strikes use.
    pub audition_key: u8,
    pub(super) serial: u32,
    /// Strike point under the pointer while a click or drag on the object view lasts.
    pub(super) object_gesture: Option<usize>,
    /// The object view's picture of the selected bank (rebuilt when the object changes).
    pub(super) drawing: Option<Arc<super::drawing::ObjectDrawing>>,
    pub(super) material: MaterialUi,
    pub(super) capture: CaptureUi,
    /// Where user materials are read and saved; `None`: [`super::logic::user_material_dir`].
    pub user_material_dir: Option<std::path::PathBuf>,
}

impl EditorUi {
    /// UI state for these parameters, library and audio-thread link.
    pub fn new(params: Arc<StruckParams>, library: Arc<Library>, shared: Arc<EditorShared>) -> Self {
        EditorUi {
            params,
            library,
            shared,
            tab: Tab::Play,
            audition_velocity: 0.8,
            audition_key: 60,
            serial: 0,
            object_gesture: None,
            drawing: None,
            material: MaterialUi::default(),
            capture: CaptureUi::default(),
            user_material_dir: None,
        }
    }

    /// The user materials folder this editor reads and saves to.
    pub fn material_dir(&self) -> std::path::PathBuf {
        self.user_material_dir.clone().unwrap_or_else(super::logic::user_material_dir)
    }

    /// The parameters this editor changes.
    pub fn params(&self) -> &Arc<StruckParams> {
        &self.params
    }

    /// Draws the whole editor into `ui`; parameter changes go through `setter` (host gestures).
    pub fn ui(&mut self, ui: &mut egui::Ui, setter: &ParamSetter) {
        self.capture.poll(&self.params);
        self.poll_ab();
        self.capture.take_dropped_files(ui.ctx());
        // The status line (voices, sounding modes) is a bottom panel, so it is always whole
        // on screen; the views scroll above it.
        egui::Panel::bottom("struck-status").show(ui, |ui| self.status_line(ui));
        egui::CentralPanel::default().show(ui, |ui| {
            ui.horizontal(|ui| {
                ui.heading("Struck");
                ui.separator();
                ui.selectable_value(&mut self.tab, Tab::Play, "Play & shape");
                ui.selectable_value(&mut self.tab, Tab::Capture, "Capture");
            });
            ui.separator();
            egui::ScrollArea::vertical().auto_shrink([false, false]).show(ui, |ui| match self.tab {
                Tab::Play => {
                    ui.columns(2, |cols| {
                        self.object_panel(&mut cols[0], setter);
                        self.material_panel(&mut cols[1], setter);
                    });
                }
                Tab::Capture => self.capture_panel(ui, setter),
            });
        });
        if self.capture.is_running() || self.object_gesture.is_some() || self.ab_busy() {
            ui.ctx().request_repaint();
        } else {
            // Meters move while notes ring: poll them a few times a second.
            ui.ctx().request_repaint_after(std::time::Duration::from_millis(100));
        }
    }

    fn status_line(&self, ui: &mut egui::Ui) {
        let (voices, modes) = self.shared.meters();
        ui.horizontal(|ui| {
            ui.label(format!("Voices {voices}"));
            ui.separator();
            ui.label(format!("Sounding modes {modes}"));
            ui.separator();
            ui.label(format!("Object {}", self.params.object));
            ui.separator();
            ui.label(format!("Material {}", self.params.material));
            ui.separator();
            ui.label(format!("Strike {}", self.params.strike_position));
        });
    }

    /// Queues a strike at `position` for the audio thread.
    pub(super) fn audition(&mut self, position: f32) {
        self.serial = self.serial.wrapping_add(1);
        let a = super::Audition {
            key: self.audition_key.min(127),
            velocity: self.audition_velocity.clamp(0.0, 1.0),
            position,
            serial: self.serial,
        };
        let _ = self.shared.audition(a);
    }
}

/// One complete host gesture: begin, set, end.
pub(super) fn set_param<P: Param>(setter: &ParamSetter, param: &P, value: P::Plain) {
    setter.begin_set_parameter(param);
    setter.set_parameter(param, value);
    setter.end_set_parameter(param);
}

/// A label and a `ParamSlider` in a grid row.
pub(super) fn param_row<P: Param>(ui: &mut egui::Ui, setter: &ParamSetter, param: &P) {
    ui.label(param.name());
    // Named for screen readers (and the UI tests): ParamSlider sets no accessibility info.
    ui.add(nice_plug_egui::widgets::ParamSlider::for_param(param, setter).with_width(170.0))
        .accessible_name(format!("{} slider", param.name()));
    ui.end_row();
}

/// The editor's look (slightly larger text than egui's default for plugin windows).
pub fn setup_style(ctx: &egui::Context) {
    ctx.set_visuals(egui::Visuals::dark());
}
