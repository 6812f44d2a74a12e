//! Issue 15's real-recording table: on each clip, the editor's A/B clips of its first
//! impact — the recording (A), its modes with the fitted law (*B: modes*) and those modes
//! plus the transferred residual (*B: modes + residual*) — and the log-spectral distance
//! of each B to A over the attack (the first 50 ms) and over the first 350 ms.
//!
//! `cargo run --release -p struck-core --example residual_table -- CLIPS_DIR [--json OUT]`
//! (clips: `tests/recordings/fetch.py`'s `CACHE/clips`; the category is the file name's
//! first word).

use std::sync::atomic::AtomicBool;
use struck_core::editor::ab::{build, Side};

mod common;
use common::{ab_request, clips, frames, lsd, median, name_and_category, write_json};

/// Ren's image-domain metric (§5.2.1, eq. 19) of `a` against `reference` over their first
/// `seconds`: loudness in half-Bark bands, both calibrated by the reference's image.
fn psycho(a: &[f32], reference: &[f32], rate: f32, seconds: f64) -> f64 {
    use estimator::psycho::{psycho_distance, PsychoSpace};
    let space = PsychoSpace::new(f64::from(rate));
    let frames = space.frames_for(seconds);
    let image = |x: &[f32]| space.image_of_signal(&x.iter().map(|&v| f64::from(v)).collect::<Vec<f64>>(), frames);
    let r = image(reference);
    let scale = PsychoSpace::calibration(&r);
    let (mut la, mut lr) = (Vec::new(), Vec::new());
    space.loudness(&image(a), scale, &mut la);
    space.loudness(&r, scale, &mut lr);
    psycho_distance(&la, &lr)
}

/// Clip, category, LSD over the attack (modes, modes + residual), over 350 ms (the same),
/// Ren's Π_psycho over 350 ms (the same).
type Row = (String, String, f64, f64, f64, f64, f64, f64);

fn main() {
    let (files, json) = clips("residual_table CLIPS_DIR [--json OUT]");
    let rate = 48_000.0f32;
    let mut rows: Vec<Row> = Vec::new();
    for f in &files {
        let (name, category) = name_and_category(f);
        let report = match estimator::estimate(
            std::slice::from_ref(f),
            &estimator::Options::default(),
            &|_| {},
            &AtomicBool::new(false),
        ) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("{name}: {e}");
                continue;
            }
        };
        let Some(imp) = report.impacts.first() else { continue };
        let req = |side| ab_request(side, f, imp, report.damping(), rate);
        let (Ok(a), Ok(m), Ok(mr)) =
            (build(&req(Side::Recording)), build(&req(Side::Modes)), build(&req(Side::ModesResidual)))
        else {
            eprintln!("{name}: a clip failed");
            continue;
        };
        let (attack, long) = (frames(0.05, rate), frames(0.35, rate));
        let row = (
            name.clone(),
            category,
            lsd(&m, &a, attack),
            lsd(&mr, &a, attack),
            lsd(&m, &a, long),
            lsd(&mr, &a, long),
            psycho(&m, &a, rate, 0.35),
            psycho(&mr, &a, rate, 0.35),
        );
        println!(
            "{name}: attack {:.2} → {:.2} dB, 350 ms {:.2} → {:.2} dB, Ren's psycho metric {:.1} → {:.1}",
            row.2, row.3, row.4, row.5, row.6, row.7
        );
        rows.push(row);
    }
    let mut cats: Vec<String> = rows.iter().map(|r| r.1.clone()).collect();
    cats.sort();
    cats.dedup();
    println!("\n| clips | n | attack: modes | attack: modes + residual | better | 350 ms: modes | 350 ms: modes + residual | Ren's Π_psycho, 350 ms: modes / modes + residual | better |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    for c in cats.iter().map(String::as_str).chain(["all"]) {
        let r: Vec<_> = rows.iter().filter(|r| c == "all" || r.1 == c).collect();
        let better = r.iter().filter(|r| r.3 < r.2).count();
        let better_psycho = r.iter().filter(|r| r.7 < r.6).count();
        println!(
            "| {c} | {} | {:.2} dB | {:.2} dB | {better}/{} | {:.2} dB | {:.2} dB | {:.1} / {:.1} | {better_psycho}/{} |",
            r.len(),
            median(r.iter().map(|r| r.2).collect()),
            median(r.iter().map(|r| r.3).collect()),
            r.len(),
            median(r.iter().map(|r| r.4).collect()),
            median(r.iter().map(|r| r.5).collect()),
            median(r.iter().map(|r| r.6).collect()),
            median(r.iter().map(|r| r.7).collect()),
            r.len()
        );
    }
    if let Some(out) = json {
        let v: Vec<serde_json::Value> = rows
            .iter()
            .map(|r| serde_json::json!({"clip": r.0, "category": r.1, "attack_modes_db": r.2, "attack_residual_db": r.3, "long_modes_db": r.4, "long_residual_db": r.5, "psycho_modes": r.6, "psycho_residual": r.7}))
            .collect();
        write_json(&out, &v);
    }
}
