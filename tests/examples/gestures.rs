//! Renders the README's lasting-contact gestures (issue 16) through the command line's
//! renderer (the plugin's own `process()`), and draws their spectrograms:
//! `cargo run --release -p struck-tests --example gestures [OUT_DIR]` (default
//! `tests/gestures`): `NAME.wav` (not committed) and `NAME.png` per gesture.

use rustfft::num_complex::Complex;
use std::path::{Path, PathBuf};
use struck_cli::cli::{render, Gesture, RenderOptions, SoundOptions};

/// (file name, object, material, notes, excitation, texture, speed curve, force curve, extra
/// parameters, seconds).
type Spec = (
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static [&'static str],
    f64,
);

const GESTURES: [Spec; 3] = [
    // A spoon's edge round the rim of a glass bowl (across the strike path, which runs from
    // the pole to the rim: the contact stays near the rim), speeding up and slowing down,
    // pressed harder in the middle.
    (
        "spoon-round-a-bowl",
        "fem-bowl",
        "glass-ren2013",
        "72:90@0.95~4.5",
        "scrape",
        "finegrit",
        "0:0.12,2:0.45,4.5:0.15",
        "0:0.4,2:1,4.5:0.5",
        &["contactdir=2", "release=20"],
        6.0,
    ),
    // A marble rolling across a steel plate with a few bumps, slowing down.
    (
        "marble-on-a-plate",
        "fem-plate",
        "steel-sterling-rayleigh",
        "60:80~4",
        "roll",
        "bumps",
        "0:0.5,4:0.08",
        "0:0.6",
        &["ball=8", "release=30"],
        5.5,
    ),
    // A stick dragged along a wooden (marimba) bar and back, over coarse grit.
    (
        "stick-along-a-bar",
        "fem-marimba-bar",
        "wood-ren2013",
        "48:100~3",
        "scrape",
        "coarsegrit",
        "0:0.25,1.5:0.4,3:0.25",
        "0:0.7",
        &["release=40"],
        4.0,
    ),
];

fn main() {
    let dir = std::env::args().nth(1).map_or_else(|| PathBuf::from("tests/gestures"), PathBuf::from);
    std::fs::create_dir_all(&dir).expect("output folder");
    for (name, object, material, notes, excitation, texture, speed, force, set, seconds) in GESTURES {
        let wav = dir.join(format!("{name}.wav"));
        let opts = RenderOptions {
            sound: SoundOptions {
                object: object.into(),
                material: material.into(),
                set: set.iter().map(|s| (*s).to_string()).collect(),
                ..SoundOptions::default()
            },
            notes: Some(notes.into()),
            midi: None,
            seconds: Some(seconds),
            block_size: 512,
            out: wav.clone(),
            normalize: Some(-3.0),
            gesture: Gesture {
                excitation: Some(excitation.into()),
                texture: Some(texture.into()),
                speed_curve: Some(speed.into()),
                force_curve: Some(force.into()),
                ..Gesture::default()
            },
        };
        println!("{}", render(&opts).expect("render"));
        spectrogram(&wav, &dir.join(format!("{name}.png")));
    }
}

/// A log-magnitude spectrogram of the left channel: 2048-point Hann frames every 256
/// samples, 0–12 kHz on a linear axis, −90…0 dB of the loudest bin, 900 × 300 pixels.
fn spectrogram(wav: &Path, png: &Path) {
    let mut r = hound::WavReader::open(wav).expect("read the render");
    let sr = f64::from(r.spec().sample_rate);
    let x: Vec<f32> = r.samples::<f32>().map(Result::unwrap).step_by(2).collect();
    let (n, hop) = (2048usize, 256usize);
    let fft = rustfft::FftPlanner::new().plan_fft_forward(n);
    let win: Vec<f32> = (0..n).map(|i| 0.5 - 0.5 * (2.0 * std::f32::consts::PI * i as f32 / n as f32).cos()).collect();
    let frames: Vec<Vec<f32>> = (0..x.len().saturating_sub(n) / hop)
        .map(|f| {
            let mut buf: Vec<Complex<f32>> = (0..n).map(|i| Complex::new(x[f * hop + i] * win[i], 0.0)).collect();
            fft.process(&mut buf);
            buf[..n / 2].iter().map(|c| c.norm_sqr()).collect()
        })
        .collect();
    let top = frames.iter().flatten().fold(1e-30f32, |m, &v| m.max(v));
    let (w, h) = (900u32, 300u32);
    let max_bin = ((12_000.0 / sr) * n as f64) as usize;
    let img = image::RgbImage::from_fn(w, h, |px, py| {
        let f = (px as usize * frames.len()) / w as usize;
        let k = ((h - 1 - py) as usize * max_bin) / h as usize;
        let db = 10.0 * (frames[f][k] / top).max(1e-12).log10();
        let v = ((db + 90.0) / 90.0).clamp(0.0, 1.0);
        // Dark blue → orange → pale yellow.
        let c = |a: f32, b: f32, c: f32| (255.0 * (a + (b - a) * v + c * v * v).clamp(0.0, 1.0)) as u8;
        image::Rgb([c(0.02, 0.6, 0.38), c(0.02, 0.2, 0.7), c(0.15, 0.3, -0.25)])
    });
    img.save(png).expect("write the spectrogram");
}
