//! Feature-extraction accuracy (Ren et al. 2013 §4 test, and multi-mode mixtures).

use estimator::synth::{mixture_stats, ren_test};

/// Ren §4: 100 single damped sinusoids, f log-uniform in [20, 20000] Hz, d log-uniform in
/// [0.1, 1000] s⁻¹, 44.1 kHz, 1 s, f32 samples. Ren: 0.040 % (f), 0.53 % (d).
#[test]
fn ren_single_sinusoids() {
    let (ef, ed, wf, wd, missing) = ren_test(100, 2013, None);
    eprintln!("ren noiseless: mean rel err f {:.2e} d {:.2e}; worst f {wf:.2e} d {wd:.2e}; missing {missing}", ef, ed);
    assert_eq!(missing, 0);
    assert!(ef < 0.00040 && ed < 0.0053, "f {ef} d {ed}");
    // With white noise 60 dB under the sinusoid's power.
    let (ef, ed, wf, wd, missing) = ren_test(100, 2014, Some(60.0));
    eprintln!("ren 60 dB: mean rel err f {:.2e} d {:.2e}; worst f {wf:.2e} d {wd:.2e}; missing {missing}", ef, ed);
    assert_eq!(missing, 0);
    assert!(ef < 0.00040 && ed < 0.0053, "f {ef} d {ed}");
}

#[test]
fn mixtures_40db_and_20db() {
    for (snr, min_p, min_r, max_med) in [(40.0, 0.7, 0.9, 0.02), (20.0, 0.8, 0.8, 0.05)] {
        let s = mixture_stats(snr, 4, 7 + snr as u64, 44_100.0);
        eprintln!("mixture {snr} dB: {s:?}");
        assert!(s.precision >= min_p && s.recall >= min_r && s.decay_err_median <= max_med, "{snr} dB: {s:?}");
    }
}
