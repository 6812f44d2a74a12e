//! Real workloads through the plugin's own `process()` (issue 13 part 2): 16 and 64 voices on
//! every factory object, keys spread over three octaves (36–72) and each retriggered every
//! second (staggered), default quality and material, 48 kHz, 512-sample blocks; and the idle
//! plugin (no voices). Throughput is counted from the modes the engine actually runs (its
//! sounding modes after each `process()` call × the call's samples).
//!
//! The reference is the hand AVX2 resonator kernel alone on one 1,024-mode bank, measured
//! beside each render of the row (the machine's speed drifts); each row gives its share of
//! that.
//!
//! `cargo bench -p struck-cli --bench workloads [-- OBJECT] [--repeat=N] [--profile]` (a plain bench
//! target: it prints a table; each row is the fastest of N renders, 5 by default, so a
//! moment of the machine's noise does not set a row; a large N with one object and
//! `--profile`, which skips the kernel runs, is a workload to profile).

use struck_cli::cli::{configured_host, note_events, NoteSpec, SoundOptions};

const SR: f64 = 48_000.0;
const SECONDS: f64 = 6.0;
const BLOCK: usize = 512;

fn main() {
    // `cargo bench` passes `--bench`; an optional object id filters.
    let filter: Option<String> = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    let repeat: usize = std::env::args()
        .find_map(|a| a.strip_prefix("--repeat=").map(|n| n.parse().expect("--repeat=N: a count")))
        .unwrap_or(5)
        .max(1);
    // `--profile`: the renders only (no kernel runs between them), for a profiler.
    let profile = std::env::args().any(|a| a == "--profile");
    let idle = {
        let mut host = configured_host(&SoundOptions::default(), BLOCK).expect("host");
        host.render(&[], (SECONDS * SR) as usize, BLOCK);
        host.stats()
    };
    println!("idle (no voices): {:.4} % of one core", 100.0 * idle.core_share(SR));
    if !profile {
        println!("kernel alone (1,024 modes, 64-sample blocks): {:.2e} mode-samples/s", kernel_reference(5));
    }
    println!(
        "| object | voices | mean voices | mean sounding modes | share of one core | mode-samples/s | of the kernel |"
    );
    println!("| --- | --- | --- | --- | --- | --- | --- |");
    for bank in presets::factory_banks() {
        if filter.as_ref().is_some_and(|f| !bank.id.contains(f.as_str())) {
            continue;
        }
        for voices in [16usize, 64] {
            let opts = SoundOptions { object: bank.id.clone(), ..SoundOptions::default() };
            let notes: Vec<NoteSpec> = (0..SECONDS as usize)
                .flat_map(|s| {
                    (0..voices).map(move |v| NoteSpec {
                        key: 36 + (v * 36 / voices) as u8,
                        velocity: 100,
                        position: Some(v as f32 / voices as f32),
                        start_s: s as f64 + v as f64 / voices as f64,
                        duration_s: None,
                    })
                })
                .collect();
            let events = note_events(&notes, SR);
            // The kernel is measured beside each render (the machine's speed drifts): the
            // row's share is its fastest render over the fastest kernel run among them.
            let mut kernel = 0.0f64;
            let st = (0..repeat)
                .map(|_| {
                    if !profile {
                        kernel = kernel.max(kernel_reference(1));
                    }
                    let mut host = configured_host(&opts, BLOCK).expect("host");
                    host.render(&events, (SECONDS * SR) as usize, BLOCK);
                    host.stats()
                })
                .max_by(|a, b| a.mode_samples_per_s().total_cmp(&b.mode_samples_per_s()))
                .expect("one render at least");
            // `--profile` measures no kernel: the column is left empty.
            let of_kernel =
                if kernel > 0.0 { format!("{:.2}", st.mode_samples_per_s() / kernel) } else { "-".to_string() };
            println!(
                "| `{}` | {voices} | {:.1} | {:.0} | {:.2} % | {:.2e} | {of_kernel} |",
                bank.id,
                st.mean_voices(),
                st.mean_modes(),
                100.0 * st.core_share(SR),
                st.mode_samples_per_s(),
            );
        }
    }
}

/// Mode-samples per second of the resonator kernel alone (AVX2 where the machine has it) on
/// one 1,024-mode bank in 64-sample blocks, best of `runs` runs of 0.2 s.
fn kernel_reference(runs: usize) -> f64 {
    use dsp::resonator::{ModeCoeffs, ResonatorBank};
    let mut bank = ResonatorBank::new(1024);
    for m in 0..1024 {
        let f = 50.0 + 19.0 * m as f64;
        let k =
            bank.push(ModeCoeffs::new(1.0 + 0.01 * m as f64, 2.0 * std::f64::consts::PI * f, SR)).expect("capacity");
        bank.excite(k, 1e-3);
    }
    let mut out = [0.0f32; 64];
    let blocks = 1500;
    (0..runs)
        .map(|_| {
            let t = std::time::Instant::now();
            for _ in 0..blocks {
                out.fill(0.0);
                bank.process(&mut out);
            }
            std::hint::black_box(&out);
            (1024 * 64 * blocks) as f64 / t.elapsed().as_secs_f64()
        })
        .fold(0.0, f64::max)
}
