use estimator::features::{extract_impact, ExtractOptions};
use estimator::synth::*;
fn main() {
    let fs = 44_100.0;
    let mut rng = Rng::new(47);
    let cancel = std::sync::atomic::AtomicBool::new(false);
    for _ in 0..4 {
        let modes = mixture_modes(&mut rng);
        let mut x = render(&modes, fs, 44_100);
        let nv = add_noise(&mut x, 40.0, 44_100, &mut rng);
        let xf: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        let t = std::time::Instant::now();
        let bp: usize = std::env::var("BP").ok().and_then(|v| v.parse().ok()).unwrap_or(2);
        let fit = extract_impact(&xf, fs, nv, &ExtractOptions { backfit_passes: bp, ..Default::default() }, &cancel).unwrap();
        let missed: Vec<_> = modes.iter().filter(|m| !fit.features.iter().any(|f| (f.freq_hz / m.0 - 1.0).abs() < 0.005)).collect();
        println!("{:?}", &fit.features[..fit.features.len().min(3)]);
        println!("{:?} feats {} fitted {} rejected {} explained {:.6} r/n {:.2} missed {:?}", t.elapsed(), fit.features.len(), fit.fitted_modes, fit.rejected_peaks, fit.explained_power, fit.residual_to_noise, missed);
    }
}
