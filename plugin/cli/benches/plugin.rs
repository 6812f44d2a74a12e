//! The whole plugin through its own `process()` (offline host), as a host would run it.
//!
//! `cargo bench -p struck-cli --bench plugin`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use struck_cli::cli::{configured_host, note_events, NoteSpec, SoundOptions};

fn sixteen_voices(c: &mut Criterion) {
    let mut g = c.benchmark_group("plugin");
    // A lightly damped plate at full quality: every voice keeps all its modes for the run.
    let opts = SoundOptions {
        object: "rect-plate".into(),
        material: "porcelain-ren2013".into(),
        set: vec!["quality=120".into(), "hard=1".into()],
        ..SoundOptions::default()
    };
    let notes: Vec<NoteSpec> = (0..16)
        .map(|i| NoteSpec {
            key: 30 + i as u8 * 2,
            velocity: 110,
            position: Some(i as f32 / 16.0),
            start_s: 0.0,
            duration_s: None,
        })
        .collect();
    let mut host = configured_host(&opts, 512).unwrap();
    let events = note_events(&notes, 48_000.0);
    host.render(&events, 512, 512);
    let modes = host.plugin().engine().unwrap().active_modes();
    eprintln!("plugin bench: 16 voices, {modes} sounding modes in all");
    g.throughput(Throughput::Elements(512));
    g.bench_function("16 voices on rect-plate, 512-sample process() call", |b| {
        b.iter(|| {
            host.render(&[], 512, 512);
        })
    });
    g.finish();
}

criterion_group!(benches, sixteen_voices);
criterion_main!(benches);
