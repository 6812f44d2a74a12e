//! Struck's editor (egui through nice-plug-egui): play the object where you click, shape the
//! material while seeing its T60 curve, and capture a material from recordings with the
//! estimator running on a background thread.
//!
//! Threads: the GUI talks to the audio thread only through [`EditorShared`] (in
//! [`crate::shared`], which the audio path imports instead of this module: a bounded
//! lock-free queue of auditions, atomics for the meters, clip playback). Parameters change only through
//! nice-plug's `ParamSetter` (host gestures). The estimator runs on its own `std::thread`;
//! progress and cancel are atomics, the result is picked up by the GUI with a `try_lock`.
//!
//! The panels are drawn by [`EditorUi::ui`], which takes any `ParamSetter`: the plugin passes
//! the host's, the tests one built on [`testing::RecordingContext`].

pub mod ab;
mod capture;
pub mod drawing;
pub mod logic;
mod material;
mod object;
mod panel;
mod plot;
pub mod testing;
mod ui;

pub use crate::shared::{
    is_audition, Audition, Clip, ClipPlayer, EditorShared, AUDITION_QUEUE, CLIP_QUEUE, CLIP_RETURN,
};
pub use crate::shared::{CaptureRecord, CapturedObject};
pub use ui::{EditorUi, Tab};

use crate::library::Library;
use crate::params::StruckParams;
use nice_plug::context::gui::GuiContext;
use nice_plug::editor::{HostMethods, SpawnedEditor};
use nice_plug::prelude::*;
use nice_plug_egui::{
    create_egui_editor, EguiEditorHandle, EguiEditorState, EguiNiceSettings, NiceEguiApp, RepaintNotifier,
};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex, PoisonError};

pub use crate::params::DEFAULT_EDITOR_SIZE as DEFAULT_SIZE;
/// Smallest window size the host may resize the editor to.
pub const MIN_SIZE: [u32; 2] = [720, 480];
/// The plugin's editor: builds a fresh egui window at each open, at the persisted size, with
/// the UI state ([`EditorUi`]) kept across opens.
pub struct StruckEditor {
    params: Arc<StruckParams>,
    ui: Arc<Mutex<EditorUi>>,
    repaint: RepaintNotifier,
    /// Last scale factor the window reported (physical / logical pixels).
    scale: Arc<AtomicF32>,
}

impl StruckEditor {
    /// An editor for these parameters and library, talking to the audio thread through `shared`.
    pub fn new(params: Arc<StruckParams>, library: Arc<Library>, shared: Arc<EditorShared>) -> Self {
        let ui = EditorUi::new(params.clone(), library, shared);
        StruckEditor {
            params,
            ui: Arc::new(Mutex::new(ui)),
            repaint: RepaintNotifier::new(),
            scale: Arc::new(AtomicF32::new(1.0)),
        }
    }

    fn logical_size(&self) -> [u32; 2] {
        sanitize_size(*self.params.editor_size.lock().unwrap_or_else(PoisonError::into_inner))
    }
}

/// A persisted size clamped to something openable (old or hand-edited states).
pub fn sanitize_size([w, h]: [u32; 2]) -> [u32; 2] {
    [w.clamp(MIN_SIZE[0], 8192), h.clamp(MIN_SIZE[1], 8192)]
}

fn resize_hint() -> ResizeHint {
    ResizeHint::resizable()
        .with_min_logical_size(nice_plug::editor::dpi::LogicalSize::new(MIN_SIZE[0] as f32, MIN_SIZE[1] as f32))
}

impl Editor for StruckEditor {
    type Handle = EguiEditorHandle;

    fn spawn(
        &self,
        parent: Option<ParentWindowHandle>,
        wait_for_parent: bool,
        fallback_scale_factor: Option<f64>,
        gui_context: GuiContext,
        host: Option<HostMethods>,
    ) -> Result<SpawnedEditor<Self::Handle>, Box<dyn std::error::Error>> {
        let [w, h] = self.logical_size();
        let state = EguiEditorState::from_size(nice_plug::editor::dpi::LogicalSize::new(w as f32, h as f32), 1.0);
        let app = App { ui: self.ui.clone(), params: self.params.clone(), scale: self.scale.clone(), ctx: None };
        let settings = EguiNiceSettings::new().with_tile("Struck").with_resize_hint(resize_hint());
        let editor = create_egui_editor(state, self.repaint.clone(), settings, app)
            .ok_or("nice-plug-egui could not create the editor")?;
        editor.spawn(parent, wait_for_parent, fallback_scale_factor, gui_context, host)
    }

    fn size(&self) -> nice_plug::editor::dpi::NativeSize<u32> {
        let [w, h] = self.logical_size();
        let size = nice_plug::editor::dpi::LogicalSize::new(f64::from(w), f64::from(h));
        nice_plug::editor::dpi::NativeSize::from_size(size.into(), f64::from(self.scale.load(Ordering::Relaxed)))
    }

    fn resize_hint(&self) -> ResizeHint {
        resize_hint()
    }
}

/// The egui app of one open window.
struct App {
    ui: Arc<Mutex<EditorUi>>,
    params: Arc<StruckParams>,
    scale: Arc<AtomicF32>,
    ctx: Option<GuiContext>,
}

impl NiceEguiApp for App {
    fn build(
        &mut self,
        egui_ctx: egui::Context,
        nice_gui_ctx: GuiContext,
        _frame: &mut nice_plug_egui::Frame,
    ) -> Result<(), nice_plug_egui::baseview::HandlerError> {
        ui::setup_style(&egui_ctx);
        self.ctx = Some(nice_gui_ctx);
        Ok(())
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut nice_plug_egui::Frame) {
        let Some(ctx) = &self.ctx else { return };
        let setter = ctx.param_setter();
        self.ui.lock().unwrap_or_else(PoisonError::into_inner).ui(ui, &setter);
    }

    fn resized(&mut self, size: nice_plug_egui::baseview::WindowSize) {
        let w = size.logical.width.round().max(1.0) as u32;
        let h = size.logical.height.round().max(1.0) as u32;
        *self.params.editor_size.lock().unwrap_or_else(PoisonError::into_inner) = [w, h];
        if size.scale_factor.is_finite() && size.scale_factor > 0.0 {
            self.scale.store(size.scale_factor as f32, Ordering::Relaxed);
        }
    }

    fn editor_closed(&mut self) {
        self.ctx = None;
    }
}
