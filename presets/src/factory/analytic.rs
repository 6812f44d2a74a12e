//! What the analytic factory banks share: a mode before sorting, a bank's metadata, the
//! assembly into a [`Bank`] and Simpson's rule. The bank modules (`bar`, `circular_plate`,
//! `rect_plate`) import it; the parent module only re-exports them.

use crate::{Bank, BankReference, DrawSurface, StrikePoint, SCHEMA_VERSION};

/// Factory banks keep every mode whose frequency at the reference is at or below this, Hz.
pub const FACTORY_MAX_FREQ_HZ: f64 = 20_000.0;

/// One analytic mode before sorting: eigenvalue, label, and (unnormalised, but mass-
/// normalised in SI) surface-normal shape value at each strike point.
pub(crate) struct Mode {
    pub lambda: f64,
    pub label: String,
    pub shape: Vec<f64>,
}

/// Metadata of a factory bank.
pub(crate) struct BankInfo {
    pub id: &'static str,
    pub name: &'static str,
    pub description: String,
    pub provenance: String,
    pub reference: BankReference,
    /// The object's drawing, in the frame of the strike points' `position_m`.
    pub surface: DrawSurface,
}

/// Sorts modes by λ, drops those above [`FACTORY_MAX_FREQ_HZ`], transposes to
/// `gains[point][mode]` and scales all gains by one factor so that max |gain| = 1.
pub(crate) fn assemble(info: BankInfo, points: Vec<StrikePoint>, mut modes: Vec<Mode>) -> Bank {
    let lambda_max = (2.0 * std::f64::consts::PI * FACTORY_MAX_FREQ_HZ).powi(2);
    modes.retain(|m| m.lambda > 0.0 && m.lambda <= lambda_max);
    modes.sort_by(|a, b| a.lambda.total_cmp(&b.lambda));
    let max = modes.iter().flat_map(|m| m.shape.iter()).fold(0.0f64, |acc, g| acc.max(g.abs()));
    let scale = if max > 0.0 { 1.0 / max } else { 1.0 };
    let gains = (0..points.len()).map(|p| modes.iter().map(|m| (m.shape[p] * scale) as f32).collect()).collect();
    Bank {
        schema_version: SCHEMA_VERSION,
        id: info.id.to_string(),
        name: info.name.to_string(),
        description: info.description,
        provenance: info.provenance,
        reference: info.reference,
        lambdas: modes.iter().map(|m| m.lambda).collect(),
        points,
        gains,
        mode_labels: modes.into_iter().map(|m| m.label).collect(),
        surface: Some(info.surface),
        recorded_strike: None,
    }
}

/// Composite Simpson rule of `f` over [a, b] with `n` (even) intervals.
pub(crate) fn simpson(a: f64, b: f64, n: usize, mut f: impl FnMut(f64) -> f64) -> f64 {
    let n = n + n % 2;
    let h = (b - a) / n as f64;
    let mut sum = f(a) + f(b);
    for k in 1..n {
        let w = if k % 2 == 1 { 4.0 } else { 2.0 };
        sum += w * f(a + h * k as f64);
    }
    sum * h / 3.0
}
