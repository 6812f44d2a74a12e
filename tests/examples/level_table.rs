//! Prints the README's table of level and brightness per object (not a check: the checks on
//! these quantities are in `tests/tests/strike.rs`):
//! `cargo run --release -p struck-tests --example level_table`.

use struck_tests::*;

const SR: u32 = 48_000;

fn main() {
    let sr = f64::from(SR);
    for b in presets::factory_banks() {
        let id = b.id;
        let mut row = format!("| `{id}` |");
        for mat in ["glass-ren2013", "wood-ren2013", "metal-ren2013", "plastic-ren2013"] {
            let mut h = host(&id, mat, SR, &[]);
            let x = render(&mut h, &[note(60, 127, Some(0.5))], 0.05, 512);
            row += &format!(" {:.1} |", db(k_weighted_rms(&x, sr)));
        }
        let mut lv = Vec::new();
        for &(size, key) in &[(0.5f32, 36u8), (2.0, 96), (1.0, 60), (0.5, 96), (2.0, 36)] {
            let mut h = host(&id, "glass-ren2013", SR, &[("size", size)]);
            let x = render(&mut h, &[note(key, 127, Some(0.5))], 0.05, 512);
            lv.push(db(k_weighted_rms(&x, sr)));
        }
        let (lo, hi) = lv.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        row += &format!(" {:.1}…{:.1} |", lo, hi);
        let c = |vel: u8, mallet: f32, hard: f32| {
            let mut h = host(&id, "glass-ren2013", SR, &[("mallet", mallet), ("hard", hard)]);
            let x = render(&mut h, &[note(60, vel, Some(0.3))], 0.05, 512);
            spectral_centroid(&x, sr)
        };
        let (c30, c100) = (c(30, 0.0, 1.0), c(100, 0.0, 1.0));
        let (h0, h1) = (c(100, 2.0, 0.0), c(100, 2.0, 1.0));
        row += &format!(
            " {:.0} → {:.0} Hz (×{:.2}) | {:.0} → {:.0} Hz (×{:.2}) |",
            c30,
            c100,
            c100 / c30,
            h0,
            h1,
            h1 / h0
        );
        println!("{row}");
    }
}
