//! What the real-clip tables (`method_table`, `residual_table`) share: the clips folder and
//! `--json` argument, a clip's category, the A/B request for its first impact, the
//! log-spectral distance and the median.

use std::path::PathBuf;

use struck_core::editor::ab::{AbRequest, Side};

/// The WAV files of the folder given as the first argument (sorted) and the `--json OUT`
/// path; exits with `usage` when no folder is given.
pub fn clips(usage: &str) -> (Vec<PathBuf>, Option<String>) {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(dir) = args.first() else {
        eprintln!("usage: {usage}");
        std::process::exit(2);
    };
    let json = args.iter().position(|a| a == "--json").and_then(|i| args.get(i + 1)).cloned();
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| {
            eprintln!("cannot read the clips folder {dir}: {e}");
            std::process::exit(2)
        })
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "wav"))
        .collect();
    files.sort();
    (files, json)
}

/// A clip's file name and category (the name's first word).
pub fn name_and_category(f: &std::path::Path) -> (String, String) {
    let name = f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let category = name.split(['-', '_', '.']).next().unwrap_or("").to_string();
    (name, category)
}

/// The editor's A/B request for `side` of the impact `imp` of `file`, played with `damping`
/// on its own partials (no object), at `rate`.
pub fn ab_request(
    side: Side,
    file: &std::path::Path,
    imp: &estimator::ImpactFeatures,
    damping: dsp::Damping,
    rate: f32,
) -> AbRequest {
    AbRequest {
        side,
        file: file.to_path_buf(),
        onset_s: imp.onset_s,
        duration_s: imp.duration_s.min(1.0),
        features: imp.features.clone(),
        damping,
        object: dsp::ObjectModes::new(vec![1e6], &[vec![1.0]]),
        params: dsp::engine::SoundParams::default(),
        position: 0.5,
        gamma_ratio: None,
        rate,
    }
}

/// Spectrogram frames in the first `seconds` at `rate`.
pub fn frames(seconds: f64, rate: f32) -> usize {
    (seconds * f64::from(rate) / estimator::residual::HOP as f64).round() as usize
}

/// Log-spectral distance, dB, over the first `frames` frames (each side floored 100 dB under
/// the reference's strongest cell).
pub fn lsd(a: &[f32], reference: &[f32], frames: usize) -> f64 {
    use estimator::residual::{power_spectrogram, BINS};
    let f = |x: &[f32]| power_spectrogram(&x.iter().map(|&v| f64::from(v)).collect::<Vec<f64>>());
    let (pa, pr) = (f(a), f(reference));
    let frames = frames.min(pa.frames).min(pr.frames);
    let floor = pr.power.iter().copied().fold(0.0, f64::max) * 1e-10;
    let db = |p: f64| 10.0 * (p + floor).log10();
    let cells = frames * BINS;
    ((0..cells).map(|i| (db(pa.power[i]) - db(pr.power[i])).powi(2)).sum::<f64>() / cells as f64).sqrt()
}

/// The median (the upper one of an even count; NaN when empty).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// Writes the rows as pretty JSON to `out`, saying so on stderr if it cannot.
pub fn write_json(out: &str, rows: &[serde_json::Value]) {
    let text = serde_json::to_string_pretty(rows).unwrap_or_default();
    if let Err(e) = std::fs::write(out, text) {
        eprintln!("cannot write {out}: {e}");
    }
}
