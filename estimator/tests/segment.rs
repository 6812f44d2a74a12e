//! Segmentation on files made the way users' files differ from ours (issue 10, part 1):
//! trimmed files that ring from sample 0, taps on a still-ringing object, noise floors that
//! start mid-file, and a single woodblock-like hit. Signals come from a small generator
//! written here (direct evaluation of a e^(−dt) sin(2πft), not `estimator::synth`).

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use estimator::{extract_features, FeaturesReport, Options};

mod common;
use common::Gen;

/// Adds a e^(−d(t−t0)) sin(2πf(t−t0)) from t0 on, by direct evaluation.
fn add_mode(x: &mut [f64], fs: f64, t0: f64, f: f64, d: f64, a: f64) {
    let i0 = (t0 * fs).round() as usize;
    for (i, v) in x.iter_mut().enumerate().skip(i0) {
        let t = (i - i0) as f64 / fs;
        let env = a * (-d * t).exp();
        if env < 1e-12 * a {
            break;
        }
        *v += env * (std::f64::consts::TAU * f * t).sin();
    }
}

/// Segments `x` (as the f32 samples a file would hold) with the default options.
fn segment(x: &[f64], fs: f64) -> estimator::segment::Segmentation {
    let x32: Vec<f32> = x.iter().map(|&v| v as f32).collect();
    estimator::segment::segment(&x32, fs, &estimator::SegmentOptions::default())
}

fn write(name: &str, x: &[f64], fs: u32) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("struck-seg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("{name}.wav"));
    let spec =
        hound::WavSpec { channels: 1, sample_rate: fs, bits_per_sample: 32, sample_format: hound::SampleFormat::Float };
    let mut w = hound::WavWriter::create(&p, spec).unwrap();
    for &v in x {
        w.write_sample(v as f32).unwrap();
    }
    w.finalize().unwrap();
    p
}

fn features(p: &PathBuf) -> Result<FeaturesReport, estimator::EstimateError> {
    extract_features(std::slice::from_ref(p), &Options::default(), &|_| {}, &AtomicBool::new(false))
}

/// Ren §4 style, through the whole pipeline (WAV → segmentation → extraction): 100 single
/// damped sinusoids, f log-uniform in [20, 20000] Hz, d log-uniform in [0.1, 1000] s⁻¹,
/// 44.1 kHz, 2 s, float WAV, each starting with the ringing at sample 0 (a trimmed
/// sample-library file). Found = a feature within 0.5 % in frequency. Target (issue 10):
/// ≥ 95 found (60 before this test existed), mean errors well under Ren's 0.040 % (f) and
/// 0.53 % (d).
#[test]
fn ren_sinusoids_starting_at_sample_0() {
    let fs = 44_100.0;
    let mut g = Gen(2026);
    let (mut found, mut ef, mut ed, mut missed) = (0usize, 0.0, 0.0, Vec::new());
    for i in 0..100 {
        let f = g.log_uniform(20.0, 20_000.0);
        let d = g.log_uniform(0.1, 1000.0);
        let mut x = vec![0.0; 2 * fs as usize];
        add_mode(&mut x, fs, 0.0, f, d, 0.5);
        let p = write(&format!("ren{i}"), &x, fs as u32);
        let best = features(&p).ok().and_then(|r| {
            r.impacts
                .iter()
                .flat_map(|imp| imp.features.iter().copied())
                .filter(|ft| (ft.freq_hz / f - 1.0).abs() < 0.005)
                .max_by(|a, b| a.amplitude.total_cmp(&b.amplitude))
        });
        match best {
            Some(b) => {
                found += 1;
                ef += (b.freq_hz / f - 1.0).abs();
                ed += (b.decay_per_s / d - 1.0).abs();
            }
            None => missed.push((f, d)),
        }
        let _ = std::fs::remove_file(p);
    }
    let (ef, ed) = (ef / found.max(1) as f64, ed / found.max(1) as f64);
    eprintln!("found {found}/100, mean rel err f {:.2e} d {:.2e}; missed (f, d): {missed:?}", ef, ed);
    assert!(found >= 95, "found {found}; missed {missed:?}");
    // Measured 3.2e-5 and 2.0e-4 (0.003 %, 0.02 %): an order of magnitude under Ren's.
    assert!(ef < 0.0001 && ed < 0.001, "f {ef} d {ed}");
}

/// Digital silence, then room noise that starts 0.2 s before each of three taps and stops
/// 1 s after: the noise onsets are not impacts (and are reported), the taps are.
#[test]
fn noise_floor_steps_are_not_taps() {
    let fs = 48_000.0;
    let mut g = Gen(5);
    let n = (9.0 * fs) as usize;
    let mut x = vec![0.0; n];
    let taps = [1.2, 4.2, 7.2];
    for &t in &taps {
        for &(f, d, a) in &[(523.0, 6.0, 0.2), (1410.0, 11.0, 0.1), (2750.0, 19.0, 0.05)] {
            add_mode(&mut x, fs, t, f, d, a);
        }
        // Room noise 45 dB under the tap's peak, from t − 0.2 s to t + 1 s.
        for v in &mut x[((t - 0.2) * fs) as usize..((t + 1.0) * fs) as usize] {
            *v += 0.2 * 10f64.powf(-45.0 / 20.0) * g.normal();
        }
    }
    // Digital silence elsewhere is exactly zero (as in a gated recording).
    let p = write("noise-steps", &x, fs as u32);
    let r = features(&p).unwrap();
    let onsets: Vec<f64> = r.impacts.iter().map(|i| i.onset_s).collect();
    eprintln!("onsets {onsets:?} skipped {:?} warnings {:?}", r.skipped, r.warnings);
    assert_eq!(onsets.len(), 3, "{onsets:?}");
    for (o, t) in onsets.iter().zip(taps) {
        assert!((o - t).abs() < 0.003, "onset {o} vs tap {t}");
    }
    assert!(r.warnings.iter().any(|w| w.contains("background noise starts or changes")), "{:?}", r.warnings);
    // No feature of noise: every feature is one of the three modes.
    for imp in &r.impacts {
        for f in &imp.features {
            assert!([523.0, 1410.0, 2750.0].iter().any(|m: &f64| (f.freq_hz / m - 1.0).abs() < 0.002), "{f:?}");
        }
    }
}

/// Issue 10's own case at its own length: a 31-minute session (8 kHz float) of digital
/// silence with six taps, room noise starting 0.2 s before each. Every tap is found at its
/// time, the last at 30 min 40 s, and nothing of it is cut (a black-box tester's 30-minute
/// file lost its last three taps to the 15-minute limit before stop 56).
#[test]
fn a_thirty_minute_session_of_gated_taps_is_read_whole() {
    let fs = 8_000.0;
    let mut g = Gen(30);
    let n = (31.0 * 60.0 * fs) as usize;
    let mut x = vec![0.0; n];
    let taps = [30.0, 600.0, 950.0, 1250.0, 1650.0, 1840.0];
    for &t in &taps {
        for &(f, d, a) in &[(523.0, 6.0, 0.2), (1410.0, 11.0, 0.1), (2750.0, 19.0, 0.05)] {
            add_mode(&mut x, fs, t, f, d, a);
        }
        for v in &mut x[((t - 0.2) * fs) as usize..((t + 1.0) * fs) as usize] {
            *v += 0.2 * 10f64.powf(-45.0 / 20.0) * g.normal();
        }
    }
    let p = write("thirty-minutes", &x, fs as u32);
    drop(x);
    let r = features(&p).unwrap();
    let _ = std::fs::remove_file(&p);
    let onsets: Vec<f64> = r.impacts.iter().map(|i| i.onset_s).collect();
    assert!(!r.warnings.iter().any(|w| w.contains("length limit")), "{:?}", r.warnings);
    assert_eq!(onsets.len(), taps.len(), "{onsets:?} {:?}", r.skipped);
    for (o, t) in onsets.iter().zip(taps) {
        assert!((o - t).abs() < 0.003, "onset {o} vs tap {t}");
    }
}

/// A crash cymbal as sample libraries have them (a black-box tester's 68 real clips: 7
/// cymbals gave "no impacts found", each onset taken for a noise floor that starts): 10 ms
/// of near silence, then 400 partials 250 Hz–14 kHz too dense to be tonal in 40 ms, each
/// blooming over 5–40 ms (the crash's energy spreads upwards after the strike) and dying
/// at 1.5–6 s⁻¹. One impact, at the strike. A burst of noise that stops 0.6 s later (a
/// floor switched on and off) is not a strike.
#[test]
fn a_cymbal_is_a_strike_and_a_burst_of_noise_is_not() {
    let fs = 48_000.0;
    let mut g = Gen(31);
    let n = (2.5 * fs) as usize;
    let t0 = 0.01;
    let mut x: Vec<f64> = (0..n).map(|_| 1e-5 * g.normal()).collect();
    let i0 = (t0 * fs) as usize;
    for _ in 0..400 {
        let (f, d, tau) = (g.log_uniform(250.0, 14_000.0), g.log_uniform(1.5, 6.0), g.log_uniform(0.005, 0.04));
        let (a, ph) = (0.02 * g.log_uniform(0.2, 1.0), std::f64::consts::TAU * g.u());
        for (i, v) in x.iter_mut().enumerate().skip(i0) {
            let t = (i - i0) as f64 / fs;
            *v += a * -(-t / tau).exp_m1() * (-d * t).exp() * (std::f64::consts::TAU * f * t + ph).sin();
        }
    }
    let p = write("cymbal", &x, fs as u32);
    let r = features(&p).unwrap();
    let onsets: Vec<f64> = r.impacts.iter().map(|i| i.onset_s).collect();
    eprintln!("cymbal: onsets {onsets:?} skipped {:?} warnings {:?}", r.skipped, r.warnings);
    assert_eq!(onsets.len(), 1, "{onsets:?}");
    assert!((onsets[0] - t0).abs() < 0.01, "onset {} vs {t0}", onsets[0]);

    // Digital silence, room noise from 0.5 s to 1.1 s, then a tap at 1.6 s.
    let mut x = vec![0.0; n];
    for v in &mut x[(0.5 * fs) as usize..(1.1 * fs) as usize] {
        *v = 1e-3 * g.normal();
    }
    add_mode(&mut x, fs, 1.6, 880.0, 8.0, 0.3);
    let seg = segment(&x, fs);
    let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
    eprintln!("burst: onsets {onsets:?} noise steps {:?}", seg.noise_steps);
    assert_eq!(onsets.len(), 1, "{onsets:?}");
    assert!((onsets[0] - 1.6).abs() < 0.003, "{onsets:?}");
}

/// A bell-like object tapped every 0.6 s while it still rings (modes decay over seconds, each
/// tap excites them with new random gains): every tap is found.
#[test]
fn taps_on_a_ringing_object() {
    let fs = 44_100.0;
    let mut g = Gen(77);
    let modes: Vec<(f64, f64)> = (0..12).map(|_| (g.log_uniform(300.0, 9000.0), g.log_uniform(0.5, 4.0))).collect();
    let taps = [0.3, 0.9, 1.5, 2.1];
    let mut x = vec![0.0; (3.5 * fs) as usize];
    for &t in &taps {
        for &(f, d) in &modes {
            add_mode(&mut x, fs, t, f, d, 0.08 * g.log_uniform(0.1, 1.0));
        }
    }
    for v in x.iter_mut() {
        *v += 1e-4 * g.normal();
    }
    let p = write("ringing-taps", &x, fs as u32);
    let r = features(&p).unwrap();
    let onsets: Vec<f64> = r.impacts.iter().map(|i| i.onset_s).collect();
    eprintln!("onsets {onsets:?} skipped {:?}", r.skipped);
    assert_eq!(onsets.len(), taps.len(), "{onsets:?}");
    for (o, t) in onsets.iter().zip(taps) {
        assert!((o - t).abs() < 0.003, "onset {o} vs tap {t}");
    }
}

/// One woodblock-like hit: a 1 ms click, a close doublet (700/704 Hz, beating with a null
/// at 125 ms) and two fast higher modes, in noise. It is one impact, not two.
#[test]
fn one_woodblock_hit_is_one_impact() {
    let fs = 44_100.0;
    let mut g = Gen(9);
    let mut x = vec![0.0; (1.5 * fs) as usize];
    let t0 = 0.25;
    let i0 = (t0 * fs) as usize;
    for i in 0..(0.001 * fs) as usize {
        x[i0 + i] += 0.3 * (-(i as f64) / (0.0003 * fs)).exp() * g.normal();
    }
    add_mode(&mut x, fs, t0, 700.0, 12.0, 0.25);
    add_mode(&mut x, fs, t0, 704.0, 12.0, 0.25);
    add_mode(&mut x, fs, t0, 1930.0, 60.0, 0.15);
    add_mode(&mut x, fs, t0, 3150.0, 110.0, 0.1);
    for v in x.iter_mut() {
        *v += 3e-5 * g.normal();
    }
    let p = write("woodblock", &x, fs as u32);
    let r = features(&p).unwrap();
    let onsets: Vec<f64> = r.impacts.iter().map(|i| i.onset_s).collect();
    eprintln!("onsets {onsets:?} skipped {:?}", r.skipped);
    assert_eq!(onsets.len(), 1, "{onsets:?}");
    assert!((onsets[0] - t0).abs() < 0.002);
    assert!(r.skipped.is_empty(), "{:?}", r.skipped);
}

/// A tap in the last 3 ms of a file: found, and skipped as too short (not a panic on the
/// frame indices past the end).
#[test]
fn tap_at_the_very_end_of_a_file() {
    let fs = 44_100.0;
    let mut x = vec![0.0f64; (0.5 * fs) as usize];
    let t0 = 0.5 - 0.003;
    add_mode(&mut x, fs, t0, 1000.0, 20.0, 0.5);
    let seg = segment(&x, fs);
    assert!(seg.impacts.is_empty(), "{:?}", seg.impacts);
    assert_eq!(seg.skipped.len(), 1, "{:?}", seg.skipped);
    assert!(seg.skipped[0].1.contains("too short"), "{:?}", seg.skipped);
}

/// Shapes of single strikes from sample libraries (issue 10: real toms, timpani, a taiko and
/// a swelling bell gave "no impacts found"; woodblocks, music boxes and temple blocks were
/// cut into 2–3 impacts). Each file starts at the strike, as the libraries trim them; each
/// must give exactly one impact at its start.
#[test]
fn single_strikes_of_many_shapes_are_one_impact_each() {
    let fs = 44_100.0;
    let n = (1.5 * fs) as usize;
    let mut g = Gen(21);
    let mut shapes: Vec<(&str, Vec<f64>)> = Vec::new();
    // A drum: 60 inharmonic partials between 80 Hz and 2 kHz that glide down 8 % and decay
    // ~10 dB per 100 ms: neither sharply tonal nor falling 15 dB by 100 ms.
    let mut drum = vec![0.0; n];
    for _ in 0..60 {
        let (f, a, ph) = (g.log_uniform(80.0, 2000.0), 0.02 * g.u(), std::f64::consts::TAU * g.u());
        let mut phase = ph;
        for (i, v) in drum.iter_mut().enumerate() {
            let t = i as f64 / fs;
            phase += std::f64::consts::TAU * f * (1.0 - 0.08 * (1.0 - (-t / 0.05).exp())) / fs;
            *v += a * (-11.5 * t).exp() * phase.sin();
        }
    }
    shapes.push(("drum", drum));
    // A bell that swells: a quiet contact, then partials rising over 30 ms (−25 dB at the
    // start), ringing for seconds.
    let mut bell = vec![0.0; n];
    for (f, a) in [(523.0, 0.3), (1250.0, 0.2), (2010.0, 0.1)] {
        for (i, v) in bell.iter_mut().enumerate() {
            let t = i as f64 / fs;
            *v += a * (1.0 - (-t / 0.03).exp()) * (-0.7 * t).exp() * (std::f64::consts::TAU * f * t).sin();
        }
    }
    shapes.push(("swelling bell", bell));
    // A woodblock whose cavity modes beat: loud onset, then a 6–9 dB swell 50 ms later at
    // −30 dB (two pairs of close modes).
    let mut block = vec![0.0; (0.4 * fs) as usize];
    for i in 0..(0.001 * fs) as usize {
        block[i] += 0.5 * (-(i as f64) / (0.0003 * fs)).exp() * g.normal();
    }
    add_mode(&mut block, fs, 0.0, 950.0, 60.0, 0.4);
    add_mode(&mut block, fs, 0.0, 1430.0, 25.0, 0.02);
    add_mode(&mut block, fs, 0.0, 1440.0, 25.0, 0.02);
    add_mode(&mut block, fs, 0.0, 2710.0, 20.0, 0.012);
    add_mode(&mut block, fs, 0.0, 2717.0, 20.0, 0.012);
    shapes.push(("beating woodblock", block));
    for (name, mut x) in shapes {
        for v in x.iter_mut() {
            *v += 1e-4 * g.normal();
        }
        let p = write(&name.replace(' ', "-"), &x, fs as u32);
        let r = features(&p).unwrap_or_else(|e| panic!("{name}: {e}"));
        let onsets: Vec<f64> = r.impacts.iter().map(|i| i.onset_s).collect();
        eprintln!("{name}: onsets {onsets:?}, skipped {:?}, warnings {:?}", r.skipped, r.warnings);
        assert_eq!(onsets.len(), 1, "{name}: {onsets:?}");
        assert!(onsets[0] < 0.01, "{name}: onset {}", onsets[0]);
    }
}

/// Late in a long ring, a faint broadband event 26 dB under the strike's peak (a rattle of
/// the stand, a swell) is part of the ringing impact; a second tap 6 dB under the first,
/// while the first still rings, is a new impact.
#[test]
fn a_faint_rattle_late_in_the_ring_is_not_a_strike_but_a_tap_is() {
    let fs = 44_100.0;
    let mut g = Gen(33);
    let mut x = vec![0.0; (3.0 * fs) as usize];
    let click = |x: &mut [f64], t0: f64, a: f64, g: &mut Gen| {
        let i0 = (t0 * fs) as usize;
        for i in 0..(0.002 * fs) as usize {
            x[i0 + i] += a * (-(i as f64) / (0.0004 * fs)).exp() * g.normal();
        }
    };
    // The strike: a click and a ringing bell (d 3–5 s⁻¹: about −30 dB by 1.2 s).
    click(&mut x, 0.1, 0.4, &mut g);
    for (f, d, a) in [(523.0, 3.0, 0.3), (1370.0, 4.0, 0.2), (2590.0, 5.0, 0.1)] {
        add_mode(&mut x, fs, 0.1, f, d, a);
    }
    // A rattle at 1.2 s, 26 dB under the strike's click but louder than the ring there.
    click(&mut x, 1.2, 0.4 * 10f64.powf(-26.0 / 20.0), &mut g);
    // A second, softer tap at 2.0 s (6 dB under the first), while the first still rings.
    click(&mut x, 2.0, 0.2, &mut g);
    for (f, d, a) in [(523.0, 3.0, 0.15), (1370.0, 4.0, 0.1), (2590.0, 5.0, 0.05)] {
        add_mode(&mut x, fs, 2.0, f, d, a);
    }
    for v in x.iter_mut() {
        *v += 1e-5 * g.normal();
    }
    let p = write("rattle-and-tap", &x, fs as u32);
    let r = features(&p).unwrap();
    let onsets: Vec<f64> = r.impacts.iter().map(|i| i.onset_s).collect();
    eprintln!("rattle and tap: onsets {onsets:?}, skipped {:?}", r.skipped);
    assert_eq!(onsets.len(), 2, "{onsets:?}");
    assert!((onsets[0] - 0.1).abs() < 0.002 && (onsets[1] - 2.0).abs() < 0.002, "{onsets:?}");
}

/// Pieces of one strike that the segmentation took as strikes on real sample-library clips
/// (issue 10: music boxes, a timpani, a ride cymbal's bell): each file below is one strike
/// and must give one impact.
/// - A precursor: a faint 2 kHz scrape 50 ms before the strike, 20 dB under it (a music
///   box's pin lifting the tooth): the impact starts at the strike, the scrape is reported.
/// - A tail cut into runs of digital zeros (16 ms in every 40: a gated or truncated sample),
///   far under the peak.
/// - Three beating doublets far apart (400/403, 2000/2003 and 6000/6003 Hz, nulls together
///   every 1/3 s) in a clean file: their swells rise together across 5.6 kHz, in few bins.
///   (A guard: the earlier segmentation also kept this one whole; the precursor and the gated
///   tail were split before.)
#[test]
fn pieces_of_one_strike_are_one_impact() {
    let fs = 44_100.0;
    let n = (2.5 * fs) as usize;
    let mut g = Gen(5);
    let click = |x: &mut [f64], t0: f64, a: f64, g: &mut Gen| {
        let i0 = (t0 * fs) as usize;
        for i in 0..(0.001 * fs) as usize {
            x[i0 + i] += a * (-(i as f64) / (0.0003 * fs)).exp() * g.normal();
        }
    };
    // Precursor, then the strike at 0.25 s.
    let mut pre = vec![0.0; n];
    let i0 = (0.2 * fs) as usize;
    for i in 0..(0.04 * fs) as usize {
        pre[i0 + i] += 0.03 * (std::f64::consts::TAU * 2000.0 * i as f64 / fs).sin() * (1.0 + 0.3 * g.normal());
    }
    click(&mut pre, 0.25, 0.4, &mut g);
    for (f, d, a) in [(880.0, 3.0, 0.3), (2230.0, 5.0, 0.2), (4410.0, 8.0, 0.1)] {
        add_mode(&mut pre, fs, 0.25, f, d, a);
    }
    // A slow strike whose tail is cut to zeros 16 ms in every 40 from 1.2 s on (no noise).
    let mut gated = vec![0.0; n];
    click(&mut gated, 0.05, 0.4, &mut g);
    for (f, d, a) in [(98.0, 4.0, 0.4), (196.0, 5.0, 0.2), (294.0, 6.0, 0.1)] {
        add_mode(&mut gated, fs, 0.05, f, d, a);
    }
    let period = (0.04 * fs) as usize;
    for (i, v) in gated.iter_mut().enumerate().skip((1.2 * fs) as usize) {
        if i % period < period * 2 / 5 {
            *v = 0.0;
        }
    }
    // Beating doublets (no noise).
    let mut beats = vec![0.0; n];
    click(&mut beats, 0.05, 0.4, &mut g);
    for (f, a) in [(400.0, 0.2), (403.0, 0.2), (2000.0, 0.15), (2003.0, 0.15), (6000.0, 0.1), (6003.0, 0.1)] {
        add_mode(&mut beats, fs, 0.05, f, 1.0, a);
    }
    for (name, x, t0) in [("precursor", pre, 0.25), ("gated-tail", gated, 0.05), ("beating-doublets", beats, 0.05)] {
        let seg = segment(&x, fs);
        let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
        eprintln!("{name}: onsets {onsets:?}, skipped {:?}", seg.skipped);
        assert_eq!(onsets.len(), 1, "{name}: {onsets:?}");
        assert!((onsets[0] - t0).abs() < 0.002, "{name}: onset {} vs {t0}", onsets[0]);
        if name == "precursor" {
            assert!(seg.skipped.iter().any(|s| s.1.contains("precursor")), "{:?}", seg.skipped);
        }
    }
}

/// The other side of the gated-tail rule: a fast ring that decayed into room noise is over,
/// and a soft tap 17 dB under it 150 ms later is a strike of its own.
#[test]
fn a_soft_tap_after_a_decayed_ring_is_a_strike() {
    let fs = 44_100.0;
    let mut g = Gen(41);
    let mut x = vec![0.0; (1.0 * fs) as usize];
    for (t0, a) in [(0.1, 0.4), (0.35, 0.4 * 10f64.powf(-17.0 / 20.0))] {
        let i0 = (t0 * fs) as usize;
        for i in 0..(0.001 * fs) as usize {
            x[i0 + i] += a * (-(i as f64) / (0.0003 * fs)).exp() * g.normal();
        }
        for (f, d, m) in [(700.0, 60.0, 0.6), (1930.0, 90.0, 0.3), (3150.0, 120.0, 0.2)] {
            add_mode(&mut x, fs, t0, f, d, a * m);
        }
    }
    for v in x.iter_mut() {
        *v += 3e-5 * g.normal();
    }
    let seg = segment(&x, fs);
    let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
    eprintln!("onsets {onsets:?}, skipped {:?}", seg.skipped);
    assert_eq!(onsets.len(), 2, "{onsets:?}");
    assert!((onsets[0] - 0.1).abs() < 0.002 && (onsets[1] - 0.35).abs() < 0.002, "{onsets:?}");
}

/// A precursor closer to its strike than the minimum gap between onsets (`min_gap_s`, 50 ms):
/// the strike's onset is where its rise starts, not where the gap let the scan look again
/// (issue 10: FluidR3's music boxes, whose tine rings 20–50 ms after the pin's first
/// noise, were taken 3–5 ms late). A faint 2 kHz scrape 20 dB under the strike starts 15–45 ms
/// before it; the strike (a click and three modes) must start within 0.3 ms of its first
/// sample, and the scrape be reported as its precursor.
#[test]
fn a_strike_right_after_its_precursor_starts_where_it_rises() {
    let fs = 44_100.0;
    let n = (1.5 * fs) as usize;
    let mut late = Vec::new();
    for (k, lead) in [0.015, 0.025, 0.035, 0.045].into_iter().enumerate() {
        let mut g = Gen(70 + k as u64);
        let t0 = 0.3;
        let mut x = vec![0.0; n];
        let i0 = ((t0 - lead) * fs) as usize;
        for i in 0..(0.06 * fs) as usize {
            x[i0 + i] += 0.03 * (std::f64::consts::TAU * 2000.0 * i as f64 / fs).sin() * (1.0 + 0.3 * g.normal());
        }
        let c0 = (t0 * fs).round() as usize;
        for i in 0..(0.001 * fs) as usize {
            x[c0 + i] += 0.4 * (-(i as f64) / (0.0003 * fs)).exp() * g.normal();
        }
        for (f, d, a) in [(880.0, 3.0, 0.3), (2230.0, 5.0, 0.2), (4410.0, 8.0, 0.1)] {
            add_mode(&mut x, fs, t0, f, d, a);
        }
        for v in x.iter_mut() {
            *v += 1e-5 * g.normal();
        }
        let seg = segment(&x, fs);
        let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
        eprintln!("precursor {lead} s before: onsets {onsets:?}, skipped {:?}", seg.skipped);
        assert_eq!(onsets.len(), 1, "precursor {lead} s before: {onsets:?}");
        assert!(seg.skipped.iter().any(|s| s.1.contains("precursor")), "{:?}", seg.skipped);
        late.push((lead, onsets[0] - t0));
    }
    assert!(late.iter().all(|&(_, dt)| dt.abs() < 3e-4), "onset minus strike, s: {late:?}");
}

/// A mallet's bounce or a flam on a wood block: a second strike 25–45 ms after the first,
/// inside the 50 ms minimum gap, 6 dB or more over the first one's ring by then. It stays part of the impact (the gap holds) but is reported, with its time;
/// the report says so in a warning.
#[test]
fn a_second_strike_inside_the_minimum_gap_is_reported() {
    let fs = 44_100.0;
    // (Past 45 ms, near the gap's end: a strike is either its own impact or reported, never
    // both.)
    for (k, lag) in [0.025, 0.03, 0.045, 0.048, 0.05, 0.052, 0.055].into_iter().enumerate() {
        let mut g = Gen(500 + k as u64);
        let mut x = vec![0.0; (1.0 * fs) as usize];
        let t0: f64 = 0.25;
        for (t, a) in [(t0, 1.0), (t0 + lag, 0.9)] {
            let i0 = (t * fs).round() as usize;
            for i in 0..(0.001 * fs) as usize {
                x[i0 + i] += 0.3 * a * (-(i as f64) / (0.0003 * fs)).exp() * g.normal();
            }
            // A wood block's fast modes.
            for (f, d, b) in [(610.0, 80.0, 0.3), (1690.0, 120.0, 0.2), (3300.0, 200.0, 0.1)] {
                add_mode(&mut x, fs, t, f, d, a * b);
            }
        }
        for v in x.iter_mut() {
            *v += 1e-5 * g.normal();
        }
        let seg = segment(&x, fs);
        let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
        let again: Vec<f64> = seg.restrikes.iter().map(|r| r.0 as f64 / fs).collect();
        eprintln!("bounce {lag} s after: onsets {onsets:?}, restrikes {again:?}");
        if k >= 3 {
            let own = onsets.len() == 2 && again.is_empty() && (onsets[1] - (t0 + lag)).abs() < 1e-3;
            assert!(own || (onsets.len() == 1 && again.len() == 1), "{lag}: {onsets:?} {again:?}");
            continue;
        }
        assert_eq!(onsets.len(), 1, "bounce {lag} s after: {onsets:?}");
        assert!((onsets[0] - t0).abs() < 3e-4, "{onsets:?}");
        assert_eq!(again.len(), 1, "bounce {lag} s after: {again:?}");
        assert!((again[0] - (t0 + lag)).abs() < 1e-3, "bounce at {} s, reported at {again:?}", t0 + lag);
        assert_eq!(seg.restrikes[0].1, seg.impacts[0].start);
        if k == 1 {
            let p = write("bounce", &x, fs as u32);
            let r = features(&p).unwrap();
            assert!(
                r.warnings
                    .iter()
                    .any(|w| w.contains("a second strike 30 ms after the one at 0.250 s") && w.contains("minimum gap")),
                "{:?}",
                r.warnings
            );
        }
    }
}

/// A fast tick (a fingernail, a rattle: decays 250–700 s⁻¹, into the floor within 20 ms)
/// and a strike twice as loud 30–40 ms after it, inside the 50 ms minimum gap (the black-box
/// tester's case D): the gap is over once the tick rang out, so the strike is an impact of its
/// own, starting within 1 ms of its first sample, and the tick is analysed up to it or
/// reported as too short. Before, the two were one 30 ms impact and the strike was dropped
/// unsaid.
#[test]
fn a_strike_after_a_tick_that_rang_out_is_its_own_impact() {
    let fs = 44_100.0;
    // The strike as loud as the tick too (`level` 0.5): no louder than the tick's frames of
    // 25–40 ms before, it must not read as a steady sound's ripple.
    let cases = [(0.03, 700.0, 1.0), (0.035, 400.0, 1.0), (0.04, 250.0, 1.0), (0.03, 700.0, 0.5), (0.04, 250.0, 0.5)];
    for (k, (lag, d, level)) in cases.into_iter().enumerate() {
        let mut g = Gen(600 + k as u64);
        let mut x = vec![0.0; (1.0 * fs) as usize];
        let t0: f64 = 0.25;
        let i0 = (t0 * fs).round() as usize;
        for i in 0..(0.0005 * fs) as usize {
            x[i0 + i] += 0.2 * (-(i as f64) / (0.0002 * fs)).exp() * g.normal();
        }
        for (f, b) in [(2400.0, 0.2), (5100.0, 0.12)] {
            add_mode(&mut x, fs, t0, f, d, b);
        }
        let t1 = t0 + lag;
        let i1 = (t1 * fs).round() as usize;
        for i in 0..(0.001 * fs) as usize {
            x[i1 + i] += level * 0.4 * (-(i as f64) / (0.0003 * fs)).exp() * g.normal();
        }
        for (f, d, b) in [(610.0, 40.0, 0.2), (1690.0, 60.0, 0.12), (3300.0, 90.0, 0.08)] {
            add_mode(&mut x, fs, t1, f, d, level * b);
        }
        for v in x.iter_mut() {
            *v += 1e-5 * g.normal();
        }
        let seg = segment(&x, fs);
        let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
        eprintln!("tick d {d}, strike {lag} s after: onsets {onsets:?}, skipped {:?}", seg.skipped);
        assert!(onsets.iter().any(|&o| (o - t1).abs() < 1e-3), "strike at {t1} s: onsets {onsets:?}");
        let tick_said = onsets.iter().any(|&o| (o - t0).abs() < 1e-3)
            || seg.skipped.iter().any(|(s, why)| (s.start as f64 / fs - t0).abs() < 1e-3 && why.contains("too short"));
        assert!(tick_said, "tick at {t0} s: onsets {onsets:?}, skipped {:?}", seg.skipped);
        assert!(seg.restrikes.is_empty(), "{:?}", seg.restrikes);
    }
}

/// Two equal strikes of a bell 150–250 ms apart (the black-box tester's case C: decays
/// 3–30 s⁻¹, so the first still rings 3–6 dB under its peak when the second comes; the level
/// rises only ~6 dB overall, but 10–25 dB over the upper partials): two impacts, each
/// starting within 1 ms of its strike.
#[test]
fn two_equal_bell_strikes_close_together_are_two_impacts() {
    let fs = 44_100.0;
    let partials = [
        (523.0, 3.0, 0.3),
        (1047.0, 4.0, 0.25),
        (1250.0, 5.0, 0.2),
        (1568.0, 7.0, 0.15),
        (2093.0, 10.0, 0.12),
        (2794.0, 15.0, 0.1),
        (3520.0, 22.0, 0.08),
        (4699.0, 30.0, 0.06),
    ];
    for (k, lag) in [0.15, 0.2, 0.25].into_iter().enumerate() {
        let mut g = Gen(700 + k as u64);
        let mut x = vec![0.0; (2.0 * fs) as usize];
        let t0: f64 = 0.25;
        for t in [t0, t0 + lag] {
            let i0 = (t * fs).round() as usize;
            for i in 0..(0.001 * fs) as usize {
                x[i0 + i] += 0.3 * (-(i as f64) / (0.0003 * fs)).exp() * g.normal();
            }
            for (f, d, a) in partials {
                add_mode(&mut x, fs, t, f, d, a);
            }
        }
        for v in x.iter_mut() {
            *v += 1e-5 * g.normal();
        }
        let seg = segment(&x, fs);
        let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
        eprintln!("bell struck again {lag} s after: onsets {onsets:?}, skipped {:?}", seg.skipped);
        assert_eq!(onsets.len(), 2, "struck again {lag} s after: {onsets:?}");
        assert!((onsets[0] - t0).abs() < 1e-3 && (onsets[1] - t0 - lag).abs() < 1e-3, "{lag}: {onsets:?}");
    }
}

/// A single strike with a slow attack (a soft mallet, a swell: raised-cosine and linear
/// rises of 10–50 ms, found by the black-box tester) is never reported as a second strike.
#[test]
fn a_slow_attack_is_not_a_second_strike() {
    let fs = 44_100.0;
    let mut bad = Vec::new();
    for (k, (rise_s, linear)) in
        [(0.01, false), (0.02, false), (0.03, false), (0.05, false), (0.02, true), (0.035, true), (0.05, true)]
            .into_iter()
            .enumerate()
    {
        let mut g = Gen(700 + k as u64);
        let mut x = vec![0.0; fs as usize];
        let t0 = 0.1;
        for (f, d, a) in
            [(523.0, 8.0, 1.0), (1443.0, 20.0, 0.5), (2827.0, 40.0, 0.3), (4673.0, 70.0, 0.2), (6980.0, 110.0, 0.1)]
        {
            add_mode(&mut x, fs, t0, f, d, 0.3 * a);
        }
        let i0 = (t0 * fs).round() as usize;
        for (i, v) in x.iter_mut().enumerate().skip(i0) {
            let t = (i - i0) as f64 / fs;
            if t < rise_s {
                *v *= if linear { t / rise_s } else { 0.5 - 0.5 * (std::f64::consts::PI * t / rise_s).cos() };
            }
        }
        for v in x.iter_mut() {
            *v += 1e-4 * g.normal();
        }
        let seg = segment(&x, fs);
        if !seg.restrikes.is_empty() {
            bad.push((rise_s, linear, seg.restrikes.clone()));
        }
    }
    assert!(bad.is_empty(), "(rise s, linear, restrikes): {bad:?}");
}

/// The other side of a strike right after its precursor: a clean strike (three modes, no
/// click, no precursor) whose first sample lands anywhere in a frame of the scan (its first
/// onset frame may hold only its last few samples) is one impact from its first sample, never
/// a "precursor" of itself a few milliseconds later.
#[test]
fn a_clean_strike_is_never_its_own_precursor() {
    let fs = 44_100.0;
    let mut bad = Vec::new();
    for k in 0..336 {
        // Every offset within a hop (110 samples): with a click, without, and with a soft
        // mallet's attack (a raised cosine over 3 ms).
        let (click, soft) = (k / 112 == 1, k / 112 == 2);
        let t0 = 0.2 + (k % 112) as f64 / fs;
        let mut g = Gen(900 + k as u64);
        let mut x = vec![0.0; (0.8 * fs) as usize];
        let i0 = (t0 * fs).round() as usize;
        if click {
            for i in 0..(0.001 * fs) as usize {
                x[i0 + i] += 0.4 * (-(i as f64) / (0.0003 * fs)).exp() * g.normal();
            }
        }
        for (f, d, a) in [(523.0, 4.0, 0.3), (1410.0, 7.0, 0.2), (2790.0, 12.0, 0.1)] {
            add_mode(&mut x, fs, t0, f, d, a);
        }
        // Started at its peak (a cosine): the sharpest attack a mode can have.
        for (i, v) in x.iter_mut().enumerate().skip(i0) {
            let t = (i - i0) as f64 / fs;
            *v += 0.2 * (-3.0 * t).exp() * (std::f64::consts::TAU * 880.0 * t).cos();
            if soft && t < 0.003 {
                *v *= 0.5 - 0.5 * (std::f64::consts::PI * t / 0.003).cos();
            }
        }
        for v in x.iter_mut() {
            *v += 1e-5 * g.normal();
        }
        let seg = segment(&x, fs);
        let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
        let precursor = seg.skipped.iter().any(|s| estimator::segment::is_precursor(&s.1));
        // (A soft attack's onset is where it reaches 30 % of its rise: within its 3 ms.)
        let tol = if soft { 3e-3 } else { 3e-4 };
        // ... and never a second strike of its own (`restrikes`).
        let again = !seg.restrikes.is_empty();
        if onsets.len() != 1 || (onsets[0] - t0).abs() > tol || onsets[0] < t0 - 3e-4 || precursor || again {
            bad.push((k, onsets, seg.skipped.len()));
        }
    }
    assert!(bad.is_empty(), "(offset in samples, onsets, skipped): {bad:?}");
}

/// A bell of six partials (420–5600 Hz, d 2–28 s⁻¹) struck at `t` with a mallet whose force
/// is a raised-cosine pulse of `pulse_s` (a soft mallet: no click, little above 1/pulse_s) of
/// unit area times `force`: each partial's response is the pulse convolved with its impulse
/// response, evaluated here by direct summation. `slow` divides the decays; `glass` takes a
/// glass of three partials (880/2410/4550 Hz, d 1.5–8 s⁻¹) instead of the bell.
fn soft_bell_strike(x: &mut [f64], fs: f64, t: f64, force: f64, pulse_s: f64, slow: f64, glass: bool) {
    const BELL: [(f64, f64, f64); 6] = [
        (420.0, 2.0, 1.0),
        (1003.0, 5.0, 0.8),
        (1770.0, 9.0, 0.6),
        (2630.0, 14.0, 0.5),
        (3900.0, 20.0, 0.4),
        (5600.0, 28.0, 0.3),
    ];
    const GLASS: [(f64, f64, f64); 3] = [(880.0, 1.5, 1.0), (2410.0, 4.0, 0.5), (4550.0, 8.0, 0.3)];
    let len = (pulse_s * fs).round() as usize;
    let pulse: Vec<f64> = (0..len).map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / len as f64).cos()).collect();
    let area: f64 = pulse.iter().sum();
    let i0 = (t * fs).round() as usize;
    for &(f, d, a) in if glass { &GLASS[..] } else { &BELL[..] } {
        let mut ir = vec![0.0; x.len() - i0];
        add_mode(&mut ir, fs, 0.0, f, d / slow, a);
        for (k, v) in x[i0..].iter_mut().enumerate() {
            let s: f64 = pulse.iter().enumerate().take(k + 1).map(|(m, p)| p * ir[k - m]).sum();
            *v += force * s / area;
        }
    }
}

/// Issue 10 (black-box tester, case B): a second strike on a bell that still rings, with a
/// soft mallet (a 1–4 ms force pulse, no click: it re-excites only the partials already
/// ringing, so no new band rises) or with a click at 0.7 of the first strike's force, 100 ms
/// to 2 s after the first, is an impact of its own starting within 2 ms of the strike. Before
/// the ring predictor, none of the bell's strikes was found while the first rang; the glass's
/// (louder than the first strike's peak) were missed by a first version of it. Noise 90 or
/// 50 dB under the first strike's peak.
#[test]
fn a_second_soft_strike_on_a_ringing_bell_is_found() {
    let fs = 48_000.0;
    let t0 = 0.2;
    let mut missed = Vec::new();
    let mut runs = 0;
    for (k, &(pulse_s, force2, lag, slow, click, glass)) in [
        (0.002, 1.0, 0.1, 1.0, false, false),
        (0.003, 1.0, 0.15, 1.0, false, false),
        (0.004, 1.0, 0.25, 1.0, false, false),
        (0.002, 1.0, 0.5, 1.0, false, false),
        (0.003, 1.0, 1.0, 1.0, false, false),
        (0.004, 1.0, 2.0, 1.0, false, false),
        (0.003, 0.7, 0.15, 1.0, false, false),
        (0.003, 3.0, 0.5, 1.0, false, false),
        (0.002, 10.0, 1.0, 1.0, false, false),
        (0.003, 0.7, 0.1, 1.0, true, false),
        (0.003, 0.7, 0.2, 1.0, true, false),
        (0.003, 0.7, 0.25, 1.0, true, false),
        (0.003, 0.7, 0.3, 5.0, true, false),
        (0.003, 0.7, 0.5, 5.0, true, false),
        // A 1 ms pulse: partials that start in sine phase, little broadband (the tester's
        // misses with a one-step predictor).
        (0.001, 1.0, 0.5, 5.0, false, false),
        (0.001, 0.7, 0.5, 1.0, false, false),
        // A glass (880/2410/4550 Hz, d 1.5–8 s⁻¹) whose second strike is louder than the
        // first's peak (the tester's misses: that frame became the ring's peak).
        (0.004, 1.0, 0.1, 1.0, false, true),
        (0.004, 3.0, 1.0, 1.0, false, true),
    ]
    .iter()
    .enumerate()
    {
        runs += 1;
        let mut g = Gen(1900 + k as u64);
        // White noise 90 or 50 dB under the first strike's peak.
        let noise = if k % 2 == 0 { 1e-5 } else { 1e-3 };
        let mut x = vec![0.0; ((t0 + lag + 0.6) * fs) as usize];
        for (t, force) in [(t0, 1.0), (t0 + lag, force2)] {
            soft_bell_strike(&mut x, fs, t, force, pulse_s, slow, glass);
            if click {
                let i0 = (t * fs).round() as usize;
                for i in 0..(0.001 * fs) as usize {
                    x[i0 + i] += 0.1 * force * (-(i as f64) / (0.0002 * fs)).exp() * g.normal();
                }
            }
        }
        let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for v in x.iter_mut() {
            *v = 0.3 * *v / peak + noise * g.normal();
        }
        let seg = segment(&x, fs);
        let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
        let ok = onsets.len() == 2 && (onsets[0] - t0).abs() < 2e-3 && (onsets[1] - t0 - lag).abs() < 2e-3;
        eprintln!("pulse {pulse_s} s, force {force2}, {lag} s later, decays / {slow}, click {click}, glass {glass}, noise {noise}: {onsets:?}");
        if !ok {
            missed.push((pulse_s, force2, lag, slow, click, glass, noise, onsets));
        }
    }
    assert!(missed.is_empty(), "{} of {runs} missed: {missed:?}", missed.len());
}

/// A low drum struck once (a tom's partials: 110, 175, 236, 290 Hz at d = 8–15 s⁻¹, scaled
/// to fundamentals of 55–220 Hz and decays down to 0.3×): one impact within 1 ms of the
/// strike. Its partials lie within a few of the 40 ms window's 23 Hz bins and it falls only
/// a few dB in the first 100 ms, so it was neither tonal nor fast and was reported as "the
/// background noise starts or changes" ("no impacts found"; issue 10, found by a black-box
/// tester). What must stay a noise step: a room's decaying noise after a tick, and a hum that
/// starts mid-file.
#[test]
fn a_low_drum_is_a_strike_and_a_room_tail_is_not() {
    let tom = [(110.0, 8.0, 1.0), (175.0, 10.0, 0.6), (236.0, 12.0, 0.4), (290.0, 15.0, 0.3)];
    let mut g = Gen(110);
    let mut bad = Vec::new();
    let mut case = 0;
    for f0 in [55.0, 110.0, 220.0] {
        for slow in [1.0, 0.3] {
            for noise in [1e-3, 1e-5] {
                case += 1;
                let fs = if case % 2 == 0 { 44_100.0 } else { 48_000.0 };
                let mut x = vec![0.0; (2.5 * fs) as usize];
                for &(f, d, a) in &tom {
                    add_mode(&mut x, fs, 0.2, f * f0 / 110.0, d * slow, a);
                }
                let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for v in &mut x {
                    *v = 0.3 * *v / peak + noise * g.normal();
                }
                let s = segment(&x, fs);
                let onsets: Vec<f64> = s.impacts.iter().map(|i| i.start as f64 / fs).collect();
                if onsets.len() != 1 || (onsets[0] - 0.2).abs() > 1e-3 {
                    bad.push((f0, slow, noise, onsets, s.noise_steps.len()));
                }
            }
        }
    }
    assert!(bad.is_empty(), "{} of {case} low drums wrong: {bad:?}", bad.len());

    // A tick (1 ms of noise) and the room's reverberation: noise decaying with T60 0.5–2 s,
    // 20 dB under the tick. No partial: no strike of an object.
    for t60 in [0.5, 1.0, 2.0] {
        let fs = 48_000.0;
        let mut x: Vec<f64> = (0..(3.0 * fs) as usize).map(|_| 1e-5 * g.normal()).collect();
        let i0 = (0.2 * fs) as usize;
        for v in &mut x[i0..i0 + 48] {
            *v += 0.3 * g.normal();
        }
        let d = 6.91 / t60;
        let mut lp = 0.0;
        for (i, v) in x[i0..].iter_mut().enumerate() {
            // A one-pole low-pass (a room's absorption of the highs): a coloured, untonal tail.
            lp = 0.7 * lp + 0.3 * g.normal();
            *v += 0.03 * (-d * i as f64 / fs).exp() * lp;
        }
        let s = segment(&x, fs);
        assert!(s.impacts.len() <= 1, "T60 {t60}: {:?}", s.impacts);
        // The tick itself may be an impact of its own (it is fast); the tail never another.
        for imp in &s.impacts {
            assert!((imp.start as f64 / fs - 0.2).abs() < 2e-3, "T60 {t60}: {:?}", s.impacts);
        }
    }

    // A hum (50 Hz and its harmonics, as mains hum is) that starts at 1 s and goes on.
    let fs = 48_000.0;
    let mut x: Vec<f64> = (0..(3.0 * fs) as usize).map(|_| 1e-5 * g.normal()).collect();
    for (i, v) in x.iter_mut().enumerate().skip(fs as usize) {
        let t = i as f64 / fs;
        *v += (1..=5).map(|k| 0.02 / k as f64 * (std::f64::consts::TAU * 50.0 * k as f64 * t).sin()).sum::<f64>();
    }
    let s = segment(&x, fs);
    assert!(s.impacts.is_empty(), "hum: {:?}", s.impacts);
    // Its start is a noise step (a ripple in its first 40 ms may be one more), what follows
    // none (it gave one every 20 ms).
    assert!(!s.noise_steps.is_empty() && s.noise_steps.len() <= 2, "hum: {:?}", s.noise_steps);
    assert!(s.noise_steps.iter().all(|&i| (i as f64 / fs - 1.0).abs() < 0.045), "hum: {:?}", s.noise_steps);

    // A noise floor that starts 2–15 ms before a strike (a gate with look-ahead opening on
    // digital silence): the strike rises during the hold after that step, and is found.
    for lead in [0.002, 0.006, 0.015] {
        let fs = 48_000.0;
        let mut x = vec![0.0; (1.5 * fs) as usize];
        let t0 = 0.5;
        for v in &mut x[((t0 - lead) * fs) as usize..] {
            *v += 3e-4 * g.normal();
        }
        for &(f, d, a) in &[(523.0, 6.0, 0.2), (1410.0, 11.0, 0.1), (2750.0, 19.0, 0.05)] {
            add_mode(&mut x, fs, t0, f, d, a);
        }
        let s = segment(&x, fs);
        let onsets: Vec<f64> = s.impacts.iter().map(|i| i.start as f64 / fs).collect();
        assert!(
            onsets.len() == 1 && (onsets[0] - t0).abs() < 2e-3,
            "noise {lead} s before the strike: {onsets:?}, steps {:?}",
            s.noise_steps
        );
    }
}

/// A file whose only sound is a tick (one sample, no ring): it is found, but no mode rings in
/// it, and the error says so (it said "no impacts found … record taps well above the
/// background noise", which is wrong advice for a tick 90 dB over the floor).
#[test]
fn a_bare_tick_is_found_and_the_error_says_it_does_not_ring() {
    let fs = 48_000.0;
    let mut g = Gen(328);
    let mut x: Vec<f64> = (0..(1.0 * fs) as usize).map(|_| 1e-4 * g.normal()).collect();
    x[(0.2 * fs) as usize] += 0.3;
    let p = write("bare-tick", &x, fs as u32);
    let msg = features(&p).expect_err("a bare tick has no modes").to_string();
    assert!(msg.contains(": 1 found,") && msg.contains("no modal features"), "{msg}");
    assert!(!msg.contains('\n'), "{msg}");
}

/// A soft strike of a bell, then the same bell struck 3× harder 80–240 ms later (10–12 dB
/// louder, decays as they are and 5× slower): two impacts, each within 2 ms of its strike
/// (the black-box tester's grid lost 30 of these first strikes as the second one's
/// "precursor"). A music box's pin scrape 12 dB under the release, rising 4 dB over its 50
/// ms, is still the release's precursor (skipped, one impact at the release).
#[test]
fn a_soft_strike_then_a_harder_one_soon_after_are_two_strikes() {
    let fs = 48_000.0;
    let t0 = 0.2;
    let mut missed = Vec::new();
    for (k, &(lag, slow)) in [
        (0.08, 1.0),
        (0.1, 1.0),
        (0.12, 1.0),
        (0.15, 1.0),
        (0.24, 1.0),
        (0.08, 5.0),
        (0.1, 5.0),
        (0.12, 5.0),
        (0.15, 5.0),
        (0.24, 5.0),
    ]
    .iter()
    .enumerate()
    {
        let mut g = Gen(2100 + k as u64);
        let mut x = vec![0.0; ((t0 + lag + 0.6) * fs) as usize];
        soft_bell_strike(&mut x, fs, t0, 1.0, 0.003, slow, false);
        soft_bell_strike(&mut x, fs, t0 + lag, 3.0, 0.003, slow, false);
        let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for v in x.iter_mut() {
            *v = 0.3 * *v / peak + 1e-5 * g.normal();
        }
        let seg = segment(&x, fs);
        let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
        eprintln!(
            "3x harder {lag} s later, decays / {slow}: {onsets:?}, skipped {:?}, restrikes {:?}",
            seg.skipped, seg.restrikes
        );
        if !(onsets.len() == 2 && (onsets[0] - t0).abs() < 2e-3 && (onsets[1] - t0 - lag).abs() < 2e-3) {
            missed.push((lag, slow, onsets));
        }
    }
    assert!(missed.is_empty(), "{missed:?}");

    // The pin scrape: band noise at 3 kHz rising 4 dB over 50 ms, 12 dB under the release.
    let mut g = Gen(2200);
    let t1 = 0.3;
    let mut x = vec![0.0; (1.2 * fs) as usize];
    let i0 = ((t1 - 0.05) * fs) as usize;
    for i in 0..(0.05 * fs) as usize {
        let rise = 10f64.powf(4.0 / 20.0 * i as f64 / (0.05 * fs));
        x[i0 + i] += 0.04 * rise * (std::f64::consts::TAU * 3000.0 * i as f64 / fs).sin() * (1.0 + 0.3 * g.normal());
    }
    for (f, d, a) in [(1568.0, 4.0, 0.3), (4700.0, 9.0, 0.1)] {
        add_mode(&mut x, fs, t1, f, d, a);
    }
    for v in x.iter_mut() {
        *v += 1e-5 * g.normal();
    }
    let seg = segment(&x, fs);
    let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
    assert_eq!(onsets.len(), 1, "{onsets:?}");
    assert!((onsets[0] - t1).abs() < 1e-3, "{onsets:?}");
    assert!(seg.skipped.iter().any(|s| s.1.contains("precursor")), "{:?}", seg.skipped);
}

/// A soft strike 20 or 26 dB under a hard one 120–240 ms later (an independent black-box
/// tester's case: four modes 440–3500 Hz decaying at 3–20 s⁻¹, a 1 ms click): two impacts,
/// each within 2 ms of its strike. The soft one was taken as the hard one's "precursor"
/// (15 dB or more under it), though its ring had decayed; a ring that fell 3 dB since its
/// first 10 ms is a strike of its own.
#[test]
fn a_much_softer_strike_that_decayed_is_not_a_precursor() {
    let fs = 48_000.0;
    let mut missed = Vec::new();
    for (k, &(soft, lag)) in
        [(0.1, 0.12), (0.1, 0.18), (0.1, 0.24), (0.05, 0.12), (0.05, 0.18), (0.05, 0.24)].iter().enumerate()
    {
        let mut g = Gen(2400 + k as u64);
        let t0: f64 = 0.2;
        let mut x = vec![0.0; ((t0 + lag + 1.2) * fs) as usize];
        for (t, a) in [(t0, soft), (t0 + lag, 1.0f64)] {
            let c = (t * fs).round() as usize;
            for i in 0..48 {
                x[c + i] += a * 0.3 * g.normal() * (0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / 48.0).cos());
            }
            for (f, d, m) in [(440.0, 3.0, 1.0), (1130.0, 6.0, 0.6), (2210.0, 12.0, 0.4), (3500.0, 20.0, 0.25)] {
                add_mode(&mut x, fs, t, f, d, a * m);
            }
        }
        for v in x.iter_mut() {
            *v = 0.3 * *v + 1e-4 * g.normal();
        }
        let seg = segment(&x, fs);
        let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
        eprintln!("soft {soft}, hard {lag} s later: {onsets:?}, skipped {:?}", seg.skipped);
        if !(onsets.len() == 2 && (onsets[0] - t0).abs() < 2e-3 && (onsets[1] - t0 - lag).abs() < 2e-3) {
            missed.push((soft, lag, onsets));
        }
    }
    assert!(missed.is_empty(), "{missed:?}");
}

/// A music box's note at 44.1 kHz, 1.2 s: from `t0` the pushed tooth's fundamental and the
/// pin's scrape, rising `swell_db` over `rise_s` and then held, up to the release at `t1`
/// `step_db` over the swell (the pin's click as it slips off, and the tooth ringing free).
/// Noise 100 dB down.
fn music_box(g: &mut Gen, t0: f64, rise_s: f64, t1: f64, swell_db: f64, step_db: f64) -> Vec<f64> {
    let fs = 44_100.0;
    let mut x = vec![0.0; (1.2 * fs) as usize];
    let i0 = (t0 * fs) as usize;
    let a0 = 0.2 * 10f64.powf(-(swell_db + step_db) / 20.0);
    for i in 0..((t1 - t0) * fs) as usize {
        let t = i as f64 / fs;
        let a = a0 * 10f64.powf(swell_db / 20.0 * (t / rise_s).min(1.0));
        let tone = (std::f64::consts::TAU * 330.0 * t).sin();
        let scrape = (std::f64::consts::TAU * 2000.0 * t).sin() * (1.0 + 0.3 * g.normal());
        x[i0 + i] += a * (tone + 0.3 * scrape);
    }
    let c1 = (t1 * fs).round() as usize;
    for i in 0..(0.001 * fs) as usize {
        x[c1 + i] += 0.6 * (-(i as f64) / (0.0003 * fs)).exp() * g.normal();
    }
    for (f, d, a) in [(330.0, 2.5, 0.2), (7160.0, 27.0, 0.2), (8118.0, 20.0, 0.04)] {
        add_mode(&mut x, fs, t1, f, d, a);
    }
    for v in x.iter_mut() {
        *v += 1e-5 * g.normal();
    }
    x
}

/// A music box's pin pressing the tooth until it slips off (FluidR3's music box at key 64 in
/// `tests/recordings`): the tooth sounds while it is pushed, swelling 11 dB over 45 ms, and
/// the release that follows (a click and the free tooth) is only 2–4 dB over the swell — not the 10 dB that makes a quiet
/// onset a precursor. The swell is still the release's precursor (it never decayed): one
/// impact at the release, the swell skipped as its precursor. (It was an impact of its own,
/// its rising features in the material's fit.) The soft-strike-then-harder test above keeps
/// a first strike that decays an impact of its own.
#[test]
fn a_swell_that_is_still_rising_is_the_precursor_of_the_release() {
    let fs = 44_100.0;
    for (k, &(swell_db, step_db)) in [(11.0, 2.0), (11.0, 4.0), (6.0, 3.0), (15.0, 2.0)].iter().enumerate() {
        let mut g = Gen(2300 + k as u64);
        // The recording's swell: 320 Hz and broad bands at 1–3.5 kHz, rising 11 dB to 45 ms,
        // then within 1 dB to the release at 70 ms.
        let t1 = 0.3 + 0.07;
        let x = music_box(&mut g, 0.3, 0.045, t1, swell_db, step_db);
        let seg = segment(&x, fs);
        let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
        eprintln!("swell {swell_db} dB, release {step_db} dB over it: {onsets:?}, skipped {:?}", seg.skipped);
        assert_eq!(onsets.len(), 1, "swell {swell_db} dB, step {step_db} dB: {onsets:?}");
        assert!((onsets[0] - t1).abs() < 2e-3, "swell {swell_db} dB, step {step_db} dB: {onsets:?}");
        assert!(seg.skipped.iter().any(|s| estimator::segment::is_precursor(&s.1)), "{:?}", seg.skipped);
    }
}

/// FluidR3's music box at key 73 (`tests/recordings`): the pin presses the tooth, which
/// sounds rising 13 dB over 35 ms and then holds, and the release 62 ms in is only 1–2 dB
/// over that (but 35 dB up above 6 kHz). The onsets' rules pass it over (the swell is no
/// longer rising when it comes, and it is 1–2 dB); the ring predictor finds it inside the
/// impact, and the swell — it rose and never decayed — is its precursor: one impact at the
/// release, 55–85 ms after the swell's start. (It was one impact from the swell's start.
/// Known limit: a release exactly at the end of the 50 ms minimum gap is an onset of its own,
/// and a swell that is no longer rising then stays an impact of its own.)
#[test]
fn a_swell_that_levelled_off_is_the_precursor_of_the_release_inside_it() {
    let mut bad = Vec::new();
    for (k, &(swell_db, step_db, hold_s)) in
        [(13.0, 1.4, 0.027), (13.0, 3.0, 0.027), (9.0, 2.0, 0.04), (13.0, 2.0, 0.02), (13.0, 2.0, 0.05)]
            .iter()
            .enumerate()
    {
        let mut g = Gen(2400 + k as u64);
        let t1 = 0.3 + 0.035 + hold_s;
        let x = music_box(&mut g, 0.3, 0.035, t1, swell_db, step_db);
        let r = features(&write(&format!("levelled-swell-{k}"), &x, 44_100)).unwrap();
        let onsets: Vec<f64> = r.impacts.iter().map(|i| i.onset_s).collect();
        let precursor = r.skipped.iter().any(|s| estimator::segment::is_precursor(&s.reason));
        eprintln!(
            "swell {swell_db} dB, held {hold_s} s, release {step_db} dB over it: {onsets:?}, skipped {:?}",
            r.skipped
        );
        if onsets.len() != 1 || (onsets[0] - t1).abs() > 2e-3 || !precursor {
            bad.push((swell_db, step_db, hold_s, onsets));
        }
    }
    assert!(bad.is_empty(), "(swell dB, release dB, held s, onsets): {bad:?}");
}

/// A second soft-mallet strike (a 3 ms force pulse, no click: only the partials already
/// ringing rise) 55–70 ms after the first, as hard or 3× harder, decays as they are and 5×
/// slower: two impacts, the second within 2 ms of its strike. The ring predictor fired from
/// 75 ms on (it trained on 40 ms of ring that began 5 ms after the onset); it now trains on
/// what ring there is, 20 ms at least, and all 20 were one impact without a warning before.
/// (At 50 ms, the end of the minimum gap, they still are.)
#[test]
fn a_soft_mallet_restrike_55_to_70_ms_later_is_found() {
    let fs = 48_000.0;
    let t0 = 0.2;
    let mut missed = Vec::new();
    let mut k = 0;
    for lag in [0.055, 0.06, 0.0625, 0.065, 0.07] {
        for (force2, slow) in [(1.0, 1.0), (3.0, 1.0), (1.0, 5.0), (3.0, 5.0)] {
            k += 1;
            let mut g = Gen(2300 + k);
            let noise = if k % 2 == 0 { 1e-5 } else { 1e-3 };
            let mut x = vec![0.0; ((t0 + lag + 0.6) * fs) as usize];
            soft_bell_strike(&mut x, fs, t0, 1.0, 0.003, slow, false);
            soft_bell_strike(&mut x, fs, t0 + lag, force2, 0.003, slow, false);
            let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for v in x.iter_mut() {
                *v = 0.3 * *v / peak + noise * g.normal();
            }
            let seg = segment(&x, fs);
            let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
            eprintln!(
                "{force2}x, {lag} s later, decays / {slow}, noise {noise}: {onsets:?}, restrikes {:?}",
                seg.restrikes
            );
            if !(onsets.len() == 2 && (onsets[0] - t0).abs() < 2e-3 && (onsets[1] - t0 - lag).abs() < 2e-3) {
                missed.push((force2, lag, slow, onsets));
            }
        }
    }
    assert!(missed.is_empty(), "{} of 20 missed: {missed:?}", missed.len());
}

/// A single strike whose sample was faded out over its last 50 ms (linear or raised cosine,
/// into digital silence or noise 70 dB down, as sample-library tails are): one impact, and no
/// strike reported where the fade begins (a reviewer's files: 26 of 120 reported one before
/// the predictor's error had to settle after a strike). Bell partials; 16-bit.
#[test]
fn a_faded_tail_is_no_strike() {
    let fs = 44_100.0;
    let mut bad = Vec::new();
    for (k, &len) in [0.3, 0.5, 1.0].iter().enumerate() {
        for cosine in [false, true] {
            for noise in [0.0, 0.5 * 10f64.powf(-70.0 / 20.0)] {
                let mut g = Gen(7000 + 4 * k as u64 + 2 * u64::from(cosine) + u64::from(noise > 0.0));
                let mut h = vec![0.0; (len * fs) as usize];
                for &(f, d, a) in ROLL_OBJECTS[1] {
                    add_mode(&mut h, fs, 0.0, f, d, a);
                }
                let (n, m) = (h.len(), (0.05 * fs) as usize);
                for i in 0..m {
                    let u = i as f64 / m as f64;
                    h[n - m + i] *= if cosine { 0.5 + 0.5 * (std::f64::consts::PI * u).cos() } else { 1.0 - u };
                }
                let peak = h.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                let mut x = vec![0.0; ((0.1 + len + 0.5) * fs) as usize];
                let i0 = (0.1 * fs) as usize;
                for (i, v) in h.iter().enumerate() {
                    x[i0 + i] = 0.5 * v / peak;
                }
                for v in x.iter_mut() {
                    *v = ((*v + noise * g.normal()) * 32_768.0).round() / 32_768.0;
                }
                let seg = segment(&x, fs);
                if seg.impacts.len() != 1 || !seg.restrikes.is_empty() {
                    bad.push((len, cosine, noise, seg.impacts.len(), seg.restrikes.clone()));
                }
            }
        }
    }
    assert!(bad.is_empty(), "(length, cosine, noise, impacts, reported): {bad:?}");
}

/// The same soft mallet 45–55 ms after the first strike, at the end of the minimum gap (a
/// known limit until stop 32: one impact, no warning; the in-gap rule needs a broad rise):
/// now an impact of its own or reported inside the first, within 2 ms; where it cuts the
/// first, the warning names the impact its part became (stop 56).
#[test]
fn a_soft_mallet_restrike_at_the_end_of_the_gap_is_cut_or_reported() {
    let fs = 48_000.0;
    let t0 = 0.2;
    let (mut missed, mut said_cuts) = (Vec::new(), 0);
    for (k, lag) in [0.045, 0.048, 0.05, 0.052, 0.055].into_iter().enumerate() {
        for force2 in [1.0, 3.0] {
            let mut g = Gen(2400 + 2 * k as u64 + force2 as u64);
            let mut x = vec![0.0; ((t0 + lag + 0.4) * fs) as usize];
            soft_bell_strike(&mut x, fs, t0, 1.0, 0.003, 1.0, false);
            soft_bell_strike(&mut x, fs, t0 + lag, force2, 0.003, 1.0, false);
            let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for v in x.iter_mut() {
                *v = 0.3 * *v / peak + 1e-5 * g.normal();
            }
            let seg = segment(&x, fs);
            let onsets: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
            let again: Vec<f64> = seg.restrikes.iter().map(|r| r.0 as f64 / fs).collect();
            eprintln!("{force2}x, {lag} s later: {onsets:?}, reported {again:?}");
            if !seg.cuts.is_empty() {
                // A cut is said as the report shows it: the part from the strike is an impact
                // of its own, starting there (a tester read "not taken as an onset" beside it).
                let r = features(&write(&format!("restrike-cut-{k}-{force2}"), &x, fs as u32)).unwrap();
                let key = "as an impact of its own (the strike's part from ";
                let w = r.warnings.iter().find(|w| w.contains(key)).expect("the cut is said");
                let at: f64 = w.split(key).nth(1).and_then(|t| t.split(' ').next()).unwrap().parse().unwrap();
                assert!(r.impacts.iter().any(|i| (i.onset_s - at).abs() < 2e-3), "{w}: no impact at {at} s");
                assert!(!w.contains("not taken as an onset"), "{w}");
                said_cuts += 1;
            }
            let second = match (onsets.len(), again.len()) {
                (2, 0) => onsets[1],
                (1, 1) => again[0],
                _ => f64::NAN,
            };
            if !((onsets[0] - t0).abs() < 2e-3 && (second - t0 - lag).abs() < 2e-3) {
                missed.push((force2, lag, onsets, again));
            }
        }
    }
    assert!(missed.is_empty(), "{} of 10 missed: {missed:?}", missed.len());
    // (6 of the 10 are cuts, each said with its impact.)
    assert!(said_cuts >= 3, "{said_cuts} cuts said: the check checks little");
}

/// A file that starts with a steady sound that is not its loudest (a mains hum or a room tone
/// running from the first sample, as the black-box tester's files did): no impact at 0 (there
/// was one at 0.001 s, whose undamped "modes" went into the fit and gave an undamped
/// material); the strikes later are found. A soft strike that starts the file and decays is
/// still an impact.
#[test]
fn a_hum_from_the_first_sample_is_not_a_strike() {
    let mut g = Gen(41);
    let fs = 48_000.0;
    // Pure or with harmonics, with a noise floor or quantised to 16 bits with none.
    for (hum_hz, level, harmonics, noise) in [
        (50.0, 0.01, 1, 0.0),
        (60.0, 0.02, 1, 0.0),
        (50.0, 0.01, 3, 1e-5),
        (50.0, 0.003, 3, 1e-5),
        (60.0, 0.05, 1, 0.0),
    ] {
        let mut x: Vec<f64> = (0..(3.0 * fs) as usize)
            .map(|i| {
                let t = i as f64 / fs;
                noise * g.normal()
                    + (1..=harmonics)
                        .map(|k| level / k as f64 * (std::f64::consts::TAU * hum_hz * k as f64 * t).sin())
                        .sum::<f64>()
            })
            .collect();
        for t0 in [0.5, 1.7] {
            for &(f, d, a) in &[(700.0, 4.0, 0.5), (1830.0, 9.0, 0.2)] {
                add_mode(&mut x, fs, t0, f, d, a);
            }
        }
        if noise == 0.0 {
            x.iter_mut().for_each(|v| *v = (*v * 32_768.0).round() / 32_768.0);
        }
        let s = segment(&x, fs);
        let onsets: Vec<f64> = s.impacts.iter().map(|i| i.start as f64 / fs).collect();
        assert_eq!(onsets.len(), 2, "{hum_hz} Hz at {level}: {onsets:?}");
        assert!((onsets[0] - 0.5).abs() < 3e-3 && (onsets[1] - 1.7).abs() < 3e-3, "{onsets:?}");
    }
    // A singing bowl struck softly at sample 0 (partials decaying at 0.2, 0.4 and 0.8 s⁻¹, no
    // click: under 1 dB in its first 0.2 s) and 14 dB louder at 3 s: two strikes.
    let mut x: Vec<f64> = (0..(4.0 * fs) as usize).map(|_| 1e-5 * g.normal()).collect();
    for (t0, scale) in [(0.0, 1.0), (3.0, 5.0)] {
        for &(f, d, a) in &[(220.0, 0.2, 0.02), (590.0, 0.4, 0.015), (1100.0, 0.8, 0.01)] {
            add_mode(&mut x, fs, t0, f, d, a * scale);
        }
    }
    let s = segment(&x, fs);
    let onsets: Vec<f64> = s.impacts.iter().map(|i| i.start as f64 / fs).collect();
    assert_eq!(onsets.len(), 2, "bowl: {onsets:?}");
    assert!(onsets[0] < 2e-3 && (onsets[1] - 3.0).abs() < 3e-3, "bowl: {onsets:?}");
    // A soft strike at sample 0 (decay 3 s⁻¹: 2.6 dB in 0.2 s), a louder one at 1 s.
    let mut x: Vec<f64> = (0..(2.5 * fs) as usize).map(|_| 1e-5 * g.normal()).collect();
    add_mode(&mut x, fs, 0.0, 880.0, 3.0, 0.05);
    add_mode(&mut x, fs, 1.0, 660.0, 5.0, 0.6);
    let s = segment(&x, fs);
    let onsets: Vec<f64> = s.impacts.iter().map(|i| i.start as f64 / fs).collect();
    assert_eq!(onsets.len(), 2, "{onsets:?}");
    assert!(onsets[0] < 2e-3 && (onsets[1] - 1.0).abs() < 3e-3, "{onsets:?}");
}

/// The roll tests' objects: the black-box tester's seven partials (220–4,100 Hz), a bell, a
/// glass. (Hz, s⁻¹, amplitude.)
const ROLL_OBJECTS: [&[(f64, f64, f64)]; 3] = [
    &[
        (220.0, 3.0, 1.0),
        (530.0, 3.6, 0.8),
        (910.0, 4.7, 0.65),
        (1400.0, 7.0, 0.55),
        (2100.0, 12.0, 0.45),
        (2950.0, 20.0, 0.4),
        (4100.0, 36.0, 0.35),
    ],
    &[(420.0, 2.0, 1.0), (1003.0, 5.0, 0.8), (1770.0, 9.0, 0.6), (2630.0, 14.0, 0.5), (3900.0, 20.0, 0.4)],
    &[(880.0, 1.5, 1.0), (2410.0, 4.0, 0.5), (4550.0, 8.0, 0.3)],
];

/// `n` strikes of `modes` `spacing` s apart from 0.05 s on at 44.1 kHz, each 0.7–1.4 times
/// the first's force (impulses: partials in sine phase), in white noise `noise` times the
/// first strike's peak. Returns the samples and the strike times.
fn roll(modes: &[(f64, f64, f64)], n: usize, spacing: f64, noise: f64, g: &mut Gen) -> (Vec<f64>, Vec<f64>) {
    let fs = 44_100.0;
    let t0 = 0.05;
    let mut x = vec![0.0; ((t0 + n as f64 * spacing + 0.3) * fs) as usize];
    let times: Vec<f64> = (0..n).map(|k| t0 + k as f64 * spacing).collect();
    for &t in &times {
        let force = 0.7 + 0.7 * g.u();
        for &(f, d, a) in modes {
            add_mode(&mut x, fs, t, f, d, 0.01 * force * a);
        }
    }
    let first_peak = x[..((t0 + 0.01) * fs) as usize].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for v in x.iter_mut() {
        *v += noise * first_peak * g.normal();
    }
    (x, times)
}

/// Whether every strike of `times` is an onset or a reported strike of `seg`, within 2 ms, and
/// nothing else is.
fn every_strike_accounted(seg: &estimator::segment::Segmentation, times: &[f64], fs: f64) -> bool {
    let mut events: Vec<f64> = seg.impacts.iter().map(|i| i.start as f64 / fs).collect();
    events.extend(seg.restrikes.iter().map(|r| r.0 as f64 / fs));
    events.sort_by(f64::total_cmp);
    events.len() == times.len() && events.iter().zip(times).all(|(a, b)| (a - b).abs() < 2e-3)
}

/// A roll: one object struck again and again while it rings, 55–150 ms apart, each strike
/// 0.7–1.4 times the first's force, in white noise 40–43 dB under the first strike's peak
/// (the black-box tester's `roll100`: from the third strike on, all merged into one 2.35 s
/// impact whose "modes" were a comb 10 Hz apart, and no warning). Once the ring builds up a
/// strike adds only 2–5 dB, so only the ring predictor can see it: with 24 consecutive
/// regressors it predicted these rings no better than zero. Every strike must be an impact
/// starting within 2 ms of it or, where it lowered the energy (a strike in antiphase to the
/// ring: the onsets' search needs the energy to rise), be reported inside the impact it falls
/// in, within 2 ms; at least 125 of the 144 are impacts (129 measured).
#[test]
fn every_strike_of_a_roll_is_found() {
    let fs = 44_100.0;
    let mut missed = Vec::new();
    let (mut cut, mut strikes) = (0, 0);
    let mut runs = 0;
    for (o, modes) in ROLL_OBJECTS.iter().enumerate() {
        for &spacing in &[0.055, 0.07, 0.1, 0.15] {
            runs += 1;
            let mut g = Gen(5100 + 10 * o as u64 + (spacing * 1000.0) as u64);
            let n = 12;
            let (x, times) = roll(modes, n, spacing, if runs % 2 == 0 { 0.01 } else { 0.007 }, &mut g);
            let seg = segment(&x, fs);
            let ok = every_strike_accounted(&seg, &times, fs);
            eprintln!("object {o}, {spacing} s apart: {} impacts, {} reported", seg.impacts.len(), seg.restrikes.len());
            cut += seg.impacts.len();
            strikes += n;
            if !ok {
                missed.push((o, spacing, seg.impacts.len(), seg.restrikes.len()));
            }
        }
    }
    assert!(missed.is_empty(), "{} of {runs} rolls not cut or reported at every strike: {missed:?}", missed.len());
    assert!(cut >= 125, "{cut} of {strikes} strikes are impacts of their own");
}

/// The strikes of a roll that only the ring predictor found (they lowered the ring's energy,
/// in antiphase to it, so they are no onsets) cut the impact they fall in where the ring's
/// spectrum rose (`Segmentation::cuts`: some partials re-excited): what is analysed then is
/// the object's modes, not a blend of two strikes' envelopes. (Before, every such impact ran
/// across its strike: the black-box tester's roll gave a 1130 Hz feature at d = 1.3 s⁻¹ for a
/// true 6 and a made-up 444.5 Hz, and they went into the fit.) The rolls of
/// `every_strike_of_a_roll_is_found` that have such strikes, through the whole pipeline: every
/// impact of the report starts within 2 ms of a strike; in each impact that holds one strike,
/// every feature within 30 dB of the strongest lies within 0.5 % of a true mode, and the
/// strongest partial decays within 25 % of its true rate (impacts of 100 ms or more); at
/// least 7 of the strikes found inside impacts cut them (8 of 15 measured, none before: the
/// others lowered the ring in every band that holds its power, as a sound that stops does,
/// and stay in the impact before, warned).
#[test]
fn strikes_found_inside_an_impact_cut_it() {
    let fs = 44_100.0;
    let (mut rolls, mut inside, mut cuts, mut spanned, mut bad) = (0, 0, 0, 0, Vec::new());
    let mut runs = 0;
    for (o, modes) in ROLL_OBJECTS.iter().enumerate() {
        for &spacing in &[0.055, 0.07, 0.1, 0.15] {
            runs += 1;
            let mut g = Gen(5100 + 10 * o as u64 + (spacing * 1000.0) as u64);
            let (x, times) = roll(modes, 12, spacing, if runs % 2 == 0 { 0.01 } else { 0.007 }, &mut g);
            let seg = segment(&x, fs);
            if seg.restrikes.is_empty() {
                continue;
            }
            rolls += 1;
            inside += seg.restrikes.len();
            cuts += seg.cuts.len();
            let r = features(&write(&format!("roll-cut-{o}-{spacing}"), &x, 44_100)).unwrap();
            for imp in &r.impacts {
                let (a, b) = (imp.onset_s, imp.onset_s + imp.duration_s);
                let Some(k) = times.iter().position(|&t| (t - a).abs() < 2e-3) else {
                    bad.push(format!("{o} {spacing}: impact {a:.4}–{b:.4} s starts at no strike {times:.4?}"));
                    continue;
                };
                let across = times[k + 1..].iter().filter(|&&t| t < b).count();
                spanned += across;
                if across > 0 {
                    // (Such an impact still gets made-up partials: 401.1, 436.5 and 1017.7 Hz
                    // in one of these.)
                    continue;
                }
                let top = imp.features.iter().fold(0.0f64, |m, f| m.max(f.amplitude));
                for f in imp.features.iter().filter(|f| f.amplitude >= top * 10f64.powf(-30.0 / 20.0)) {
                    if !modes.iter().any(|m| (f.freq_hz / m.0 - 1.0).abs() < 0.005) {
                        bad.push(format!("{o} {spacing}: impact at {a:.4} s: made-up {:.1} Hz", f.freq_hz));
                    }
                }
                let strongest = imp.features.iter().max_by(|p, q| p.amplitude.total_cmp(&q.amplitude));
                if let (Some(f), true) = (strongest, imp.duration_s >= 0.1) {
                    let m = modes.iter().min_by(|p, q| (p.0 - f.freq_hz).abs().total_cmp(&(q.0 - f.freq_hz).abs()));
                    let d = m.map_or(f64::NAN, |m| m.1);
                    if !((f.decay_per_s / d - 1.0).abs() <= 0.25) {
                        bad.push(format!(
                            "{o} {spacing}: impact at {a:.4} s: {:.1} Hz decays at {:.2} for {d}",
                            f.freq_hz, f.decay_per_s
                        ));
                    }
                }
            }
        }
    }
    eprintln!(
        "{rolls} rolls: {inside} strikes found inside impacts, {cuts} cut, {spanned} still inside an analysed one"
    );
    assert!(rolls >= 3 && inside >= 12, "{rolls} rolls, {inside} strikes inside impacts: the test tests little");
    assert!(cuts >= 7, "only {cuts} of {inside} strikes inside impacts cut them");
    assert_eq!(cuts + spanned, inside, "a strike neither cut nor inside an analysed impact");
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// Impacts that are no modes (the black-box tester's low-passed noise bursts gave a
/// material with a Ren product of 0.96 and no warning) are told from strikes of an object by
/// whether they ring at the same frequencies: five bursts of noise low-passed at 2 kHz
/// (two one-pole sections) with a 25 ms decay get the warning; an object of six partials
/// struck four times with other amplitudes each time (a strike elsewhere on it), in noise
/// 50 dB down, and a woodblock's short strikes (120–400 s⁻¹) six times do not.
#[test]
fn noise_bursts_are_said_to_share_no_partials() {
    let fs = 44_100.0;
    let mut g = Gen(7300);
    let mut x = vec![0.0; (4.0 * fs) as usize];
    let pole = (-std::f64::consts::TAU * 2000.0 / fs).exp();
    for k in 0..5 {
        let i0 = ((0.3 + 0.7 * k as f64) * fs) as usize;
        let (mut s1, mut s2) = (0.0, 0.0);
        for i in 0..(0.08 * fs) as usize {
            let t = i as f64 / fs;
            s1 = pole * s1 + (1.0 - pole) * g.normal() * (-40.0 * t).exp();
            s2 = pole * s2 + (1.0 - pole) * s1;
            x[i0 + i] += s2;
        }
    }
    for v in x.iter_mut() {
        *v += 1e-5 * g.normal();
    }
    let shared = |r: &FeaturesReport| r.warnings.iter().any(|w| w.contains("strongest partials"));
    let r = features(&write("bursts", &x, 44_100)).unwrap();
    assert_eq!(r.impacts.len(), 5, "{:?}", r.skipped);
    assert!(shared(&r), "{:?}", r.warnings);

    let modes = [(440.0, 12.0), (1210.0, 30.0), (2380.0, 55.0), (3900.0, 90.0), (5800.0, 140.0), (7900.0, 200.0)];
    let mut x = vec![0.0; (4.0 * fs) as usize];
    for k in 0..4 {
        for &(f, d) in &modes {
            add_mode(&mut x, fs, 0.3 + 0.9 * k as f64, f, d, 0.05 + 0.25 * g.u());
        }
    }
    for v in x.iter_mut() {
        *v += 3e-4 * g.normal();
    }
    let r = features(&write("struck-four-times", &x, 44_100)).unwrap();
    assert_eq!(r.impacts.len(), 4, "{:?}", r.skipped);
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);

    // A woodblock's short strikes (decays 120–400 s⁻¹: impacts of 50–90 ms, whose
    // frequencies are less precise), six of them 0.12 s apart, in noise 45 dB down.
    let modes = [(820.0, 120.0), (1930.0, 180.0), (3350.0, 260.0), (4870.0, 400.0)];
    let mut x = vec![0.0; (1.2 * fs) as usize];
    for k in 0..6 {
        for &(f, d) in &modes {
            add_mode(&mut x, fs, 0.1 + 0.12 * k as f64, f, d, 0.05 + 0.2 * g.u());
        }
    }
    for v in x.iter_mut() {
        *v += 1e-3 * g.normal();
    }
    let r = features(&write("woodblock-six-times", &x, 44_100)).unwrap();
    assert_eq!(r.impacts.len(), 6, "{:?}", r.skipped);
    assert!(!shared(&r), "{:?}", r.warnings);
}

/// A roll faster than the 50 ms minimum gap (strikes 25–45 ms apart): the impacts hold two
/// or more strikes each (the black-box tester's `roll25` and `roll40`: impacts 80–100 ms
/// long, no warning). Every strike is now an onset or reported inside the impact it falls in,
/// within 2 ms; the features report says it in one line. (No strike is reported twice, and
/// none where there was none: a single strike of each object reports nothing.)
#[test]
fn every_strike_of_a_fast_roll_is_cut_or_reported() {
    let fs = 44_100.0;
    let mut bad = Vec::new();
    for (o, modes) in ROLL_OBJECTS.iter().enumerate() {
        for &spacing in &[0.025, 0.03, 0.04, 0.045] {
            let mut g = Gen(6100 + 10 * o as u64 + (spacing * 1000.0) as u64);
            let n = 16;
            let (x, times) = roll(modes, n, spacing, 0.007, &mut g);
            let seg = segment(&x, fs);
            let ok = every_strike_accounted(&seg, &times, fs);
            eprintln!("object {o}, {spacing} s apart: {} impacts, {} reported", seg.impacts.len(), seg.restrikes.len());
            if !ok {
                bad.push((o, spacing, seg.impacts.len(), seg.restrikes.len()));
            }
        }
        let (x, _) = roll(modes, 1, 1.0, 0.007, &mut Gen(6000 + o as u64));
        let seg = segment(&x, fs);
        assert!(seg.impacts.len() == 1 && seg.restrikes.is_empty(), "object {o} struck once: {seg:?}");
    }
    assert!(bad.is_empty(), "strikes not cut or reported (object, spacing, impacts, reported): {bad:?}");
    let (x, _) = roll(ROLL_OBJECTS[1], 16, 0.03, 0.007, &mut Gen(6200));
    let r = features(&write("roll30", &x, 44_100)).unwrap();
    let w: Vec<_> = r.warnings.iter().filter(|w| w.contains("strikes fell inside impacts")).collect();
    assert_eq!(w.len(), 1, "{:?}", r.warnings);
    assert!(w[0].contains("a roll") && w[0].contains("each 30 ms after the strike before it"), "{}", w[0]);
}

/// The features and components of `r` at over 1 % of its strongest feature's amplitude that
/// are none of `modes` (within 0.5 %), as (f, d, amplitude / strongest).
fn made_up(r: &FeaturesReport, modes: &[(f64, f64, f64)]) -> Vec<(f64, f64, f64)> {
    let feats = r.impacts.iter().flat_map(|i| i.features.iter());
    let strongest = feats.clone().fold(0.0f64, |m, f| m.max(f.amplitude));
    feats
        .chain(r.impacts.iter().flat_map(|i| i.components.iter()))
        .filter(|f| f.amplitude > 0.01 * strongest)
        .filter(|f| !modes.iter().any(|m| (f.freq_hz / m.0 - 1.0).abs() < 0.005))
        .map(|f| (f.freq_hz, f.decay_per_s, f.amplitude / strongest))
        .collect()
}

/// A file trimmed mid-ring with an editor's fade-in (linear, sine, quadratic, linear in dB
/// from −60 dB; 5–50 ms): the analysis starts after the fade, so the features are the ring's
/// partials, not the comb of fast modes that explains a fade (before: a 5 ms linear fade over
/// this ring gave 23 made-up features, the strongest 5 dB under the fundamental), and the
/// report says where the analysis started. A strike whose response rises within 1 ms (a hard
/// mallet's contact, a raised cosine) and a file that starts at its loudest are analysed from
/// their onset, without the warning.
#[test]
fn a_fade_in_is_left_out_of_the_analysis() {
    let fs = 44_100.0;
    let modes = [(440.0, 3.0, 1.0), (1210.0, 6.0, 0.6), (2370.0, 10.0, 0.4), (3920.0, 16.0, 0.3)];
    let ring = |g: &mut Gen| {
        let mut x = vec![0.0; 2 * fs as usize];
        // The ring 0.3 s after its strike, with the partials' phases of then.
        for &(f, d, a) in &modes {
            for (i, v) in x.iter_mut().enumerate() {
                let t = 0.3 + i as f64 / fs;
                *v += 0.3 * a * (-d * t).exp() * (std::f64::consts::TAU * f * t).sin();
            }
        }
        x.iter_mut().for_each(|v| *v += 1e-5 * g.normal());
        x
    };
    type Shape = fn(f64) -> f64;
    let shapes: [(&str, Shape); 4] = [
        ("linear", |u| u),
        ("sine", |u| (std::f64::consts::FRAC_PI_2 * u).sin()),
        ("quadratic", |u| u * u),
        ("dB", |u| 10f64.powf(-3.0 * (1.0 - u))),
    ];
    let mut bad = Vec::new();
    let mut k = 0;
    for (name, shape) in shapes {
        for ms in [5.0, 10.0, 20.0, 50.0] {
            k += 1;
            let mut x = ring(&mut Gen(9100 + k));
            let n = (ms * 1e-3 * fs) as usize;
            for (i, v) in x.iter_mut().take(n).enumerate() {
                *v *= shape(i as f64 / n as f64);
            }
            let p = write(&format!("fade-{name}-{ms}"), &x, fs as u32);
            let r = features(&p).unwrap();
            let _ = std::fs::remove_file(&p);
            let feats: Vec<_> = r.impacts.iter().flat_map(|i| i.features.iter().copied()).collect();
            // Made-up features or components: none at 1 % of the strongest away from the
            // partials.
            let made_up = made_up(&r, &modes);
            // Each partial's decay within 1 %.
            let decays_off = modes.iter().any(|m| {
                !feats.iter().any(|f| (f.freq_hz / m.0 - 1.0).abs() < 0.005 && (f.decay_per_s / m.1 - 1.0).abs() < 0.01)
            });
            let said = r.warnings.iter().any(|w| w.contains("rises gradually"));
            let start = r.impacts.first().map_or(0.0, |i| i.onset_s);
            // The sine fade's last 10 % is within 1.2 % of full; a 5 ms fade linear in dB
            // rises from −20 dB to −1 dB in 1.6 ms, like a strike, and its onset is found
            // at its end.
            if !made_up.is_empty()
                || decays_off
                || !(said || ms < 10.0)
                || r.impacts.len() != 1
                || start < 0.9 * ms * 1e-3
            {
                bad.push(format!("{name} {ms} ms: start {start:.4} s, said {said}, made up {made_up:?}"));
            }
        }
    }
    // Not fades: the ring from its strike on, rising over 0.5–2 ms (a raised cosine), or at
    // once; a strike 60 ms into the file after noise 22 dB under its peak, or after a graze
    // 12 dB under it (whose first moments reach within 20 dB of the peak before the strike's
    // rise: the rise is the strike's own); and a sound that swells in linearly over 150 ms
    // (still rising after the first 100 ms, 3.5 dB louder at 150 ms: a swell, not a fade;
    // without that check its first 100 ms pass every other test of a fade). Each keeps its
    // onset (within 2 ms of the strike; the swell within 10 ms of its start) and gets no
    // warning.
    for (k, case) in ["0", "0.5", "1", "2", "noise", "graze", "swell"].into_iter().enumerate() {
        let mut g = Gen(9200 + k as u64);
        let mut x = vec![0.0; 2 * fs as usize];
        let t0 = if matches!(case, "noise" | "graze") { 0.06 } else { 0.0 };
        for &(f, d, a) in &modes {
            add_mode(&mut x, fs, t0, f, d, 0.3 * a);
        }
        if let Ok(rise_ms) = case.parse::<f64>() {
            let n = (rise_ms * 1e-3 * fs) as usize;
            for (i, v) in x.iter_mut().take(n).enumerate() {
                *v *= 0.5 - 0.5 * (std::f64::consts::PI * i as f64 / n as f64).cos();
            }
        } else if case == "swell" {
            let n = (0.15 * fs) as usize;
            for (i, v) in x.iter_mut().take(n).enumerate() {
                *v *= i as f64 / n as f64;
            }
        }
        let noise = if case == "noise" { 0.3 * 10f64.powf(-22.0 / 20.0) } else { 1e-5 };
        x.iter_mut().for_each(|v| *v += noise * g.normal());
        if case == "graze" {
            // 10 ms of scraping noise 12 dB under the strike's peak, ending 20 ms before it.
            for v in x.iter_mut().skip((0.03 * fs) as usize).take((0.01 * fs) as usize) {
                *v += 0.3 * 10f64.powf(-12.0 / 20.0) * g.normal();
            }
        }
        let p = write(&format!("strike-{case}"), &x, fs as u32);
        let r = features(&p).unwrap();
        let _ = std::fs::remove_file(&p);
        let start = r.impacts.first().map_or(1.0, |i| i.onset_s);
        // (The swell's onset is where its frames rise over the floor, a few ms in.)
        let tol = if case == "swell" { 0.01 } else { 0.002 };
        if r.warnings.iter().any(|w| w.contains("rises gradually")) || (start - t0).abs() > tol {
            bad.push(format!("not a fade ({case}): start {start:.4} s, warnings {:?}", r.warnings));
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}

/// A ring that fades out to the end of its file (an editor's fade-out: linear, sine,
/// quadratic or linear in dB, 100–200 ms at the end of 0.5 s) or is damped by hand (every
/// partial 60 s⁻¹ faster from 0.3 s on, into the noise) is analysed up to where the fade
/// began, and said: over the fade the partials follow its shape, which the extractor
/// explains with made-up modes and slowed decays (a 200 ms linear fade at the end of
/// 0.5 s: the 440 Hz partial's decay 3.08 s⁻¹ for 3.0; faded over 0.4 s, 5.2 and nine
/// made-up features). Each partial's decay within 1 %, nothing made up at 1 % of the
/// strongest, the analysis ending from 100 ms before the fade to 25 % into it (a sine fade
/// is 0.7 dB down there, 1 dB 30 % in).
#[test]
fn a_fade_out_is_left_out_of_the_analysis() {
    let fs = 44_100.0;
    let modes = [(440.0, 3.0, 1.0), (1210.0, 6.0, 0.6), (2370.0, 10.0, 0.4), (3920.0, 16.0, 0.3)];
    type Shape = fn(f64) -> f64;
    // The gain through the fade, u running 0 → 1 over it ("hand": e^(−60 t) from its start).
    let shapes: [(&str, Option<Shape>); 5] = [
        ("linear", Some(|u| 1.0 - u)),
        ("sine", Some(|u| (std::f64::consts::FRAC_PI_2 * u).cos())),
        ("quadratic", Some(|u| (1.0 - u) * (1.0 - u))),
        ("dB", Some(|u| 10f64.powf(-3.0 * u))),
        ("hand", None),
    ];
    let mut bad = Vec::new();
    let mut k = 0;
    for (name, shape) in shapes {
        for ms in [100.0, 150.0, 200.0] {
            k += 1;
            let mut g = Gen(9300 + k);
            let len = if name == "hand" { 1.0 } else { 0.5 };
            let mut x = vec![0.0; (len * fs) as usize];
            for &(f, d, a) in &modes {
                add_mode(&mut x, fs, 0.0, f, d, 0.3 * a);
            }
            // The hand damps from 0.5 s − the "fade's length" on, and the ring goes on
            // falling 60 s⁻¹ faster into the noise after 0.5 s.
            let from = (0.5 - ms * 1e-3) * fs;
            for (i, v) in x.iter_mut().enumerate().skip(from as usize) {
                let u = (i as f64 - from) / (ms * 1e-3 * fs);
                *v *= shape.map_or_else(|| (-60.0 * (i as f64 - from) / fs).exp(), |shape| shape(u));
            }
            x.iter_mut().for_each(|v| *v += 1e-5 * g.normal());
            let p = write(&format!("fade-out-{name}-{ms}"), &x, fs as u32);
            let r = features(&p).unwrap();
            let _ = std::fs::remove_file(&p);
            let feats: Vec<_> = r.impacts.iter().flat_map(|i| i.features.iter().copied()).collect();
            let made_up = made_up(&r, &modes);
            let decays: Vec<f64> = modes
                .iter()
                .map(|m| {
                    feats
                        .iter()
                        .find(|f| (f.freq_hz / m.0 - 1.0).abs() < 0.005)
                        .map_or(f64::NAN, |f| f.decay_per_s / m.1)
                })
                .collect();
            let said = r.warnings.iter().any(|w| w.contains("falls away faster than it rang"));
            let end = r.impacts.first().map_or(0.0, |i| i.onset_s + i.duration_s);
            let fade_at = from / fs;
            if !made_up.is_empty()
                || decays.iter().any(|d| !((d - 1.0).abs() < 0.01))
                || !said
                || r.impacts.len() != 1
                || end > fade_at + 0.25 * ms * 1e-3
                || end < fade_at - 0.1
            {
                bad.push(format!(
                    "{name} {ms} ms: analysed to {end:.3} s (fade at {fade_at:.3}), said {said}, decays / true {decays:.3?}, made up {made_up:?}"
                ));
            }
        }
    }
    // A short sample: 0.2 s, its last 20 ms faded out linearly (before the quarters' means were
    // right, missed: decays 8 % slow).
    // The ring, `len_s` long, faded in linearly over `in_s` and out over `out_s`, analysed.
    let faded = |name: &str, len_s: f64, in_s: f64, out_s: f64, seed: u64| {
        let mut x = vec![0.0; (len_s * fs) as usize];
        for &(f, d, a) in &modes {
            add_mode(&mut x, fs, 0.0, f, d, 0.3 * a);
        }
        let (n, m_in, m_out) = (x.len(), (in_s * fs) as usize, (out_s * fs) as usize);
        for i in 0..m_in {
            x[i] *= i as f64 / m_in as f64;
        }
        for i in 0..m_out {
            x[n - m_out + i] *= 1.0 - i as f64 / m_out as f64;
        }
        let mut g = Gen(seed);
        x.iter_mut().for_each(|v| *v += 1e-5 * g.normal());
        let p = write(name, &x, fs as u32);
        let r = features(&p).unwrap();
        let _ = std::fs::remove_file(&p);
        r
    };
    {
        let r = faded("fade-out-short", 0.2, 0.0, 0.02, 9399);
        let feats: Vec<_> = r.impacts.iter().flat_map(|i| i.features.iter().copied()).collect();
        let off = modes.iter().any(|m| {
            !feats.iter().any(|f| (f.freq_hz / m.0 - 1.0).abs() < 0.005 && (f.decay_per_s / m.1 - 1.0).abs() < 0.01)
        });
        if off
            || !made_up(&r, &modes).is_empty()
            || !r.warnings.iter().any(|w| w.contains("falls away faster than it rang"))
        {
            bad.push(format!("short: {feats:?} {:?}", r.warnings));
        }
    }
    // Struck, damped by hand from 0.3 s on, struck again at 0.6 s: the first impact's fall is
    // found though the next strike follows (an independent review found the check for a ring
    // that comes back seeing that strike's first frames, which turned the rule off).
    {
        let mut x = vec![0.0; (1.2 * fs) as usize];
        for t0 in [0.0, 0.6] {
            for &(f, d, a) in &modes {
                add_mode(&mut x, fs, t0, f, d, 0.3 * a);
            }
        }
        for (i, v) in x.iter_mut().enumerate().take((0.6 * fs) as usize).skip((0.3 * fs) as usize) {
            *v *= (-60.0 * (i as f64 / fs - 0.3)).exp();
        }
        let mut g = Gen(9397);
        x.iter_mut().for_each(|v| *v += 1e-5 * g.normal());
        let p = write("damped-then-struck", &x, fs as u32);
        let r = features(&p).unwrap();
        let _ = std::fs::remove_file(&p);
        let end = r.impacts.first().map_or(0.0, |i| i.onset_s + i.duration_s);
        let said = r.warnings.iter().any(|w| w.contains("the sound at 0.000 s falls away faster than it rang"));
        if !said || r.impacts.len() != 2 || !(0.2..=0.31).contains(&end) {
            bad.push(format!(
                "damped then struck: analysed to {end:.3} s, {} impacts, {:?}",
                r.impacts.len(),
                r.warnings
            ));
        }
    }
    // Faded in and out (20 ms in, 150 ms out, 0.5 s): both left out, and the fade-out is said of
    // the sound at its onset (where the fade-in rose over the floor, a few ms in), as the
    // fade-in is, not at where its analysis starts after the fade-in (`strike_at`).
    {
        let r = faded("fade-in-and-out", 0.5, 0.02, 0.15, 9398);
        let start = r.impacts.first().map_or(0.0, |i| i.onset_s);
        let end = r.impacts.first().map_or(0.0, |i| i.onset_s + i.duration_s);
        // The onset each warning names ("the sound at X s ...").
        let said_at = |what: &str| {
            r.warnings.iter().find(|w| w.contains(what)).and_then(|w| {
                let at = w.split("the sound at ").nth(1)?;
                at.split(' ').next()?.parse::<f64>().ok()
            })
        };
        let (said_in, said_out) = (said_at("rises gradually"), said_at("falls away faster than it rang"));
        let same_onset = said_in.is_some_and(|a| a < 0.01) && said_in == said_out;
        if !(same_onset && start > 0.02 && end <= 0.35 + 0.25 * 0.15 && end > 0.25) {
            bad.push(format!("in and out: analysed {start:.3}–{end:.3} s, {:?}", r.warnings));
        }
    }
    // Not fades, analysed whole and not said: a ring into the noise floor (2 s), a two-stage
    // decay (a loud partial at 60 s⁻¹ over a quiet one at 2 s⁻¹, cut while ringing), two
    // partials beating 1.1 Hz apart cut while ringing (at a peak, half way up from a null),
    // the four partials cut while ringing, and a doublet ending at a null a period after
    // another.
    // 500 and 501.1 Hz (a = 0.2, d = 2), the beat's null `phase` (0–1) of its period before
    // the file's end: 0 ends at the null, 0.25 half way up, 0.5 at a peak.
    let beat = |x: &mut [f64], phase: f64| {
        let end = x.len() as f64 / fs;
        let null_at = end - phase / 1.1;
        let phi = std::f64::consts::PI - std::f64::consts::TAU * 1.1 * null_at;
        for (i, v) in x.iter_mut().enumerate() {
            let t = i as f64 / fs;
            let w = std::f64::consts::TAU * t;
            *v += 0.2 * (-2.0 * t).exp() * ((500.0 * w).sin() + (501.1 * w + phi).sin());
        }
    };
    // (Known limit, not asserted: "beat-0", the same beat ending at its null, is taken for a
    // fade, analysed to 0.30 of 0.5 s: with no earlier null in the record its fall is a fade's.)
    for (k, case) in ["floor", "two-stage", "beat-0.25", "beat-0.5", "cut", "doublet"].into_iter().enumerate() {
        let mut g = Gen(9400 + k as u64);
        let len = match case {
            "floor" => 2.0,
            "doublet" => 1.5,
            _ => 0.5,
        };
        let mut x = vec![0.0; (len * fs) as usize];
        match case {
            // A black-box tester's case (stop 38): 440 and 441 Hz (a = 1 and 0.8, d = 3) and a
            // weak 1250 Hz, the file ending at the beat's second null, 1.5 s in. Before the
            // beat rule its fall into the null was taken for a fade: analysed to 0.98 s, the
            // 440 Hz decay 6.1 s⁻¹ for 3.
            "doublet" => {
                for (f, d, a) in [(440.0, 3.0, 1.0), (441.0, 3.0, 0.8), (1250.0, 10.0, 0.3)] {
                    for (i, v) in x.iter_mut().enumerate() {
                        let t = i as f64 / fs;
                        *v += 0.4 * a * (-d * t).exp() * (std::f64::consts::TAU * f * t + 0.3).sin();
                    }
                }
            }
            "floor" => modes.iter().for_each(|&(f, d, a)| add_mode(&mut x, fs, 0.0, f, 4.0 * d, 0.3 * a)),
            "two-stage" => {
                add_mode(&mut x, fs, 0.0, 700.0, 60.0, 0.5);
                add_mode(&mut x, fs, 0.0, 703.0, 2.0, 0.02);
            }
            "cut" => modes.iter().for_each(|&(f, d, a)| add_mode(&mut x, fs, 0.0, f, d, 0.3 * a)),
            _ => beat(&mut x, case[5..].parse().unwrap()),
        }
        x.iter_mut().for_each(|v| *v += 1e-5 * g.normal());
        let p = write(&format!("not-fade-{case}"), &x, fs as u32);
        let r = features(&p).unwrap();
        let _ = std::fs::remove_file(&p);
        let said = r.warnings.iter().any(|w| w.contains("falls away faster than it rang"));
        // Analysed to the file's end (within a frame), but the ring into the floor.
        let end = r.impacts.first().map_or(0.0, |i| i.onset_s + i.duration_s);
        if said || r.impacts.len() != 1 || (case != "floor" && end < len - 0.006) {
            bad.push(format!("not a fade ({case}): analysed to {end:.3} of {len} s, {:?}", r.warnings));
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}
