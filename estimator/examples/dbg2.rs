use estimator::features::{extract_impact, ExtractOptions};
use estimator::synth::*;
fn main() {
    let fs = 44_100.0;
    let mut rng = Rng::new(140);
    let cancel = std::sync::atomic::AtomicBool::new(false);
    for i in 0..20 {
        let modes = mixture_modes(&mut rng);
        let mut x = render(&modes, fs, 44_100);
        let nv = add_noise(&mut x, 40.0, 44_100, &mut rng);
        let xf: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        let fit = extract_impact(&xf, fs, nv, &ExtractOptions::default(), &cancel).unwrap();
        for m in &modes {
            let near = fit.features.iter().filter(|f| (f.freq_hz / m.0 - 1.0).abs() < 0.005);
            if let Some(f) = near.max_by(|a, b| a.amplitude.total_cmp(&b.amplitude)) {
                let e = (f.decay_per_s / m.1 - 1.0).abs();
                if e > 0.2 {
                    let nb = modes.iter().filter(|o| o.0 != m.0).map(|o| (o.0 / m.0 - 1.0).abs()).fold(1.0, f64::min);
                    println!("impact {i}: true {m:?} got {f:?} err {e:.2} nearest other {:.4}", nb);
                }
            }
        }
    }
}
