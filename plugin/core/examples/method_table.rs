//! Issue 15's comparison of the two seed methods on real clips: for each clip, `estimate`
//! with EMG (the thesis) and with Ren's method (`--method ren`, Ren 2013 §5), the time each
//! took, Ren's hybrid metric of each material (EMG's as the plugin plays it: law + mean
//! support damping), and — a measure neither method optimises — the log-spectral distance
//! to the recording of its first impact's partials resynthesised with each material's
//! decays (the editor's *B: modes*, with EMG's support), over the first 50 ms and 350 ms.
//!
//! `cargo run --release -p struck-core --example method_table -- CLIPS_DIR [--json OUT]`
//! (clips: `tests/recordings/fetch.py`'s `CACHE/clips`; the category is the file name's
//! first word).

use std::sync::atomic::AtomicBool;
use std::time::Instant;
use struck_core::editor::ab::{build, modes_clip, Side};

mod common;
use common::{ab_request, clips, frames, lsd, median, name_and_category, write_json};

/// `law` with a constant extra c (the mean support damping), for the laws with a constant
/// term; the power law has none and is returned as it is.
fn with_support(law: dsp::Damping, s: f64) -> dsp::Damping {
    match law {
        dsp::Damping::Rayleigh { alpha1, alpha2 } => dsp::Damping::Rayleigh { alpha1: alpha1 + s, alpha2 },
        dsp::Damping::Hybrid { alpha1, alpha2, alpha3 } => dsp::Damping::Hybrid { alpha1: alpha1 + s, alpha2, alpha3 },
        dsp::Damping::Caughey { mut coeffs, order } => {
            coeffs[0] += s;
            dsp::Damping::Caughey { coeffs, order }
        }
        p @ dsp::Damping::Power { .. } => p,
    }
}

struct Row {
    clip: String,
    category: String,
    seconds: [f64; 2],
    hybrid: [f64; 2],
    attack: [f64; 2],
    long: [f64; 2],
}

fn main() {
    let (files, json) = clips("method_table CLIPS_DIR [--json OUT]");
    let rate = 48_000.0f32;
    let mut rows: Vec<Row> = Vec::new();
    for f in &files {
        let (name, category) = name_and_category(f);
        let run = |method| {
            let t = Instant::now();
            let opts = estimator::Options { method, ..estimator::Options::default() };
            estimator::estimate(std::slice::from_ref(f), &opts, &|_| {}, &AtomicBool::new(false))
                .map(|r| (r, t.elapsed().as_secs_f64()))
        };
        let (Ok((emg, t_emg)), Ok((ren, t_ren))) = (run(estimator::Method::Emg), run(estimator::Method::Ren)) else {
            eprintln!("{name}: an estimate failed");
            continue;
        };
        let Some(rf) = ren.ren_fit.as_ref().filter(|_| ren.method == estimator::Method::Ren) else {
            eprintln!("{name}: the ren fit fell back: {:?}", ren.warnings);
            continue;
        };
        let Some(imp) = emg.impacts.first() else { continue };
        let req = ab_request(Side::Recording, f, imp, emg.damping(), rate);
        let Ok(a) = build(&req) else {
            eprintln!("{name}: the recording clip failed");
            continue;
        };
        let seconds = a.len() as f64 / f64::from(rate);
        let b_emg = modes_clip(
            &imp.features,
            Some(&with_support(emg.damping(), emg.support_c().unwrap_or(0.0))),
            rate,
            seconds,
        );
        let b_ren = modes_clip(&imp.features, Some(&ren.damping()), rate, seconds);
        let (attack, long) = (frames(0.05, rate), frames(0.35, rate));
        let row = Row {
            clip: name.clone(),
            category,
            seconds: [t_emg, t_ren],
            hybrid: [rf.emg_hybrid.unwrap_or(f64::NAN), rf.hybrid],
            attack: [lsd(&b_emg, &a, attack), lsd(&b_ren, &a, attack)],
            long: [lsd(&b_emg, &a, long), lsd(&b_ren, &a, long)],
        };
        println!(
            "{name}: {:.2}/{:.2} s; hybrid {:.3e} → {:.3e}; 50 ms {:.2} → {:.2} dB; 350 ms {:.2} → {:.2} dB",
            row.seconds[0],
            row.seconds[1],
            row.hybrid[0],
            row.hybrid[1],
            row.attack[0],
            row.attack[1],
            row.long[0],
            row.long[1]
        );
        rows.push(row);
    }
    let mut cats: Vec<String> = rows.iter().map(|r| r.category.clone()).collect();
    cats.sort();
    cats.dedup();
    println!("\n| clips | n | time EMG / Ren (median, max) | Ren's metric EMG / Ren | 50 ms LSD EMG / Ren | Ren closer | 350 ms LSD EMG / Ren | Ren closer |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- |");
    for c in cats.iter().map(String::as_str).chain(["all"]) {
        let r: Vec<&Row> = rows.iter().filter(|r| c == "all" || r.category == c).collect();
        let m = |f: &dyn Fn(&Row) -> f64| median(r.iter().map(|x| f(x)).collect());
        let max_ren = r.iter().map(|x| x.seconds[1]).fold(0.0, f64::max);
        println!(
            "| {c} | {} | {:.2} s / {:.2} s (max {:.2} s) | {:.3e} / {:.3e} | {:.2} / {:.2} dB | {}/{} | {:.2} / {:.2} dB | {}/{} |",
            r.len(),
            m(&|x| x.seconds[0]),
            m(&|x| x.seconds[1]),
            max_ren,
            m(&|x| x.hybrid[0]),
            m(&|x| x.hybrid[1]),
            m(&|x| x.attack[0]),
            m(&|x| x.attack[1]),
            r.iter().filter(|x| x.attack[1] < x.attack[0]).count(),
            r.len(),
            m(&|x| x.long[0]),
            m(&|x| x.long[1]),
            r.iter().filter(|x| x.long[1] < x.long[0]).count(),
            r.len(),
        );
    }
    if let Some(out) = json {
        let v: Vec<serde_json::Value> = rows
            .iter()
            .map(|r| serde_json::json!({"clip": r.clip, "category": r.category, "seconds": r.seconds, "hybrid": r.hybrid, "attack_lsd_db": r.attack, "long_lsd_db": r.long}))
            .collect();
        write_json(&out, &v);
    }
}
