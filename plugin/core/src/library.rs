//! The objects and materials the plugin offers: the factory library, computed once per
//! process (off the audio thread) and shared by every instance.

use dsp::{Damping, ObjectModes};
use presets::{Bank, Material};
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

/// Factory banks and materials, with the engine's view of them.
pub struct Library {
    /// Object banks in parameter order.
    pub banks: Vec<Bank>,
    /// Materials in parameter order (the parameter's last value, one past these, is *Custom*).
    pub materials: Vec<Material>,
    /// Each material's damping law (validated).
    pub dampings: Vec<Damping>,
    /// Problems met loading user banks (each names the file); such banks are left out. A
    /// bank with fields Struck does not read is listed, and the fields are noted here.
    pub load_errors: Vec<String>,
    /// The user banks listed with fields Struck does not read: (bank id, the note of
    /// [`load_errors`](Self::load_errors)), so playing one can say so.
    pub unknown_fields: Vec<(String, String)>,
}

/// Most lift [`recorded_strike_factors`] gives a mode, dB: the range `struck bank capture`
/// keeps by default, so a partial the assumed strike all but missed is not raised out of
/// proportion (over it the recording plays darker than recorded with that strike).
pub const MAX_STRIKE_LIFT_DB: f64 = 40.0;

/// The engine's object for `bank`: its eigenvalues and the gains it plays ([`played_gains`]).
/// Allocates.
pub fn engine_object(bank: &Bank) -> ObjectModes {
    ObjectModes::new(bank.lambdas.clone(), &played_gains(bank))
}

/// The gains the engine plays for `bank`, `[point][mode]`: its own, or for a bank captured
/// from a recording (`recorded_strike`), the recorded amplitudes times
/// [`recorded_strike_factors`], so the strike that made the recording, played at the
/// recorded pitch, sounds the recorded balance instead of that strike's spectrum twice.
pub fn played_gains(bank: &Bank) -> Vec<Vec<f32>> {
    match recorded_strike_factors(bank) {
        Some(k) => bank
            .gains
            .iter()
            .map(|row| row.iter().zip(&k).map(|(&g, &k)| (f64::from(g) * k) as f32).collect())
            .collect(),
        None => bank.gains.clone(),
    }
}

/// Per mode of a bank captured from a recording, the factor that takes its recorded amplitude
/// aᵢ = |F(fᵢ)|·φᵢ back to the mode's own gain φᵢ: 1/|F(fᵢ)|, F the unit-area force pulse of
/// the bank's `recorded_strike` (that mallet on the bank's reference material, E = γ₀ρ, at
/// that hardness and velocity, as the engine strikes; [`dsp::exciter::pulse_spectrum`]) at
/// the mode's undamped frequency √λ/2π, lifting at most [`MAX_STRIKE_LIFT_DB`]; scaled so the
/// largest played |gain| is 1. `None` for a bank without a recorded strike (mode shapes).
pub fn recorded_strike_factors(bank: &Bank) -> Option<Vec<f64>> {
    use dsp::exciter::{hardness_scale, pulse_spectrum, strike_speed, MalletKind};
    let strike = bank.recorded_strike.as_ref()?;
    let kind = MalletKind::ALL.into_iter().find(|k| k.name().eq_ignore_ascii_case(&strike.mallet))?;
    let modulus = bank.reference.specific_modulus * bank.reference.density;
    let mallet = kind.mallet().on_object(modulus);
    let velocity = f32::from(strike.velocity.clamp(1, 127)) / 127.0;
    let contact = mallet.contact_time_s(strike_speed(velocity), hardness_scale(strike.hardness as f32));
    let floor = 10f64.powf(-MAX_STRIKE_LIFT_DB / 20.0);
    let mut k: Vec<f64> = bank
        .lambdas
        .iter()
        .map(|&l| 1.0 / pulse_spectrum(l.max(0.0).sqrt() / std::f64::consts::TAU, contact, mallet.skew).max(floor))
        .collect();
    let peak = bank
        .gains
        .iter()
        .flat_map(|row| row.iter().zip(&k).map(|(&g, &k)| f64::from(g).abs() * k))
        .fold(0.0f64, f64::max);
    if !(peak.is_finite() && peak > 0.0) {
        return None;
    }
    k.iter_mut().for_each(|v| *v /= peak);
    Some(k)
}

/// The folder user banks are listed from: `$STRUCK_BANK_DIR`, else `banks` beside the user
/// materials folder (Linux `~/.local/share/struck/banks`, macOS
/// `~/Library/Application Support/Struck/banks`, Windows `%APPDATA%\Struck\banks`).
pub fn user_bank_dir() -> PathBuf {
    match std::env::var_os("STRUCK_BANK_DIR") {
        Some(d) => PathBuf::from(d),
        None => user_material_dir().with_file_name("banks"),
    }
}

/// The default material's id (it rings, and is a measured one).
pub const DEFAULT_MATERIAL: &str = "glass-ren2013";

impl Library {
    /// The factory library plus the banks in [`user_bank_dir`] (computed on first use, then
    /// shared by every instance in the process).
    pub fn factory() -> Arc<Library> {
        static LIB: OnceLock<Arc<Library>> = OnceLock::new();
        LIB.get_or_init(|| Arc::new(Library::load(Some(&user_bank_dir())))).clone()
    }

    /// Factory banks and materials, then every `*.json` bank in `user_banks` (sorted by file
    /// name). A user bank that fails to load, or repeats an id already listed, is left out
    /// and reported in [`load_errors`](Self::load_errors); it never stops the others. A user
    /// bank with fields Struck does not read is listed, and noted there and in
    /// [`unknown_fields`](Self::unknown_fields).
    pub fn load(user_banks: Option<&Path>) -> Library {
        let mut banks = presets::factory_banks();
        let mut load_errors = Vec::new();
        let mut unknown_fields = Vec::new();
        if let Some(dir) = user_banks {
            if let Ok(entries) = std::fs::read_dir(dir) {
                let mut files: Vec<PathBuf> = entries
                    .filter_map(|e| e.ok().map(|e| e.path()))
                    .filter(|p| p.extension().is_some_and(|x| x == "json"))
                    .collect();
                files.sort();
                for f in files {
                    match Bank::load_listing_unknown(&f) {
                        Ok((b, _)) if banks.iter().any(|x| x.id == b.id) => load_errors.push(format!(
                            "{}: skipped: a bank with id '{}' is already listed; rename its id",
                            f.display(),
                            b.id
                        )),
                        Ok((b, unknown)) => {
                            // Listed, and the fields Struck does not read said (a misspelt
                            // field plays its default).
                            if let Some(note) = presets::unknown_fields_note(&unknown) {
                                let note = format!("{}: {note}", f.display());
                                load_errors.push(note.clone());
                                unknown_fields.push((b.id.clone(), note));
                            }
                            banks.push(b);
                        }
                        Err(e) => load_errors.push(format!("{}: skipped: {e}", f.display())),
                    }
                }
            }
        }
        let mut materials = Vec::new();
        let mut dampings = Vec::new();
        for m in presets::factory_materials() {
            // Factory materials are validated by presets' tests; a bad one would be skipped
            // rather than crash a host.
            if let Ok(d) = m.damping.to_damping() {
                materials.push(m);
                dampings.push(d);
            }
        }
        Library { banks, materials, dampings, load_errors, unknown_fields }
    }

    /// This library with `bank` (read from a file) added after the others; a bank whose id is
    /// already listed replaces that one, so a rebuilt factory or user bank plays as built.
    pub fn with_bank(&self, bank: Bank) -> Library {
        // (The bank read from a file replaces a listed one with its id, and that one's note.)
        let unknown_fields = self.unknown_fields.iter().filter(|(id, _)| *id != bank.id).cloned().collect();
        let mut banks = self.banks.clone();
        match banks.iter().position(|b| b.id == bank.id) {
            Some(i) => banks[i] = bank,
            None => banks.push(bank),
        }
        Library {
            banks,
            materials: self.materials.clone(),
            dampings: self.dampings.clone(),
            load_errors: self.load_errors.clone(),
            unknown_fields,
        }
    }

    /// Index of the bank with `id`, if any.
    pub fn bank_index(&self, id: &str) -> Option<usize> {
        self.banks.iter().position(|b| b.id == id)
    }

    /// Index of the material with `id`, if any.
    pub fn material_index(&self, id: &str) -> Option<usize> {
        self.materials.iter().position(|m| m.id == id)
    }

    /// The material selected by default.
    pub fn default_material_index(&self) -> usize {
        self.material_index(DEFAULT_MATERIAL).unwrap_or(0)
    }

    /// Value of the material parameter that selects the *Custom* knobs.
    pub fn custom_material_index(&self) -> usize {
        self.materials.len()
    }

    /// The engine's objects, one per bank ([`engine_object`]). Allocates.
    pub fn object_modes(&self) -> Vec<ObjectModes> {
        self.banks.iter().map(engine_object).collect()
    }

    /// The specific-modulus ratio a material implies on a bank (1 when unknown).
    pub fn material_modulus_ratio(&self, material: usize, bank: usize) -> f64 {
        match (self.materials.get(material).and_then(|m| m.specific_modulus), self.banks.get(bank)) {
            (Some(g), Some(b)) if g > 0.0 && b.reference.specific_modulus > 0.0 => g / b.reference.specific_modulus,
            _ => 1.0,
        }
    }
}

/// One material file in the user folder ([`scan_user_materials`]).
pub struct UserMaterial {
    /// The file.
    pub path: PathBuf,
    /// The material, or why it does not load (one line).
    pub material: Result<Material, String>,
    /// The fields the file has that Struck does not read, in words (none: `None`).
    pub unknown: Option<String>,
}

/// Lists `dir`'s `.json` materials, sorted by file name (the editor's user list and `struck
/// materials`).
pub fn scan_user_materials(dir: &Path) -> Vec<UserMaterial> {
    let mut out: Vec<UserMaterial> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")))
                .map(|path| match Material::load_listing_unknown(&path) {
                    Ok((m, unknown)) => {
                        UserMaterial { material: Ok(m), unknown: presets::unknown_fields_note(&unknown), path }
                    }
                    Err(e) => UserMaterial { material: Err(e.to_string()), unknown: None, path },
                })
                .collect()
        })
        .unwrap_or_default();
    out.sort_by(|a, b| a.path.cmp(&b.path));
    out
}

/// The folder user materials are saved to and listed from: `$STRUCK_USER_DIR`, else
/// `$XDG_DATA_HOME/struck/materials`, `~/.local/share/struck/materials` (Linux),
/// `~/Library/Application Support/Struck/materials` (macOS), `%APPDATA%\Struck\materials`.
pub fn user_material_dir() -> std::path::PathBuf {
    use std::path::PathBuf;
    if let Some(d) = std::env::var_os("STRUCK_USER_DIR") {
        return PathBuf::from(d);
    }
    if cfg!(target_os = "windows") {
        if let Some(a) = std::env::var_os("APPDATA") {
            return PathBuf::from(a).join("Struck").join("materials");
        }
    }
    let home = std::env::var_os("HOME").map(PathBuf::from).unwrap_or_else(std::env::temp_dir);
    if cfg!(target_os = "macos") {
        return home.join("Library/Application Support/Struck/materials");
    }
    match std::env::var_os("XDG_DATA_HOME") {
        Some(x) if !x.is_empty() => PathBuf::from(x).join("struck/materials"),
        _ => home.join(".local/share/struck/materials"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every mallet name a bank's recorded strike takes is one the plugin plays, in the
    /// *Mallet* parameter's order; a bank without a recorded strike plays its gains as they
    /// are, and one with it plays φᵢ = aᵢ/|F(fᵢ)|: the mallet's force spectrum at a mode,
    /// times its played gain, gives back the recorded amplitude (a 40 dB lift at most).
    #[test]
    fn a_recorded_strike_is_divided_out_of_the_played_gains() {
        use dsp::exciter::{hardness_scale, pulse_spectrum, strike_speed, MalletKind};
        let names: Vec<String> = MalletKind::ALL.iter().map(|k| k.name().to_lowercase()).collect();
        assert_eq!(names, presets::MALLET_NAMES);
        for b in presets::factory_banks() {
            assert!(recorded_strike_factors(&b).is_none(), "{}", b.id);
            assert_eq!(played_gains(&b), b.gains);
        }
        let mut bank = presets::factory_bank("bar").unwrap();
        bank.gains.truncate(1);
        bank.points.truncate(1);
        bank.recorded_strike = Some(presets::RecordedStrike { mallet: "felt".into(), hardness: 0.2, velocity: 40 });
        let played = played_gains(&bank);
        let peak = played[0].iter().fold(0.0f32, |m, g| m.max(g.abs()));
        assert!((peak - 1.0).abs() < 1e-6, "{peak}");
        let mallet = MalletKind::Felt.mallet();
        let t = mallet.contact_time_s(strike_speed(40.0 / 127.0), hardness_scale(0.2));
        // Recorded amplitude over played gain: the spectrum, up to one common scale.
        let ratio: Vec<f64> = (0..bank.num_modes())
            .filter(|&m| bank.gains[0][m].abs() > 1e-3)
            .map(|m| {
                let f = bank.lambdas[m].sqrt() / std::f64::consts::TAU;
                let heard = pulse_spectrum(f, t, mallet.skew).max(0.01);
                f64::from(played[0][m]) * heard / f64::from(bank.gains[0][m])
            })
            .collect();
        assert!(ratio.len() > 5);
        for r in &ratio {
            assert!((r / ratio[0] - 1.0).abs() < 1e-4, "{ratio:?}");
        }
        // The felt at hardness 0.2 and velocity 40 is soft: the top modes are lifted.
        let top = bank.num_modes() - 1;
        assert!(played[0][top].abs() / played[0][0].abs() > 10.0 * bank.gains[0][top].abs() / bank.gains[0][0].abs());
    }

    #[test]
    fn user_banks_are_listed_and_broken_ones_reported() {
        let dir = std::env::temp_dir().join(format!("struck-user-banks-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut good = presets::factory_bank("bar").unwrap();
        good.id = "my-bar".into();
        good.name = "My bar".into();
        good.save(&dir.join("a-good.json")).unwrap();
        std::fs::write(dir.join("b-broken.json"), "{ not a bank").unwrap();
        let dup = presets::factory_bank("rect-plate").unwrap();
        std::fs::write(dir.join("c-dup.json"), dup.to_json()).unwrap();
        // A misspelt field: listed, and said.
        good.id = "my-other-bar".into();
        let text = good.to_json().replacen("\"points\"", "\"pionts\": [], \"points\"", 1);
        std::fs::write(dir.join("d-typo.json"), text).unwrap();
        let lib = Library::load(Some(&dir));
        let factory = presets::factory_banks().len();
        assert_eq!(lib.banks.len(), factory + 2);
        assert_eq!(lib.banks[factory].id, "my-bar");
        assert_eq!(lib.banks[factory + 1].id, "my-other-bar");
        assert_eq!(lib.load_errors.len(), 3, "{:?}", lib.load_errors);
        assert!(lib.load_errors[0].contains("b-broken.json"));
        assert!(lib.load_errors[1].contains("already listed"));
        assert!(lib.load_errors[2].contains("d-typo.json") && lib.load_errors[2].contains("`pionts`"));
        assert_eq!(lib.unknown_fields, [("my-other-bar".to_string(), lib.load_errors[2].clone())]);
        // A clean bank file with that id replaces it, note and all.
        assert!(lib.with_bank(good.clone()).unknown_fields.is_empty());
        assert_eq!(lib.with_bank(dup).unknown_fields.len(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
