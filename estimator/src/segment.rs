//! Impact segmentation: onsets from a short-frame energy envelope against a noise-floor
//! estimate; each impact runs from its onset until it decays into the noise floor, the next
//! onset, or `max_impact_s`.

use serde::{Deserialize, Serialize};

/// Thresholds of the segmentation. `Default` gives the values used in the tests.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SegmentOptions {
    /// Frame energy must exceed the noise floor by this much to start an impact, dB.
    pub onset_db: f64,
    /// ... and exceed the mean of the previous 20 ms by this much, dB (taps during a ring).
    pub rise_db: f64,
    /// Impacts whose peak is less than this above the noise floor are skipped, dB.
    pub min_snr_db: f64,
    /// Impacts shorter than this are skipped, s.
    pub min_impact_s: f64,
    /// Impacts are cut at this length, s.
    pub max_impact_s: f64,
    /// No new onset within this time after the previous one, s.
    pub min_gap_s: f64,
}

impl Default for SegmentOptions {
    fn default() -> Self {
        Self { onset_db: 15.0, rise_db: 6.0, min_snr_db: 20.0, min_impact_s: 0.03, max_impact_s: 6.0, min_gap_s: 0.05 }
    }
}

/// One cut impact, in samples of the recording.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// First sample (the onset).
    pub start: usize,
    /// One past the last sample.
    pub end: usize,
    /// Peak frame power over the noise floor, dB.
    pub snr_db: f64,
}

/// Result of [`segment`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Segmentation {
    /// Impacts kept.
    pub impacts: Vec<Segment>,
    /// Impacts skipped, with the reason.
    pub skipped: Vec<(Segment, String)>,
    /// Noise power per sample (10th percentile of frame power).
    pub noise_var: f64,
}

/// Finds the impacts in a mono signal `x` sampled at `fs` Hz.
pub fn segment(x: &[f32], fs: f64, opts: &SegmentOptions) -> Segmentation {
    let hop = ((fs * 0.0025).round() as usize).max(8);
    let frame = 2 * hop;
    let nfr = if x.len() >= frame { (x.len() - frame) / hop + 1 } else { 0 };
    if nfr == 0 {
        return Segmentation::default();
    }
    let e: Vec<f64> = (0..nfr)
        .map(|j| x[j * hop..j * hop + frame].iter().map(|&v| f64::from(v) * f64::from(v)).sum::<f64>() / frame as f64)
        .collect();
    let mut sorted = e.clone();
    sorted.sort_by(f64::total_cmp);
    let peak_e = sorted[sorted.len() - 1];
    // Noise floor: 10th percentile; floored 120 dB under the loudest frame (synthetic silence).
    let noise = sorted[sorted.len() / 10].max(peak_e * 1e-12).max(1e-30);
    let onset_thr = noise * 10f64.powf(opts.onset_db / 10.0);
    let rise = 10f64.powf(opts.rise_db / 10.0);
    let back = ((0.02 * fs) as usize / hop).max(1);
    let gap = ((opts.min_gap_s * fs) as usize / hop).max(1);
    let mut onsets: Vec<usize> = Vec::new();
    let mut j = 0;
    while j < nfr {
        let prev = if j == 0 {
            0.0
        } else {
            let a = j.saturating_sub(back);
            e[a..j].iter().sum::<f64>() / (j - a) as f64
        };
        if e[j] > onset_thr && e[j] > rise * prev.max(noise) {
            // Sample-accurate start: first sample reaching 30 % of the local peak.
            let a = j.saturating_sub(1) * hop;
            let b = ((j + 3) * hop + frame).min(x.len());
            let pk = x[a..b].iter().fold(0.0f32, |m, v| m.max(v.abs()));
            let s = a + x[a..b].iter().position(|v| v.abs() >= 0.3 * pk).unwrap_or(0);
            if onsets.last().is_none_or(|&o| s > o) {
                onsets.push(s);
            }
            j += gap;
            continue;
        }
        j += 1;
    }
    let mut out = Segmentation { noise_var: noise, ..Default::default() };
    let end_thr = noise * 2.0;
    let max_len = (opts.max_impact_s * fs) as usize;
    for (i, &s) in onsets.iter().enumerate() {
        let next = onsets.get(i + 1).copied().unwrap_or(x.len());
        let mut end = next.min(s + max_len).min(x.len());
        // Decayed into the noise: four consecutive frames under 2 × noise.
        let mut quiet = 0;
        let mut snr: f64 = 0.0;
        let mut jf = s / hop + 1;
        while jf < nfr && jf * hop < end {
            snr = snr.max(e[jf]);
            if e[jf] < end_thr {
                quiet += 1;
                if quiet >= 4 {
                    end = end.min((jf + 1) * hop);
                    break;
                }
            } else {
                quiet = 0;
            }
            jf += 1;
        }
        snr = snr.max(e[(s / hop).min(nfr - 1)]);
        let seg = Segment { start: s, end, snr_db: 10.0 * (snr / noise).log10() };
        if ((end - s) as f64) < opts.min_impact_s * fs {
            out.skipped.push((
                seg,
                format!("too short ({:.0} ms); leave more time between taps", 1e3 * (end - s) as f64 / fs),
            ));
        } else if seg.snr_db < opts.min_snr_db {
            out.skipped.push((
                seg,
                format!("too quiet ({:.0} dB above the noise); tap harder or reduce background noise", seg.snr_db),
            ));
        } else {
            out.impacts.push(seg);
        }
    }
    out
}
