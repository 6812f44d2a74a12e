//! A stand-in for the host's GUI context: it applies parameter changes directly and records
//! every gesture, so the editor's UI can be driven headlessly (egui_kittest) with the same
//! `ParamSetter` code path as in a host.

use crate::params::StruckParams;
use nice_plug::prelude::*;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, PoisonError};

/// One call the editor made on the host.
#[derive(Clone, Debug, PartialEq)]
pub enum Gesture {
    /// `begin_set_parameter` of this parameter id.
    Begin(String),
    /// `set_parameter` with this normalised value.
    Set(String, f32),
    /// `end_set_parameter`.
    End(String),
}

/// A GUI context that sets parameters itself and logs gestures.
pub struct RecordingContext {
    params: Arc<StruckParams>,
    ids: Vec<(ParamPtr, String)>,
    log: Mutex<Vec<Gesture>>,
}

// SAFETY: the raw parameter pointers target `params`, which this struct keeps alive; they are
// only dereferenced through `ParamPtr`'s own (thread-safe, atomic) accessors.
unsafe impl Send for RecordingContext {}
// SAFETY: as above; the log is behind a mutex.
unsafe impl Sync for RecordingContext {}

impl RecordingContext {
    /// A context for `params`.
    pub fn new(params: Arc<StruckParams>) -> Self {
        let ids = params.param_map().into_iter().map(|(id, ptr, _)| (ptr, id)).collect();
        RecordingContext { params, ids, log: Mutex::new(Vec::new()) }
    }

    /// The parameters.
    pub fn params(&self) -> &Arc<StruckParams> {
        &self.params
    }

    /// Every gesture so far.
    pub fn gestures(&self) -> Vec<Gesture> {
        self.log.lock().unwrap_or_else(PoisonError::into_inner).clone()
    }

    /// Forgets the log.
    pub fn clear(&self) {
        self.log.lock().unwrap_or_else(PoisonError::into_inner).clear();
    }

    /// Whether every `Set` of a parameter lies inside a `Begin`…`End` of that parameter, and
    /// every gesture is closed.
    pub fn gestures_well_formed(&self) -> bool {
        let mut open: Vec<String> = Vec::new();
        for g in self.gestures() {
            match g {
                Gesture::Begin(id) => {
                    if open.contains(&id) {
                        return false;
                    }
                    open.push(id);
                }
                Gesture::Set(id, _) => {
                    if !open.contains(&id) {
                        return false;
                    }
                }
                Gesture::End(id) => match open.iter().position(|o| *o == id) {
                    Some(i) => {
                        open.remove(i);
                    }
                    None => return false,
                },
            }
        }
        open.is_empty()
    }

    fn id(&self, ptr: ParamPtr) -> String {
        self.ids.iter().find(|(p, _)| *p == ptr).map_or_else(|| "?".into(), |(_, id)| id.clone())
    }

    fn push(&self, g: Gesture) {
        self.log.lock().unwrap_or_else(PoisonError::into_inner).push(g);
    }
}

impl GuiContextInner for RecordingContext {
    fn plugin_api(&self) -> PluginApi {
        PluginApi::Clap
    }

    unsafe fn raw_begin_set_parameter(&self, param: ParamPtr) {
        self.push(Gesture::Begin(self.id(param)));
    }

    unsafe fn raw_set_parameter_normalized(&self, param: ParamPtr, normalized: f32) {
        // SAFETY: `param` comes from `self.params` (the editor only sets its own parameters).
        unsafe { param._internal_set_normalized_value(normalized) };
        self.push(Gesture::Set(self.id(param), normalized));
    }

    unsafe fn raw_end_set_parameter(&self, param: ParamPtr) {
        self.push(Gesture::End(self.id(param)));
    }

    fn get_state(&self) -> PluginState {
        PluginState { version: String::new(), params: BTreeMap::new(), fields: BTreeMap::new() }
    }

    fn set_state(&self, _state: PluginState) {}

    fn request_restart(&self) {}
}
