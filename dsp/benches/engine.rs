//! Speed of the resonator kernel and the engine (figures go in the README).
//!
//! `cargo bench -p struck-dsp`. Throughput is reported in mode-samples per second.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use dsp::engine::{Engine, NoteId, ObjectModes, SoundParams, Strike};
use dsp::resonator::{ModeCoeffs, ResonatorBank};
use dsp::Damping;
use std::f64::consts::PI;
use std::hint::black_box;

const SR: f64 = 48_000.0;

/// An object with `n` modes spread from 50 Hz to 20 kHz and 8 strike points.
fn object(n: usize) -> ObjectModes {
    let lambdas: Vec<f64> = (0..n).map(|i| (2.0 * PI * 50.0 * (400.0f64).powf(i as f64 / n as f64)).powi(2)).collect();
    let gains: Vec<Vec<f32>> =
        (0..8).map(|p| (0..n).map(|i| (((i * 7 + p * 13) % 17) as f32 / 17.0 - 0.4).max(0.05)).collect()).collect();
    ObjectModes::new(lambdas, &gains)
}

fn quiet_params() -> SoundParams {
    // Light damping and full quality so no mode is culled and nothing ends during the bench.
    SoundParams {
        damping: Damping::Rayleigh { alpha1: 0.01, alpha2: 0.0 },
        quality_db: 200.0,
        hardness: 1.0,
        ..SoundParams::default()
    }
}

fn kernel(c: &mut Criterion) {
    let _ftz = dsp::ftz::DenormalGuard::new();
    let mut g = c.benchmark_group("resonator");
    for modes in [32usize, 96, 256, 1000] {
        let mut bank = ResonatorBank::new(modes);
        for k in 0..modes {
            // Undamped so the state never decays towards subnormals however long the bench runs.
            let s = bank.push(ModeCoeffs::new(0.0, 2.0 * PI * (60.0 + 19.0 * k as f64), SR)).unwrap();
            bank.excite(s, 0.01);
        }
        let mut out = [0.0f32; 64];
        g.throughput(Throughput::Elements((modes * 64) as u64));
        g.bench_function(format!("{modes} modes x 64 samples"), |b| {
            b.iter(|| {
                bank.process(black_box(&mut out));
            })
        });
    }
    g.finish();
}

fn engine_16_voices(c: &mut Criterion) {
    let _ftz = dsp::ftz::DenormalGuard::new();
    let mut g = c.benchmark_group("engine");
    let mut e = Engine::new(vec![object(1000)], 32, SR);
    e.set_params(quiet_params());
    e.reset();
    for v in 0..16u8 {
        e.note_on(
            NoteId { voice_id: None, channel: 0, key: 40 + v },
            Strike { velocity: 1.0, position: f32::from(v) / 16.0, lambda_factor: 1.0 },
        );
    }
    let mut out = vec![0.0f32; 512];
    e.render(&mut out);
    assert_eq!(e.active_modes(), 16_000);
    g.throughput(Throughput::Elements(16_000 * 512));
    g.bench_function("16 voices x 1000 modes, 512-sample block", |b| {
        b.iter(|| {
            out.fill(0.0);
            e.render(black_box(&mut out));
        })
    });
    // Few modes a voice (a glockenspiel bar's culled voices hold 5–8): the packing across
    // voices and each voice's fixed costs, not the kernel, set the pace.
    let mut few = Engine::new(vec![object(6)], 32, SR);
    // Undamped: millions of blocks run in the bench, hours of audio.
    few.set_params(SoundParams { damping: Damping::Rayleigh { alpha1: 0.0, alpha2: 0.0 }, ..quiet_params() });
    few.reset();
    for v in 0..16u8 {
        few.note_on(
            NoteId { voice_id: None, channel: 0, key: 40 + v },
            Strike { velocity: 1.0, position: f32::from(v) / 16.0, lambda_factor: 1.0 },
        );
    }
    for _ in 0..200 {
        few.render(&mut out);
    }
    assert_eq!(few.active_modes(), 96, "voices {}", few.active_voices());
    g.throughput(Throughput::Elements(96 * 512));
    g.bench_function("16 voices x 6 modes, 512-sample block", |b| {
        b.iter(|| {
            out.fill(0.0);
            few.render(black_box(&mut out));
        })
    });

    // Issue 16's target: 16 voices of scrape on 1000 modes each at 48 kHz in ≤ 30 % of a core.
    let mut e = Engine::new(vec![object(1000)], 32, SR);
    let mut p = quiet_params();
    p.contact.excitation = dsp::contact::Excitation::Scrape;
    p.contact.texture = dsp::contact::TextureKind::CoarseGrit;
    e.set_params(p);
    e.reset();
    for v in 0..16u8 {
        e.note_on(
            NoteId { voice_id: None, channel: 0, key: 40 + v },
            Strike { velocity: 1.0, position: f32::from(v) / 16.0, lambda_factor: 1.0 },
        );
    }
    e.render(&mut out);
    assert_eq!(e.active_modes(), 16_000);
    g.throughput(Throughput::Elements(16_000 * 512));
    g.bench_function("16 voices of scrape x 1000 modes, 512-sample block", |b| {
        b.iter(|| {
            out.fill(0.0);
            e.render(black_box(&mut out));
        })
    });

    // Issue 16's audio-in target: a 1000-mode object driven by the input in ≤ 5 % of a core.
    let mut e = Engine::new(vec![object(1000)], 32, SR);
    e.set_params(quiet_params());
    e.reset();
    e.set_audio_input(true, 0.3);
    let mut noise = dsp::exciter::Noise::new(1);
    let input: Vec<f32> = (0..512).map(|_| 0.1 * noise.next_sample()).collect();
    e.render_input(&input, &mut out);
    assert_eq!(e.active_modes(), 1000);
    g.throughput(Throughput::Elements(1000 * 512));
    g.bench_function("audio in x 1000 modes, 512-sample block", |b| {
        b.iter(|| {
            out.fill(0.0);
            e.render_input(black_box(&input), black_box(&mut out));
        })
    });

    // Issue 13's target: 64 voices of 250 modes at 48 kHz in ≤ 25 % of one core.
    let mut e = Engine::new(vec![object(250)], 64, SR);
    e.set_params(quiet_params());
    e.reset();
    for v in 0..64u8 {
        e.note_on(
            NoteId { voice_id: None, channel: 0, key: 30 + v },
            Strike { velocity: 1.0, position: f32::from(v) / 64.0, lambda_factor: 1.0 },
        );
    }
    e.render(&mut out);
    assert_eq!(e.active_modes(), 16_000);
    g.throughput(Throughput::Elements(16_000 * 512));
    g.bench_function("64 voices x 250 modes, 512-sample block", |b| {
        b.iter(|| {
            out.fill(0.0);
            e.render(black_box(&mut out));
        })
    });

    // Worst-case block: 32 note-ons in one 512-sample block, each striking 1000 modes.
    g.throughput(Throughput::Elements(1));
    g.bench_function("block with a burst of 32 note-ons (1000 modes each)", |b| {
        b.iter_batched(
            || {
                let mut e = Engine::new(vec![object(1000)], 32, SR);
                e.set_params(quiet_params());
                e.reset();
                e
            },
            |mut e| {
                for v in 0..32u8 {
                    e.note_on(
                        NoteId { voice_id: None, channel: 0, key: 30 + v },
                        Strike { velocity: 0.8, position: 0.3, lambda_factor: 1.0 },
                    );
                }
                let mut out = [0.0f32; 512];
                e.render(&mut out);
                e
            },
            BatchSize::LargeInput,
        )
    });

    // A parameter change: every sounding mode's pole is rebuilt at the next control tick.
    let mut flip = false;
    g.bench_function("coefficient rebuild: 16 voices x 1000 modes (64 samples incl.)", |b| {
        b.iter(|| {
            flip = !flip;
            let mut p = quiet_params();
            p.damping = Damping::Rayleigh { alpha1: if flip { 0.01 } else { 0.02 }, alpha2: 0.0 };
            e.set_params(p);
            let mut out = [0.0f32; 256];
            e.render(&mut out);
        })
    });

    // Pitch bends take effect at their sample: each message rebuilds its channel's voices
    // there (every one of these 16,000 modes), here one every 32 samples: 16 a block, an MPE
    // controller's rate (≈ 1.5 kHz) on a channel holding every voice.
    let mut k = 0u32;
    g.throughput(Throughput::Elements(16_000 * 512));
    g.bench_function("16,000 modes bent every 32 samples, 512-sample block", |b| {
        b.iter(|| {
            for chunk in out.chunks_mut(32) {
                k = k.wrapping_add(1);
                e.set_pitch_bend(0, (k % 64) as f32 / 320.0 - 0.1);
                chunk.fill(0.0);
                e.render(black_box(chunk));
            }
        })
    });
    g.finish();
}

criterion_group!(benches, kernel, engine_16_voices);
criterion_main!(benches);
