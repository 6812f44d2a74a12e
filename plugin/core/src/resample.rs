//! Band-limited resampling of mono clips (rubato's FFT resampler): the editor's A/B clips
//! and the residual layer's transfers, made at a recording's rate, played at the host's.

use rubato::audioadapter_buffers::direct::InterleavedSlice;
use rubato::{Fft, FixedSync, Resampler};

/// Resamples mono `x` from `from` Hz to `to` Hz (band-limited). Same length ratio as the
/// rates, the resampler's delay removed.
///
/// # Errors
/// If a rate is zero or the resampler cannot be built.
pub fn resample(x: &[f32], from: u32, to: u32) -> Result<Vec<f32>, String> {
    if from == 0 || to == 0 {
        return Err("a sample rate of 0 Hz".into());
    }
    if from == to || x.is_empty() {
        return Ok(x.to_vec());
    }
    let mut r =
        Fft::<f32>::new(from as usize, to as usize, 1024, 1, FixedSync::Both).map_err(|e| format!("resampler: {e}"))?;
    let needed = r.process_all_needed_output_len(x.len());
    let mut out = vec![0.0f32; needed];
    let input = InterleavedSlice::new(x, 1, x.len()).map_err(|e| format!("resampler input: {e}"))?;
    let mut output = InterleavedSlice::new_mut(&mut out, 1, needed).map_err(|e| format!("resampler output: {e}"))?;
    let (_, produced) =
        r.process_all_into_buffer(&input, &mut output, x.len(), None).map_err(|e| format!("resampling: {e}"))?;
    let want = ((x.len() as f64) * f64::from(to) / f64::from(from)).round() as usize;
    out.truncate(produced.min(want));
    Ok(out)
}
