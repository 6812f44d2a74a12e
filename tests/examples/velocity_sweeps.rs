//! Prints the README's velocity-sweep figures (not a check: `a_velocity_sweep_has_no_holes` in
//! `tests/tests/strike.rs` is): for 5 objects × felt, rubber, wood, plastic × hardness 0 and
//! 0.5 × keys 48 and 72, velocity 1–127 in steps of 3 at the default strike position 0.3,
//! the RMS of the first 0.4 s, and each sweep's largest fall under a softer strike:
//! `cargo run --release -p struck-tests --example velocity_sweeps`.

use struck_tests::*;

const SR: u32 = 48_000;

fn main() {
    let mut falls = Vec::new();
    for object in ["bar", "circular-plate", "fem-marimba-bar", "fem-bell", "fem-vibraphone-bar"] {
        for mallet in [0.0f32, 1.0, 2.0, 3.0] {
            for hard in [0.0f32, 0.5] {
                for key in [48u8, 72] {
                    let (mut loudest, mut fall) = (f64::NEG_INFINITY, 0.0f64);
                    for velocity in (1..=127u8).step_by(3) {
                        let mut h = host(object, "glass-ren2013", SR, &[("mallet", mallet), ("hard", hard)]);
                        let x = render(&mut h, &[note(key, velocity, Some(0.3))], 0.4, 512);
                        let level = db(rms(&x));
                        loudest = loudest.max(level);
                        fall = fall.min(level - loudest);
                    }
                    println!("{object:20} mallet {mallet} hardness {hard} key {key}: largest fall {fall:.2} dB");
                    falls.push((fall, format!("{object} mallet {mallet} hardness {hard} key {key}")));
                }
            }
        }
    }
    let worst = falls.iter().min_by(|a, b| a.0.total_cmp(&b.0)).expect("sweeps");
    let count = |db: f64| falls.iter().filter(|f| f.0 < db).count();
    println!(
        "{} sweeps: worst {:.2} dB ({}), {} worse than -1 dB, {} worse than -3 dB",
        falls.len(),
        worst.0,
        worst.1,
        count(-1.0),
        count(-3.0)
    );
}
