//! What the panels share: the context a panel draws in, and host-gesture helpers.
//!
//! The panels (`object`, `material`, `capture`) each own their state and import only this
//! module, `logic`, `plot` and `drawing`; `ui` owns the panels and builds the context each
//! frame. No panel reaches into another.

use crate::library::Library;
use crate::params::StruckParams;
use crate::shared::EditorShared;
use nice_plug::prelude::{Param, ParamSetter};
use std::path::Path;
use std::sync::Arc;

/// What a panel reads while it draws: the parameters (changed through `setter`, as host
/// gestures), the library, the link to the audio thread and the user materials folder.
pub(super) struct PanelCtx<'a> {
    /// The plugin's parameters.
    pub params: &'a Arc<StruckParams>,
    /// Banks and materials.
    pub library: &'a Arc<Library>,
    /// Auditions, meters and clips shared with the audio thread.
    pub shared: &'a Arc<EditorShared>,
    /// Host gestures.
    pub setter: &'a ParamSetter<'a>,
    /// Where user materials are read and saved.
    pub material_dir: &'a Path,
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

/// Sets the *Custom* material to reproduce `d` and its recorded support damping `support_c`
/// (s⁻¹): one gesture per parameter.
///
/// # Errors
/// As [`StruckParams::custom_knobs_for`] (nothing is changed).
pub(super) fn apply_damping(
    params: &StruckParams,
    custom_index: usize,
    setter: &ParamSetter,
    d: &dsp::Damping,
    support_c: f64,
) -> Result<(), String> {
    let k = params.custom_knobs_for(d)?;
    set_param(setter, &params.custom_support_per_s, support_c.clamp(0.0, 2000.0) as f32);
    set_param(setter, &params.material, custom_index as i32);
    set_param(setter, &params.damping_model, k.model);
    set_param(setter, &params.alpha1_per_s, k.alpha1_per_s);
    set_param(setter, &params.damping_1k_per_s, k.damping_1k_per_s);
    set_param(setter, &params.exponent, k.exponent);
    set_param(setter, &params.caughey_10k_per_s, k.caughey_10k_per_s);
    Ok(())
}
