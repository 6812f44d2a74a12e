//! Material panel: factory and user materials, the damping knobs and the sound controls,
//! and the T60 curve of the law the audio plays.

use super::logic::{self, F_MAX_HZ, F_MIN_HZ};
use super::panel::{apply_damping, param_row, set_param, PanelCtx};
use super::plot::{Axis, Plot};
use crate::library::{scan_user_materials, UserMaterial};
use egui::{self, Color32, Stroke};
use std::path::PathBuf;

/// Material panel state.
#[derive(Default)]
pub(super) struct MaterialPanel {
    /// User materials, listed on first show and on *Rescan*.
    pub user: Option<Vec<UserMaterial>>,
    /// Name of the user material last loaded into the Custom knobs.
    pub loaded_user: Option<String>,
    /// Last error or note.
    pub message: Option<String>,
    /// The texture file field, and the last load's result.
    pub texture_path: String,
    pub texture_message: Option<String>,
    /// Read a .png texture along a spiral from its centre (else its middle row).
    pub texture_spiral: bool,
}

/// Height of the T60 plot, logical points.
const T60_PLOT_HEIGHT: f32 = 170.0;

impl MaterialPanel {
    /// Lists the user folder again the next time the panel is drawn (after a save).
    pub fn rescan(&mut self) {
        self.user = None;
    }

    /// Draws the panel: the material choice, the T60 curve, the knob groups.
    pub fn show(&mut self, ui: &mut egui::Ui, cx: &PanelCtx) {
        ui.heading("Material");
        self.chooser(ui, cx);
        t60_plot(ui, cx);
        knob_groups(ui, cx, self);
    }

    /// Loads the first of the files dropped on the *Play* view as the texture (what typing its
    /// path and *Load texture* do).
    pub fn take_dropped_texture(&mut self, dropped: &[PathBuf], cx: &PanelCtx) {
        if let Some(first) = dropped.first() {
            self.texture_path = first.display().to_string();
            self.load_texture(cx);
        }
    }

    /// Loads the texture file in the field: kept with the project, sent to the audio thread,
    /// *Texture* set to User file. The result (or the one-line error) is shown under the field.
    pub fn load_texture(&mut self, cx: &PanelCtx) {
        if self.texture_path.trim().is_empty() {
            self.texture_message = Some("type the path of a texture file (.csv, .txt, .wav, .png)".into());
            return;
        }
        let path = PathBuf::from(self.texture_path.trim());
        let image_path =
            if self.texture_spiral { presets::texture::ImagePath::Spiral } else { presets::texture::ImagePath::Row };
        let file = match crate::user_texture::load_texture_file(&path, image_path) {
            Ok(f) => f,
            Err(e) => {
                self.texture_message = Some(e);
                return;
            }
        };
        let note = format!("{}: {} texels of {:.3} mm", file.name, file.heights_m.len(), file.texel_m * 1e3);
        if let Err(e) = cx.params.user_texture.set_file(Some(file)) {
            self.texture_message = Some(e);
            return;
        }
        self.texture_message = Some(note);
        set_param(cx.setter, &cx.params.texture, crate::params::TextureParam::User);
    }

    /// Factory, Custom and user materials in one list; a user material loads into the Custom
    /// knobs.
    fn chooser(&mut self, ui: &mut egui::Ui, cx: &PanelCtx) {
        let (lib, p, setter) = (cx.library, cx.params, cx.setter);
        let selected = p.material.value().max(0) as usize;
        let custom = lib.custom_material_index();
        if self.user.is_none() {
            self.user = Some(scan_user_materials(cx.material_dir));
        }
        let shown = match (lib.materials.get(selected), &self.loaded_user) {
            (Some(m), _) => m.name.clone(),
            (None, Some(u)) => format!("Custom: {u}"),
            (None, None) => "Custom (knobs)".into(),
        };
        // A user material chosen: its name, law, and the material itself.
        let mut chosen_user: Option<(String, dsp::Damping, presets::Material, Option<String>)> = None;
        ui.horizontal(|ui| {
            egui::ComboBox::from_label("Material").selected_text(shown).width(220.0).show_ui(ui, |ui| {
                ui.label(egui::RichText::new("Factory").weak());
                for (i, m) in lib.materials.iter().enumerate() {
                    let r = ui
                        .selectable_label(i == selected, m.name.as_str())
                        .on_hover_text(format!("{}\n\n{}", m.provenance, m.notes));
                    if r.clicked() && i != selected {
                        set_param(setter, &p.material, i as i32);
                        self.loaded_user = None;
                    }
                }
                if ui.selectable_label(selected >= custom, "Custom (the knobs below)").clicked() && selected < custom {
                    set_param(setter, &p.material, custom as i32);
                }
                ui.separator();
                ui.label(egui::RichText::new(format!("User ({})", cx.material_dir.display())).weak());
                for u in self.user.iter().flatten() {
                    let name = u.path.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
                    match &u.material {
                        Ok(m) => {
                            if ui
                                .selectable_label(false, m.name.as_str())
                                .on_hover_text(format!("{}\n\n{}", m.provenance, u.path.display()))
                                .clicked()
                            {
                                let note = u.unknown.as_ref().map(|n| format!("{name}: {n}"));
                                match m.to_damping() {
                                    Ok(d) => chosen_user = Some((m.name.clone(), d, m.clone(), note)),
                                    Err(e) => self.message = Some(e.to_string()),
                                }
                            }
                        }
                        Err(e) => {
                            ui.label(egui::RichText::new(format!("{name}: unreadable")).weak())
                                .on_hover_text(e.as_str());
                        }
                    }
                }
            });
            if ui.small_button("Rescan").on_hover_text("List the user materials folder again").clicked() {
                self.user = None;
            }
        });
        if let Some((name, d, m, note)) = chosen_user {
            let (support, residual, recorded) = (m.support_c(), m.residual.clone(), m.recorded_modes().cloned());
            // The material's residual and per-mode support go with its law into Custom (none:
            // none plays).
            match apply_damping(p, custom, setter, &d, support)
                .and_then(|()| p.user_residual.set_source(residual))
                .and_then(|()| p.user_support.set_source(recorded).map(|_| ()))
            {
                Ok(()) => {
                    self.loaded_user = Some(name);
                    // Loaded, but say what was left out (a misspelt field plays its default).
                    self.message = note;
                }
                Err(e) => {
                    // Never an earlier material's residual or support with this law.
                    let _ = p.user_residual.set_source(None);
                    let _ = p.user_support.set_source(None);
                    self.message = Some(e);
                }
            }
        }
        if let Some(m) = &self.message {
            ui.colored_label(Color32::from_rgb(255, 170, 60), m.as_str());
        }
    }
}

/// The T60 curve of the law the audio plays, with the last capture's features as dots. Drawn
/// before the knobs, so it is whole on screen at the default window size (issue 11 part 6).
fn t60_plot(ui: &mut egui::Ui, cx: &PanelCtx) {
    let (lib, p) = (cx.library, cx.params);
    ui.add_space(4.0);
    ui.label("Decay time T60 = ln(1000)/d, d = c(λ)/2, λ = (2πf)² (dots: last capture)");
    let d = logic::current_damping(p, lib);
    let scale = f64::from(p.decay_scale.value());
    let curve = logic::t60_curve(&d, scale, F_MIN_HZ, F_MAX_HZ, 200);
    let (plot, _, painter) = Plot::show(
        ui,
        T60_PLOT_HEIGHT,
        Axis::log(F_MIN_HZ, F_MAX_HZ),
        Axis::log(1e-3, 100.0),
        "frequency (Hz)",
        "T60 (s)",
        "T60 curve",
    );
    if let Ok(c) = p.capture.try_lock() {
        if let Some(rec) = c.as_ref() {
            for f in rec.report.impacts.iter().flat_map(|i| &i.features) {
                if f.decay_per_s > 0.0 {
                    plot.dot(&painter, f.freq_hz, logic::LN_1000 / f.decay_per_s, 2.0, Color32::from_gray(150));
                }
            }
        }
    }
    plot.line(&painter, &curve, Stroke::new(2.0, Color32::from_rgb(255, 190, 60)));
    ui.add_space(4.0);
}

/// The sound controls in groups: custom law, mallet, material and object, keys, output.
fn knob_groups(ui: &mut egui::Ui, cx: &PanelCtx, panel: &mut MaterialPanel) {
    let (lib, p, setter) = (cx.library, cx.params, cx.setter);
    let selected = p.material.value().max(0) as usize;
    let custom = lib.custom_material_index();

    egui::CollapsingHeader::new("Custom damping law").default_open(selected >= custom).show(ui, |ui| {
        if selected < custom {
            ui.label(egui::RichText::new("These knobs play when Material is Custom.").weak());
        }
        egui::Grid::new("damping-knobs").num_columns(2).show(ui, |ui| {
            param_row(ui, setter, &p.damping_model);
            param_row(ui, setter, &p.alpha1_per_s);
            param_row(ui, setter, &p.damping_1k_per_s);
            param_row(ui, setter, &p.exponent);
            param_row(ui, setter, &p.caughey_10k_per_s);
            param_row(ui, setter, &p.custom_support_per_s);
        });
        // Support recorded mode by mode (issue 10 part 6): where it plays, and whether it does.
        if let Some((object, mapping)) = p.user_support.status() {
            let text = match mapping.object {
                None => format!("Support recorded mode by mode on '{object}', which is not in the library: not played"),
                Some(o) => {
                    let name = cx.library.banks.get(o).map_or(object.as_str(), |b| b.name.as_str());
                    let mut t = format!(
                        "Support as recorded on {name}: {} modes with their own measured damping",
                        mapping.modes
                    );
                    if mapping.skipped > 0 {
                        t += &format!(" ({} no longer match the bank)", mapping.skipped);
                    }
                    let playing = selected >= custom
                        && crate::object_index_of(p, cx.library) == o
                        && p.support_mode.value() == crate::params::SupportMode::AsRecorded
                        && !p.support_at_point.value();
                    t += if playing {
                        ": playing"
                    } else {
                        ": plays with Custom on that object, Support As recorded, not held at a point"
                    };
                    t
                }
            };
            ui.label(egui::RichText::new(text).weak());
        }
    });
    egui::CollapsingHeader::new("Residual").default_open(p.user_residual.is_set()).show(ui, |ui| {
        egui::Grid::new("residual-knobs").num_columns(2).show(ui, |ui| {
            param_row(ui, setter, &p.residual);
            param_row(ui, setter, &p.residual_level_db);
        });
        let status = match p.user_residual.source() {
            Some(r) => format!(
                "The Custom material keeps a recorded residual ({} modes, {:.2} s): strikes play it, transferred to the object",
                r.modes.len(),
                f64::from(r.frames.saturating_sub(1) * r.hop) / f64::from(r.sample_rate.max(1))
            ),
            None => "No residual: load a captured material (or apply a capture) into Custom".into(),
        };
        ui.label(egui::RichText::new(status).weak());
        if selected < custom && p.user_residual.is_set() {
            ui.label(egui::RichText::new("It plays when Material is Custom.").weak());
        }
    });
    egui::CollapsingHeader::new("Mallet").default_open(true).show(ui, |ui| {
        egui::Grid::new("mallet-knobs").num_columns(2).show(ui, |ui| {
            param_row(ui, setter, &p.mallet);
            param_row(ui, setter, &p.hardness);
            param_row(ui, setter, &p.velocity_sensitivity);
            param_row(ui, setter, &p.variation);
            param_row(ui, setter, &p.noise);
        });
    });
    egui::CollapsingHeader::new("Excitation").default_open(true).show(ui, |ui| {
        egui::Grid::new("excitation-knobs").num_columns(2).show(ui, |ui| {
            param_row(ui, setter, &p.excitation);
            param_row(ui, setter, &p.contact_speed);
            param_row(ui, setter, &p.texture);
            param_row(ui, setter, &p.texture_scale);
            param_row(ui, setter, &p.ball_radius_mm);
            param_row(ui, setter, &p.contact_direction);
            param_row(ui, setter, &p.path_ends);
            param_row(ui, setter, &p.audio_in);
            param_row(ui, setter, &p.dry_wet);
        });
        ui.horizontal(|ui| {
            ui.label("Texture file");
            ui.add(egui::TextEdit::singleline(&mut panel.texture_path).desired_width(170.0))
                .accessible_name("Texture file path");
            if ui.button("Load texture").clicked() {
                panel.load_texture(cx);
            }
        });
        ui.checkbox(
            &mut panel.texture_spiral,
            "Spiral through an image (.png: from its centre out, else its middle row)",
        );
        if ui.ctx().input(|i| !i.raw.hovered_files.is_empty()) {
            ui.colored_label(egui::Color32::from_rgb(255, 190, 60), "Drop a texture file to load it");
        }
        let shown = panel.texture_message.clone().or_else(|| p.user_texture.name().map(|n| format!("User file: {n}")));
        if let Some(m) = shown {
            ui.label(egui::RichText::new(m).weak());
        }
        if p.excitation.value() != crate::params::ExcitationParam::Strike {
            ui.label(
                egui::RichText::new("Held keys keep contact: pressure = force, mod wheel / MPE slide = speed.").weak(),
            );
        }
    });
    egui::CollapsingHeader::new("Material and object").default_open(true).show(ui, |ui| {
        egui::Grid::new("material-knobs").num_columns(2).show(ui, |ui| {
            param_row(ui, setter, &p.decay_scale);
            param_row(ui, setter, &p.support_mode);
            param_row(ui, setter, &p.support_amount_per_s);
            param_row(ui, setter, &p.support_at_point);
            param_row(ui, setter, &p.support_point);
            param_row(ui, setter, &p.modulus_ratio);
            param_row(ui, setter, &p.material_pitch);
            param_row(ui, setter, &p.size);
        });
    });
    egui::CollapsingHeader::new("Keys and pitch").default_open(true).show(ui, |ui| {
        egui::Grid::new("key-knobs").num_columns(2).show(ui, |ui| {
            param_row(ui, setter, &p.key_mode);
            param_row(ui, setter, &p.root_note);
            param_row(ui, setter, &p.key_tuning);
            param_row(ui, setter, &p.pitch_reference);
            param_row(ui, setter, &p.pitch_mode);
            // The chosen mode's label, when the bank names its modes.
            if let Some(label) = logic::object_index(p, lib)
                .and_then(|i| lib.banks.get(i))
                .and_then(|b| b.mode_labels.get((p.pitch_mode.value() - 1).max(0) as usize))
            {
                ui.label("");
                ui.label(egui::RichText::new(format!("mode {}: {label}", p.pitch_mode.value())).weak());
                ui.end_row();
            }
        });
    });
    egui::CollapsingHeader::new("Notes and output").default_open(true).show(ui, |ui| {
        egui::Grid::new("output-knobs").num_columns(2).show(ui, |ui| {
            param_row(ui, setter, &p.release_damping_per_s);
            param_row(ui, setter, &p.pressure_damping_per_s);
            param_row(ui, setter, &p.quality_db);
            param_row(ui, setter, &p.gain_db);
            param_row(ui, setter, &p.normalize_level);
            param_row(ui, setter, &p.output_safety);
        });
    });
}
