//! The editor's state and top-level layout. The panels are their own types (`object`,
//! `material`, `capture`), each with its own state; this module owns them and gives each the
//! [`PanelCtx`] it draws in.

use super::capture::CapturePanel;
use super::material::MaterialPanel;
use super::object::ObjectPanel;
use super::panel::PanelCtx;
use crate::library::Library;
use crate::params::StruckParams;
use crate::shared::EditorShared;
use nice_plug::prelude::ParamSetter;
use std::path::PathBuf;
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
    params: Arc<StruckParams>,
    library: Arc<Library>,
    shared: Arc<EditorShared>,
    /// The visible tab.
    pub tab: Tab,
    object: ObjectPanel,
    material: MaterialPanel,
    capture: CapturePanel,
    /// Where user materials are read and saved; `None`: [`super::logic::user_material_dir`].
    pub user_material_dir: Option<PathBuf>,
    /// The lasting contact's position at the last frame, and when it last moved (egui time,
    /// s): a moving contact is redrawn every frame.
    last_contact: Option<f32>,
    contact_moved_at: f64,
}

impl EditorUi {
    /// UI state for these parameters, library and audio-thread link.
    pub fn new(params: Arc<StruckParams>, library: Arc<Library>, shared: Arc<EditorShared>) -> Self {
        EditorUi {
            params,
            library,
            shared,
            tab: Tab::Play,
            object: ObjectPanel::default(),
            material: MaterialPanel::default(),
            capture: CapturePanel::default(),
            user_material_dir: None,
            last_contact: None,
            contact_moved_at: f64::NEG_INFINITY,
        }
    }

    /// The user materials folder this editor reads and saves to.
    pub fn material_dir(&self) -> PathBuf {
        self.user_material_dir.clone().unwrap_or_else(super::logic::user_material_dir)
    }

    /// The parameters this editor changes.
    pub fn params(&self) -> &Arc<StruckParams> {
        &self.params
    }

    /// Draws the whole editor into `ui`; parameter changes go through `setter` (host gestures).
    pub fn ui(&mut self, ui: &mut egui::Ui, setter: &ParamSetter) {
        self.capture.poll(&self.params);
        self.capture.poll_ab(&self.shared);
        let material_dir = self.material_dir();
        let cx = PanelCtx {
            params: &self.params,
            library: &self.library,
            shared: &self.shared,
            setter,
            material_dir: &material_dir,
        };
        // Files dropped on the window: recordings on the Capture view, a texture on Play.
        let dropped: Vec<PathBuf> =
            ui.ctx().input(|i| i.raw.dropped_files.iter().map(|f| f.path().to_path_buf()).collect());
        if !dropped.is_empty() {
            match self.tab {
                Tab::Capture => self.capture.add_dropped_files(dropped),
                Tab::Play => self.material.take_dropped_texture(&dropped, &cx),
            }
        }
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
                        self.object.show(&mut cols[0], &cx);
                        self.material.show(&mut cols[1], &cx);
                    });
                }
                Tab::Capture => {
                    if self.capture.show(ui, &cx) {
                        self.material.rescan();
                    }
                }
            });
        });
        // A contact that moves is drawn every frame; a still one (the effect's input at speed 0)
        // needs no more than the meters.
        let contact = self.shared.contact();
        let now = ui.input(|i| i.time);
        if contact.is_some() && contact != self.last_contact {
            self.contact_moved_at = now;
        }
        self.last_contact = contact;
        // Blocks may be longer than a frame: a contact is moving if it moved lately.
        let moving = contact.is_some() && now - self.contact_moved_at < 0.25;
        if self.capture.is_running() || self.object.is_active() || self.capture.ab_busy() || moving {
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

    /// Adds a recording to the capture list (what the path field, the browser and a drop do).
    ///
    /// # Errors
    /// If `path` is not an existing `.wav` file.
    pub fn add_capture_file(&mut self, path: PathBuf) -> Result<(), String> {
        self.capture.add_file(path)
    }

    /// The last texture load's result or error.
    pub fn texture_message(&self) -> Option<&str> {
        self.material.texture_message.as_deref()
    }

    /// Ticks or clears *Spiral through an image* (as a click would).
    pub fn set_texture_spiral(&mut self, spiral: bool) {
        self.material.texture_spiral = spiral;
    }

    /// Sets the texture file field (as typing would).
    pub fn set_texture_path(&mut self, path: &str) {
        self.material.texture_path = path.to_string();
    }

    /// The recordings the next analysis will use.
    pub fn capture_files(&self) -> &[PathBuf] {
        &self.capture.files
    }

    /// Whether an analysis is running.
    pub fn capture_running(&self) -> bool {
        self.capture.is_running()
    }

    /// Blocks until a running analysis ends and stores its result (for tests).
    pub fn wait_for_capture(&mut self) {
        self.capture.wait(&self.params);
    }

    /// The last capture error or note shown in the panel.
    pub fn capture_message(&self) -> Option<&str> {
        self.capture.message.as_deref()
    }

    /// Whether an A/B clip is being built.
    pub fn ab_busy(&self) -> bool {
        self.capture.ab_busy()
    }

    /// Waits for the A/B clip being built and queues it (for tests).
    pub fn wait_for_ab(&mut self) {
        self.capture.wait_for_ab(&self.shared);
    }

    /// The last A/B button pressed and the impact it played.
    pub fn ab_last(&self) -> Option<(super::ab::Side, usize)> {
        self.capture.ab_last
    }
}

/// The editor's look (slightly larger text than egui's default for plugin windows).
pub fn setup_style(ctx: &egui::Context) {
    ctx.set_visuals(egui::Visuals::dark());
}
