//! Object banks: the modes (λᵢ⁰, gains at strike points) of one object at a reference
//! material and size.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::Shown;
use crate::json;
use crate::PresetError;

/// Most modes a bank may hold (guards against absurd files; factory banks have ~100–300).
pub const MAX_BANK_MODES: usize = 4096;
/// Most strike points a bank may hold.
pub const MAX_BANK_POINTS: usize = 1024;
/// Tolerance above 1 accepted for |gain| (f32 round-off of the normalisation).
const GAIN_TOLERANCE: f32 = 1e-4;
/// Most triangles of a bank's drawing surface (a coarse picture, not the FEM mesh).
pub const MAX_DRAW_TRIANGLES: usize = 20_000;

/// A coarse closed triangulated surface of the reference object, for drawing it: vertices
/// in metres in the frame of the strike points' `position_m`, triangles wound
/// counter-clockwise seen from outside (outward normals).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq, Default)]
pub struct DrawSurface {
    /// Vertex positions, metres.
    pub vertices: Vec<[f32; 3]>,
    /// Vertex indices of each triangle, outward winding.
    pub triangles: Vec<[u32; 3]>,
}

impl DrawSurface {
    /// The surface of the box `min`..`max`, two triangles per face.
    pub fn cuboid(min: [f64; 3], max: [f64; 3]) -> DrawSurface {
        let v = |i: usize| {
            [
                (if i & 1 == 0 { min[0] } else { max[0] }) as f32,
                (if i & 2 == 0 { min[1] } else { max[1] }) as f32,
                (if i & 4 == 0 { min[2] } else { max[2] }) as f32,
            ]
        };
        // Quads (counter-clockwise from outside): -z, +z, -y, +y, -x, +x.
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let triangles = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        DrawSurface { vertices: (0..8).map(v).collect(), triangles }
    }

    /// The surface of a disc of `radius` about the z axis between `z0` and `z1`, with
    /// `segments` around.
    pub fn disc(radius: f64, z0: f64, z1: f64, segments: usize) -> DrawSurface {
        let n = segments.max(3);
        let mut vertices = vec![[0.0, 0.0, z0 as f32], [0.0, 0.0, z1 as f32]];
        for k in 0..n {
            let a = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
            let (x, y) = ((radius * a.cos()) as f32, (radius * a.sin()) as f32);
            vertices.push([x, y, z0 as f32]);
            vertices.push([x, y, z1 as f32]);
        }
        let mut triangles = Vec::with_capacity(4 * n);
        for k in 0..n {
            let (b0, t0) = (2 + 2 * k as u32, 3 + 2 * k as u32);
            let (b1, t1) = (2 + 2 * ((k + 1) % n) as u32, 3 + 2 * ((k + 1) % n) as u32);
            triangles.push([0, b1, b0]);
            triangles.push([1, t0, t1]);
            triangles.push([b0, b1, t1]);
            triangles.push([b0, t1, t0]);
        }
        DrawSurface { vertices, triangles }
    }

    /// The volume enclosed (divergence theorem; positive for outward winding), m³.
    pub fn volume(&self) -> f64 {
        let p = |i: u32| self.vertices[i as usize].map(f64::from);
        self.triangles
            .iter()
            .map(|t| {
                let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]))
                    / 6.0
            })
            .sum()
    }

    fn validate(&self) -> Result<(), PresetError> {
        if self.triangles.is_empty() || self.triangles.len() > MAX_DRAW_TRIANGLES {
            return Err(PresetError::invalid(
                "surface.triangles",
                format!("{} triangles; a drawing has 1 to {MAX_DRAW_TRIANGLES}", self.triangles.len()),
            ));
        }
        if self.vertices.len() > 3 * MAX_DRAW_TRIANGLES {
            return Err(PresetError::invalid(
                "surface.vertices",
                format!("{} vertices; a drawing has at most {}", self.vertices.len(), 3 * MAX_DRAW_TRIANGLES),
            ));
        }
        if let Some(i) = self.vertices.iter().position(|v| !v.iter().all(|x| x.is_finite() && x.abs() <= 1e3)) {
            return Err(PresetError::invalid(format!("surface.vertices[{i}]"), "must be finite metres within ±1000 m"));
        }
        let n = self.vertices.len();
        if let Some(i) = self.triangles.iter().position(|t| t.iter().any(|&k| k as usize >= n)) {
            return Err(PresetError::invalid(
                format!("surface.triangles[{i}]"),
                format!("vertex index out of range (there are {n} vertices)"),
            ));
        }
        Ok(())
    }
}

/// One place where the object can be struck.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct StrikePoint {
    /// Short display label, e.g. `"x = 0.10 L"`.
    pub label: String,
    /// Drawing coordinates in [0, 1]² for the editor (how they map onto the object is in the
    /// bank's `description`).
    pub xy: [f32; 2],
    /// Position on the reference object in metres (frame in the bank's `description`).
    pub position_m: [f32; 3],
}

/// The reference object the bank's eigenvalues were computed for.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct BankReference {
    /// γ₀ = E/ρ of the reference material, m²/s². λ scales by γ/γ₀ (Ren 2013 eq. 10).
    pub specific_modulus: f64,
    /// Poisson's ratio ν of the reference material (λ scaling assumes it fixed).
    pub poisson: f64,
    /// Density of the reference material, kg/m³ (informative).
    pub density: f64,
    /// Shape-specific dimensions in metres, documented in the bank's `description`.
    pub dimensions_m: Vec<f64>,
    /// Characteristic length in metres: size s = 1 means `dimensions_m`; λ scales by 1/s².
    pub size_m: f64,
}

/// A modal bank: eigenvalues and per-strike-point gains of one object.
///
/// Conventions: λ = ω² in rad²/s² at the reference material and size; the gains are the
/// surface-normal, mass-normalised mode shapes at each strike point, all scaled by one
/// common factor so that max |gain| = 1.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Bank {
    /// Format version; must equal [`crate::SCHEMA_VERSION`].
    pub schema_version: u32,
    /// Stable kebab-case identifier, e.g. `"circular-plate"`.
    pub id: String,
    /// Display name.
    pub name: String,
    /// What the object is, its dimensions, and how `xy` / `position_m` map onto it.
    pub description: String,
    /// Where the modes come from (formula, book, section).
    pub provenance: String,
    /// The reference material and dimensions.
    pub reference: BankReference,
    /// λᵢ⁰ in rad²/s² at the reference, ascending (non-decreasing), all finite and > 0.
    pub lambdas: Vec<f64>,
    /// Strike points ordered along a path so that neighbours are close: the plugin's strike
    /// position 0..1 interpolates linearly along this order.
    pub points: Vec<StrikePoint>,
    /// `gains[point][mode]`: mode shape at that point, max |gain| over the bank = 1.
    pub gains: Vec<Vec<f32>>,
    /// One label per mode (e.g. `"bend 3"`, `"(m,n)=(0,2)"`), or empty.
    #[serde(default)]
    pub mode_labels: Vec<String>,
    /// A coarse surface of the reference object for the editor's drawing (optional).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub surface: Option<DrawSurface>,
    /// How the recording a captured bank was taken from was struck (`struck bank capture`),
    /// when its gains are that recording's amplitudes: they carry that strike's force
    /// spectrum, which the player divides out so that the same strike plays the recording's
    /// balance (optional; absent for banks of mode shapes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recorded_strike: Option<RecordedStrike>,
}

/// The mallet names a [`RecordedStrike`] takes, softest first (the plugin's *Mallet* choices).
pub const MALLET_NAMES: [&str; 6] = ["felt", "rubber", "wood", "plastic", "brass", "steel"];

/// The strike that made a recording, as the plugin would play it: the mallet, its hardness
/// and the note's velocity. A captured bank's gains are the recorded amplitudes aᵢ = |F(fᵢ)|·φᵢ,
/// F the force pulse's spectrum; the player takes φᵢ = aᵢ / |F(fᵢ)| with F of this strike on
/// the bank's reference material, so this strike at the recorded pitch sounds the recorded
/// balance and any other mallet, hardness or velocity changes it as it would on the object.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct RecordedStrike {
    /// One of [`MALLET_NAMES`].
    pub mallet: String,
    /// *Mallet hardness*, 0..=1 (0.5: the mallet as made).
    pub hardness: f64,
    /// MIDI velocity, 1..=127.
    pub velocity: u8,
}

impl RecordedStrike {
    /// Checks the fields (names the field on error).
    ///
    /// # Errors
    /// An unknown mallet, a hardness outside 0..=1, a velocity outside 1..=127.
    pub fn validate(&self) -> Result<(), PresetError> {
        if !MALLET_NAMES.contains(&self.mallet.as_str()) {
            return Err(PresetError::invalid(
                "recorded_strike.mallet",
                format!("unknown mallet '{}' (known: {})", self.mallet, MALLET_NAMES.join(", ")),
            ));
        }
        if !(self.hardness.is_finite() && (0.0..=1.0).contains(&self.hardness)) {
            return Err(PresetError::invalid(
                "recorded_strike.hardness",
                format!("must be from 0 to 1, found {}", Shown(self.hardness)),
            ));
        }
        if !(1..=127).contains(&self.velocity) {
            return Err(PresetError::invalid(
                "recorded_strike.velocity",
                format!("must be a MIDI velocity from 1 to 127, found {}", self.velocity),
            ));
        }
        Ok(())
    }
}

impl Bank {
    /// Number of modes.
    pub fn num_modes(&self) -> usize {
        self.lambdas.len()
    }

    /// Each mode's largest |gain| over the strike points: how strongly it can be excited
    /// anywhere (0 for modes no strike point reaches).
    pub fn max_gains(&self) -> Vec<f64> {
        let mut g = vec![0.0f64; self.lambdas.len()];
        for row in &self.gains {
            for (m, &v) in g.iter_mut().zip(row) {
                *m = m.max(f64::from(v.abs()));
            }
        }
        g
    }

    /// Number of strike points.
    pub fn num_points(&self) -> usize {
        self.points.len()
    }

    /// Undamped mode frequencies sqrt(λ)/(2π) in Hz at the reference.
    pub fn frequencies_hz(&self) -> Vec<f64> {
        self.lambdas.iter().map(|l| l.sqrt() / (2.0 * std::f64::consts::PI)).collect()
    }

    /// Eigenvalues in rad²/s² for a material of specific modulus `specific_modulus` (m²/s²)
    /// and size `size` relative to the reference: λ = (γ/γ₀) λ⁰ / s² (Ren 2013 eq. 10;
    /// uniform scaling of every dimension by s scales λ by 1/s²).
    pub fn scaled_lambdas(&self, specific_modulus: f64, size: f64) -> Vec<f64> {
        let k = specific_modulus / self.reference.specific_modulus / (size * size);
        self.lambdas.iter().map(|l| l * k).collect()
    }

    /// Writes into `out` the gains at strike `position` in 0..=1, interpolated linearly
    /// between neighbouring strike points (0 = first point, 1 = last). Only
    /// `min(out.len(), num_modes)` entries are written.
    ///
    /// # Realtime safety
    /// No allocation.
    pub fn gains_at(&self, position: f32, out: &mut [f32]) {
        let n = self.gains.len();
        if n == 0 {
            return;
        }
        let t = if position.is_finite() { position.clamp(0.0, 1.0) } else { 0.0 } * (n - 1) as f32;
        // `t` is in 0..=n−1, so the floor fits and `i` is a valid index.
        let i = (t.floor() as usize).min(n.saturating_sub(2));
        let frac = if n == 1 { 0.0 } else { t - i as f32 };
        let a = &self.gains[i];
        let b = &self.gains[(i + 1).min(n - 1)];
        for ((o, &ga), &gb) in out.iter_mut().zip(a).zip(b) {
            // Written so that frac = 0 and frac = 1 reproduce the rows exactly.
            *o = ga * (1.0 - frac) + gb * frac;
        }
    }

    /// Scales all gains by one factor so that max |gain| = 1 (no-op if all are zero).
    pub fn normalize_gains(&mut self) {
        let max = self.gains.iter().flatten().fold(0.0f32, |m, g| m.max(g.abs()));
        if max > 0.0 && max.is_finite() {
            for g in self.gains.iter_mut().flatten() {
                *g /= max;
            }
        }
    }

    /// Parses a bank from JSON and validates it.
    ///
    /// # Errors
    /// [`PresetError::Json`] for malformed JSON or missing/mistyped fields,
    /// [`PresetError::SchemaVersion`] for another format version, and
    /// [`PresetError::Invalid`] for values [`Bank::validate`] rejects.
    pub fn from_json(s: &str) -> Result<Bank, PresetError> {
        json::parse_valid(s, "bank", &mut Vec::new())
    }

    /// [`Bank::from_json`], and the fields the text has that this version does not read (JSON
    /// paths such as `damping.parms`: a misspelt name, or a field of a newer Struck), which
    /// `from_json` ignores ([`crate::unknown_fields_note`] words them for a warning).
    ///
    /// # Errors
    /// As [`Bank::from_json`].
    pub fn from_json_listing_unknown(s: &str) -> Result<(Bank, Vec<String>), PresetError> {
        let mut unknown = Vec::new();
        json::parse_valid(s, "bank", &mut unknown).map(|v| (v, unknown))
    }

    /// Pretty-printed JSON (with a trailing newline). Does not validate.
    pub fn to_json(&self) -> String {
        json::to_pretty(self)
    }

    /// Reads and validates a bank file.
    ///
    /// # Errors
    /// [`PresetError::Io`] naming `path` if it cannot be read; otherwise as
    /// [`Bank::from_json`], with the path in [`PresetError::Json`]'s `what`.
    pub fn load(path: &Path) -> Result<Bank, PresetError> {
        json::load(path, &mut Vec::new())
    }

    /// [`Bank::load`], and the fields the file has that this version does not read
    /// ([`Bank::from_json_listing_unknown`]).
    ///
    /// # Errors
    /// As [`Bank::load`].
    pub fn load_listing_unknown(path: &Path) -> Result<(Bank, Vec<String>), PresetError> {
        let mut unknown = Vec::new();
        json::load(path, &mut unknown).map(|v| (v, unknown))
    }

    /// Validates, then writes pretty JSON to `path` (through a temporary file and a rename).
    ///
    /// # Errors
    /// As [`Bank::validate`] (nothing is written), or [`PresetError::Output`] naming `path`
    /// (an existing file is then untouched).
    pub fn save(&self, path: &Path) -> Result<(), PresetError> {
        json::save(self, path)
    }

    /// Checks every field.
    ///
    /// # Errors
    /// [`PresetError::SchemaVersion`] for another `schema_version`; otherwise
    /// [`PresetError::Invalid`] naming the field for: an id that is not kebab-case; a blank
    /// name; reference values that are not finite and > 0 (Poisson's ratio must be in
    /// (−1, 0.5)); no modes or more than [`MAX_BANK_MODES`]; a λ that is NaN, infinite or
    /// ≤ 0, or smaller than the one before; no strike points or more than
    /// [`MAX_BANK_POINTS`]; non-finite or out-of-[0, 1] `xy`; non-finite `position_m`; a
    /// gains matrix that is not points × modes; non-finite gains, |gain| > 1, or all gains
    /// zero; `mode_labels` neither empty nor one per mode; a `surface` with no or more than
    /// [`MAX_DRAW_TRIANGLES`] triangles, more than 3 × that many vertices, vertices not finite or
    /// beyond ±1000 m, or indices out of range.
    pub fn validate(&self) -> Result<(), PresetError> {
        json::check_version(self.schema_version)?;
        json::check_id(&self.id)?;
        json::check_name(&self.name)?;
        self.validate_reference()?;

        let n_modes = self.lambdas.len();
        if n_modes == 0 {
            return Err(PresetError::invalid(
                "lambdas",
                "the bank has no modes; add at least one eigenvalue (rad^2/s^2)",
            ));
        }
        if n_modes > MAX_BANK_MODES {
            return Err(PresetError::invalid(
                "lambdas",
                format!("{n_modes} modes; at most {MAX_BANK_MODES} are supported"),
            ));
        }
        let mut previous = 0.0;
        for (i, &l) in self.lambdas.iter().enumerate() {
            let field = format!("lambdas[{i}]");
            if !l.is_finite() || l <= 0.0 {
                return Err(PresetError::invalid(
                    field,
                    format!("eigenvalues must be finite and > 0 (rad^2/s^2), found {}", Shown(l)),
                ));
            }
            if l < previous {
                return Err(PresetError::invalid(
                    field,
                    format!("eigenvalues must be in ascending order, but {} follows {}; sort the modes (and their gains) by lambda", Shown(l), Shown(previous)),
                ));
            }
            previous = l;
        }

        let n_points = self.points.len();
        if n_points == 0 {
            return Err(PresetError::invalid("points", "the bank has no strike points; add at least one"));
        }
        if n_points > MAX_BANK_POINTS {
            return Err(PresetError::invalid(
                "points",
                format!("{n_points} strike points; at most {MAX_BANK_POINTS} are supported"),
            ));
        }
        for (i, p) in self.points.iter().enumerate() {
            if !p.xy.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)) {
                return Err(PresetError::invalid(
                    format!("points[{i}].xy"),
                    format!("drawing coordinates must be in [0, 1], found {:?}", p.xy),
                ));
            }
            if !p.position_m.iter().all(|v| v.is_finite()) {
                return Err(PresetError::invalid(
                    format!("points[{i}].position_m"),
                    format!("must be finite metres, found {:?}", p.position_m),
                ));
            }
        }

        if self.gains.len() != n_points {
            return Err(PresetError::invalid(
                "gains",
                format!("must have one row per strike point: {n_points} points but {} rows", self.gains.len()),
            ));
        }
        let mut max = 0.0f32;
        for (p, row) in self.gains.iter().enumerate() {
            if row.len() != n_modes {
                return Err(PresetError::invalid(
                    format!("gains[{p}]"),
                    format!("must have one gain per mode: {n_modes} modes but {} gains", row.len()),
                ));
            }
            for (m, &g) in row.iter().enumerate() {
                if !g.is_finite() {
                    return Err(PresetError::invalid(
                        format!("gains[{p}][{m}]"),
                        format!("must be finite, found {}", Shown(f64::from(g))),
                    ));
                }
                if g.abs() > 1.0 + GAIN_TOLERANCE {
                    return Err(PresetError::invalid(
                        format!("gains[{p}][{m}]"),
                        format!(
                            "|gain| must be <= 1 (gains are normalised so the largest is 1), found {}",
                            Shown(f64::from(g))
                        ),
                    ));
                }
                max = max.max(g.abs());
            }
        }
        if max == 0.0 {
            return Err(PresetError::invalid("gains", "all gains are zero: the bank would be silent"));
        }

        if let Some(surface) = &self.surface {
            surface.validate()?;
        }
        if let Some(strike) = &self.recorded_strike {
            strike.validate()?;
        }
        if !self.mode_labels.is_empty() && self.mode_labels.len() != n_modes {
            return Err(PresetError::invalid(
                "mode_labels",
                format!(
                    "must be empty or have one label per mode: {n_modes} modes but {} labels",
                    self.mode_labels.len()
                ),
            ));
        }
        Ok(())
    }

    fn validate_reference(&self) -> Result<(), PresetError> {
        let r = &self.reference;
        let positive = |field: &str, v: f64, unit: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(PresetError::invalid(
                    format!("reference.{field}"),
                    format!("must be finite and > 0 ({unit}), found {}", Shown(v)),
                ))
            }
        };
        positive("specific_modulus", r.specific_modulus, "E/rho in m^2/s^2")?;
        positive("density", r.density, "kg/m^3")?;
        positive("size_m", r.size_m, "m")?;
        if !(r.poisson.is_finite() && r.poisson > -1.0 && r.poisson < 0.5) {
            return Err(PresetError::invalid(
                "reference.poisson",
                format!("Poisson's ratio must be in (-1, 0.5), found {}", Shown(r.poisson)),
            ));
        }
        for (i, &d) in r.dimensions_m.iter().enumerate() {
            positive(&format!("dimensions_m[{i}]"), d, "m")?;
        }
        Ok(())
    }
}

impl json::PresetFile for Bank {
    fn validate(&self) -> Result<(), PresetError> {
        Bank::validate(self)
    }
}
