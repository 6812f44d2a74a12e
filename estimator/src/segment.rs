//! Impact segmentation: onsets from short frames (5 ms, hop 2.5 ms) of the signal, each
//! impact running from its onset until it decays into the local noise floor, the next onset,
//! or `max_impact_s`.
//!
//! Each frame has its energy and its power spectrum (Hann window, one-sided, scaled so that
//! white noise of variance σ² gives σ² in every bin). From the spectrum comes a *flat-noise
//! level* ν = median over bins / ln 2: the variance of the white noise that would explain
//! the frame's typical bin (the median of an exponential variable is ln 2 × its mean), so
//! narrow modal peaks do not raise it. Rules:
//! - Noise floor: the lower of the 10th percentile of frame energy and the 10th percentile
//!   of ν, so a file that rings from its first to its last sample (a trimmed sample-library
//!   file) still has the floor of its noise, not of its ringing; over the frames from the
//!   first to the last that is not constant (the digital silence an editor pads a take with
//!   before and after measures no noise; a gate's inside the file still counts).
//! - Onset candidate: energy over the floor by `onset_db`, and either the frame's energy
//!   rises by `rise_db` over the previous 20 ms, or (a tap while the object still rings) the
//!   energy that is new in this frame, bin by bin (Σ max(0, P − rise × P_prev)), is at least
//!   half the previous frames' energy. The first frame of the file counts as a rise: a file
//!   that starts with the ringing has its onset at sample 0.
//! - While an impact still rings, a new onset must also be broadband (see below): a fresh
//!   strike excites many modes or a click, whereas beating of close modes or a slowly
//!   building partial of the same hit raises only a few peaks.
//! - A candidate is a strike only if what follows is tonal (a quarter of the energy of the
//!   40 ms from the onset, or from the loudest frame of its first 100 ms — a bell that swells
//!   after a quiet contact —, lies in spectral peaks ≥ 12 dB over their neighbourhood's
//!   median) or transient (the energy 75–100 ms later is `onset_db` below the onset's), or
//!   it is the start of a file whose loudest moment comes within its first 250 ms (a sample
//!   library's trimmed strike: drums are neither sharply tonal nor that fast), or it comes
//!   while an impact rings (it then passed the rules below, within 20 dB of that impact's
//!   peak: a tom or a timpani struck again), or it is a low drum: tonal on 4× the window
//!   (6 Hz bins: a tom's partials 110–290 Hz fill the 23 Hz bins' neighbourhoods) and decayed
//!   `onset_db` 0.2, 0.4 or 0.8 s on (a tom falls only a few dB in 100 ms). A step of the
//!   noise floor (digital silence → room noise) is none of these, and is reported, not
//!   analysed.
//! - A candidate whose 40 ms before (`STEADY_FRAMES`) were all over the onset threshold and
//!   not `rise_db` under it is a steady sound's ripple, neither a strike nor a noise step
//!   (a mains hum's 5 ms frames rise 6 dB over their mean every cycle), unless an impact rings
//!   or it starts the file.
//! - Within `SAME_STRIKE_S` of an onset, while that impact rings, a new onset must also come
//!   within `onset_db` of the impact's peak: the beating and cavity swells of one strike
//!   (woodblocks, music boxes, temple blocks) rise by 6 dB at −30 dB, a second strike that
//!   soon after is as loud as the first. Later in the ring it must come within
//!   `RINGING_RESTRIKE_DB` (20 dB) of that peak: a tap 20 dB softer than the one still
//!   ringing is taken as part of it. The same holds within `SAME_STRIKE_S` after a ring was
//!   cut to digital silence (a tail cut into runs of zeros by a gate comes back for a moment).
//! - While an impact rings, its new bins must be broad: the bins that rose and lie within
//!   30 dB of the frame's strongest add up to `MIN_NEW_SPAN_HZ` (two beating partials far
//!   apart rise together but are not broad).
//! - ... or the strike must break the ring's prediction: a strike that re-excites only the
//!   partials already ringing (a soft mallet: no click, no new band, and a rise of each
//!   partial that depends on its phase against the ring) is seen by a linear predictor of
//!   order 24 (its samples spread over 4 ms), 1.25 ms ahead, fitted to the 40 ms of ring that
//!   end a hop before the frame (covariance method, `RingPredictor`; soon after an onset, to
//!   as much of them as the ring since the onset's first 5 ms fills, 20 ms at least:
//!   `LP_MIN_TRAIN_S`). Decaying partials are predicted to the noise
//!   whatever their amplitudes and beating; a strike that changes them is not. The frame's
//!   prediction error must jump `LP_JUMP_DB` (9 dB) over the largest of the 20 ms before,
//!   the energy rise 0.5 dB, and the ring's loudest frame lie 10 ms before those 20 ms (a
//!   sample library's glitch does not raise the energy, an attack still building is not
//!   past its peak); the onset is the first sample whose error is 15 dB over the ring's.
//!   (A strike that does not raise the energy, in antiphase to the ring, is not cut here, but
//!   may be reported: the last rule below.)
//!   What the predictor cannot follow is what a modal model leaves in its residual (the
//!   contact, a new excitation), as in Ren et al. 2013's residual (§6.1), here run forward in
//!   time.
//! - The other way round, an onset followed within `SAME_STRIKE_S` by one 10 dB louder than
//!   anything since — or by any louder one while it still swells (`PRECURSOR_SWELL`) — was
//!   that strike's precursor (a music box's pin lifting the tooth, a
//!   mallet grazing first): it is reported as skipped and the strike starts at the loud onset,
//!   even within `min_gap_s` of the precursor (from its first 10 ms on: a strike that loud
//!   within them is the precursor's own attack). Not when the first onset was a strike of its
//!   own: it peaked in its first 10 ms and decayed (did not rise 0.5 dB over that peak), and
//!   the second is less than 15 dB over it (`PRECURSOR_REGROWTH`) or it fell 3 dB by then
//!   (`PRECURSOR_DECAYED`: a soft strike 20 dB under a hard one).
//! - The minimum gap (`min_gap_s`) counts from the onset's frame, so it ends 45–50 ms after
//!   the onset sample, and holds only while the impact rings: a tick that decayed into the
//!   floor or 40 dB under its peak (`RANG_OUT_DB`) within it is over, and what rises next is
//!   a strike of its own (the tick is then analysed up to it, or skipped as too short, which
//!   the report says).
//! - Any other strike within `min_gap_s` of an onset stays part of that impact, but one that
//!   rises like an onset while the impact rings, after it fell `rise_db` from its peak (from
//!   15 ms after the onset on: the rise rules above, or `rise_db` over the 10 ms before;
//!   broadband) is reported in
//!   [`Segmentation::restrikes`] (a mallet's bounce, a flam) when it falls inside an
//!   analysed impact: its decays then mix two strikes, unless it cuts the impact (below).
//! - Last, each analysed impact is searched for strikes that were neither cut nor reported
//!   (a roll 25–45 ms apart, inside the gap; strikes whose ring before gave the predictor no
//!   20 ms to train on; strikes that lowered the energy), with the predictor trained on 8 ms,
//!   from 23 ms after the onset on, energy or not: its error must jump 20 dB over a ring
//!   predicted to 1 % of its energy, to −30 dB of the frame's (a loop's splice in a sampled
//!   marimba jumps 10–16 dB to −34 dB of the frame), leave the object ringing, be spread over
//!   its first samples (a two-sample pulse is not) and settle once the predictor's regressors
//!   have passed it (a fade-out does not). They are reported in
//!   [`Segmentation::restrikes`] too.
//! - A reported strike after which the ring's spectrum rose (some partial re-excited:
//!   [`Segmentation::cuts`]) cuts its impact for the analysis ([`Segmentation::pieces`]);
//!   one within `SAME_STRIKE_S` of the onset, louder than anything before, after a sound
//!   that rose and never decayed makes that sound its precursor, as the onsets' swell rule
//!   does.
//! - A file's first sound whose attack rises gradually — 3 ms or more from the last moment
//!   it was 20 dB under the peak of its first 100 ms to 1 dB under that peak (not exceeded
//!   later: a swell still rising is none), still 4 dB under it half way, its top gradual (a
//!   fade-in at the start of a trimmed file, a soft mallet's long contact) — is analysed from
//!   where it rings freely, half the rise's length after it reached −1 dB (`attack_end`); it
//!   is said in [`Segmentation::attacks`]. Known limit: partials beating to a null under
//!   −20 dB during the fade shorten the measured rise (the fade may then be missed).
//! - The other end: a ring that falls away faster than it rang (`fade_out_start`: its last
//!   frames 10 dB under the line its level followed in dB, lower than ever before, the
//!   shortfall deepening through the fade) — an editor's fade-out at the end of a trimmed
//!   sample, a gate, a hand damping the object — is analysed up to where that began, less a
//!   quarter of the fade's length; said in [`Segmentation::fades`]. A free ring cannot do
//!   that: a sum of damped sinusoids has a log-convex envelope (its fast partials die
//!   first), save for beating. A file that ends in a beat's null falls away like a fade, so
//!   the fall must go 6 dB deeper than the ring dipped under its line before (up to a fade's
//!   length before the fall), and if it dipped 5 dB there (it may beat), last under a quarter
//!   of the time since the last such dip (a fall into a null takes half the beat's period; an
//!   independent black-box test found a 1 Hz doublet ending at its null cut at 1.0 of 1.5 s,
//!   its decay doubled, before this). The line is fitted after the last cut inside the
//!   impact (a strike only reported there, where the ring only fell, may be the fade's own
//!   start). Known limits: a beat slower than the record that ends in its null (1.1 Hz,
//!   equal partials, 0.5 s) is taken for a fade, analysed to 0.30 s; a fade over most of the ring (0.4 s of a 0.5 s file) is found
//!   late, the line being fitted inside it (analysed to 0.35 s: the fundamental's decay
//!   3.90 s⁻¹ for 3.0; 5.2 without this rule); a fade on a ring that beats deeply (toms,
//!   timpani) is mostly left in; fades under 10 ms are not looked for (a 10 ms linear fade at
//!   the end of 0.2 s: decays 1.6 % slow).

use realfft::num_complex::Complex64 as C64;
use realfft::RealFftPlanner;
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
    /// Impacts are analysed over at least this long (unless the next onset or the end of
    /// the file comes first; then shorter ones are skipped), s.
    pub min_impact_s: f64,
    /// Impacts are cut at this length, s.
    pub max_impact_s: f64,
    /// No new onset within this time after the previous one, s, except a strike 10 dB over
    /// everything since that makes the previous onset its precursor (module docs).
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
    /// Noise power per sample around this impact (the local floor; ≥ the file's floor).
    pub noise_var: f64,
}

/// Result of [`segment`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Segmentation {
    /// Impacts kept.
    pub impacts: Vec<Segment>,
    /// Impacts skipped, with the reason.
    pub skipped: Vec<(Segment, String)>,
    /// Noise power per sample (the file's floor, see the module docs).
    pub noise_var: f64,
    /// Sample positions where the level rose like an onset but what followed was steady,
    /// untonal noise (a noise floor that starts or changes): not impacts.
    pub noise_steps: Vec<usize>,
    /// Strikes inside analysed impacts, in time order: `(its sample, the start of the impact
    /// it falls in)` (the impact's onset, or where its analysis starts after a gradual attack:
    /// [`Segmentation::attacks`] maps it back): a second strike inside the minimum gap, and strikes found by
    /// `strikes_within` (a roll faster than the gap, or whose ring gave no 20 ms to train the
    /// predictor on). Not impacts of their own, but said: the impact's analysis mixes the
    /// strikes' decays (module docs) unless the strike is one of [`Segmentation::cuts`].
    pub restrikes: Vec<(usize, usize)>,
    /// The samples of `restrikes` where the ring's spectrum rose (`RESTRIKE_RISE_SHARE`):
    /// a strike that re-excited some of the object's partials, which
    /// [`Segmentation::pieces`] cuts the impact at. (Not where it only fell: a ring
    /// component that stops — a truncated sample under a later strike — breaks the ring's
    /// prediction as clearly as one that starts.)
    pub cuts: Vec<usize>,
    /// Impacts whose attack rose gradually (a fade-in, a sound that swells in), as
    /// `(onset, the sample the analysis starts at)`: the impact in `impacts` starts at the
    /// second, and so do the `restrikes` inside it (module docs).
    pub attacks: Vec<(usize, usize)>,
    /// Impacts whose ring fades out faster than it rang (an editor's fade-out, a gate, a
    /// hand damping the object), as `(the impact's start, where the fall begins, the sample
    /// its analysis now ends at)`: the impact in `impacts` ends at the third (module docs).
    pub fades: Vec<(usize, usize, usize)>,
}

/// A strike inside an impact ([`Segmentation::cuts`]): the frames compared before it (ending
/// a frame before the one holding its onset) and after it (from the frame after), each
/// side this many (4: 10 ms of hops).
const RESTRIKE_SPECTRUM_FRAMES: usize = 4;
/// ... a bin rose when its power after is this many times (3 dB) its power before ...
const RESTRIKE_BIN_RISE: f64 = 2.0;
/// ... and is this many times (6 dB) the impact's noise floor ...
const RESTRIKE_BIN_OVER_FLOOR: f64 = 4.0;
/// ... and the strike re-excited the object when the bins that rose hold this share of the
/// power after it.
const RESTRIKE_RISE_SHARE: f64 = 0.1;

/// Within this time of an onset, a new onset during the ring must be within `onset_db` of
/// the impact's peak (module docs), s.
const SAME_STRIKE_S: f64 = 0.25;
/// Later in the ring, a new onset must still come within this many dB of the impact's peak:
/// the late swells of a long ring (a timpani's beating, a bell's warble) stay far under it,
/// a new tap while the object rings does not.
const RINGING_RESTRIKE_DB: f64 = 20.0;
/// An onset this many times (10 dB) louder than the impact before it, within
/// `SAME_STRIKE_S` of that impact's onset, makes it a precursor (module docs).
const PRECURSOR_DB_RATIO: f64 = 10.0;
/// ... unless that impact is a strike of its own: after its first 10 ms it never rose over
/// this factor (0.5 dB) of their peak, and the onset is under
/// `PRECURSOR_STRUCK_DB_RATIO` (15 dB) over it. A music box's pin scrape rises 1.1–2.5 dB
/// over its first 10 ms by 10–30 ms later (3–4 dB by the release: `metal-music-box-fluid-44`,
/// `-50`, `-60` of `tests/recordings`); a soft strike of a bell decays, and the same bell
/// struck 3× harder 80–250 ms later is 10–12 dB over it. A graze that stays flat (within
/// 0.5 dB) counts as struck: 15–20 dB under the strike it stays a precursor, within 15 dB
/// it is an impact of its own.
const PRECURSOR_REGROWTH: f64 = 1.122;
/// See `PRECURSOR_REGROWTH`.
const PRECURSOR_STRUCK_DB_RATIO: f64 = 31.623;
/// A first onset whose ring fell this factor (3 dB) from its first 10 ms by its last 10 ms
/// before a louder onset is a strike of its own however much louder that one is
/// (`PRECURSOR_STRUCK_DB_RATIO` holds only for what did not fall that far). Limit: a ring
/// falls 3 dB in ~100 ms only if its strongest partial decays at d ≳ 3.5 s⁻¹; a soft strike
/// on a slowly decaying bell or glockenspiel 15 dB or more under a strike soon after is
/// still taken as its precursor.
const PRECURSOR_DECAYED: f64 = 2.0;
/// A precursor still rising when the next onset comes — gradually this factor (3 dB) over
/// its first 10 ms, never 3 dB under them on the way, and loudest in its last 10 ms — is
/// that onset's precursor however little
/// louder the onset is: a music box's pin pressing the tooth until it slips off
/// (`metal-music-box-fluid-64` of `tests/recordings` swells 11 dB over 45 ms and holds to the
/// release at 70 ms, which is 2.6 dB over it). A struck object's ring decays instead.
/// Known limit (an independent review, stop 36): a strike that swells without a dip — a
/// vibraphone struck at its tremolo's trough — and is struck again while still swelling is
/// taken as the second strike's precursor; 3× harder (10–16 dB) the older 10 dB rule already
/// took it so (measured on a synthetic 5 Hz, 12 dB tremolo, second strike 60–90 ms later).
const PRECURSOR_SWELL: f64 = 2.0;

/// Frames (2.5 ms hops) of a possible precursor's own start, its first 10 ms, that a strike
/// making it a precursor must come after and be compared with.
const PRECURSOR_MIN_FRAMES: usize = 4;
/// An impact that fell this far under its peak (or into the floor) no longer holds the
/// minimum gap: what is left of its ring is negligible, a strike then is one of its own, dB.
const RANG_OUT_DB: f64 = 40.0;
/// New bins of an onset during a ring must add up to at least this, Hz.
const MIN_NEW_SPAN_HZ: f64 = 1500.0;
/// Share of the following 10 ms's energy in spectral peaks that makes a candidate tonal.
const TONAL_SHARE: f64 = 0.25;
/// A bin is a peak if it exceeds its neighbourhood's median (±8 bins) by this factor (12 dB).
const PEAK_OVER_MEDIAN: f64 = 16.0;

/// How the reason of a skipped precursor begins.
const PRECURSOR: &str = "the precursor";

/// Whether a skipped segment's reason says it was a strike's precursor (part of that strike,
/// not an impact of its own).
pub fn is_precursor(reason: &str) -> bool {
    reason.starts_with(PRECURSOR)
}

/// The start of the reason of a stretch of an impact left out because a strike inside it
/// came too soon after it ([`Segmentation::pieces`]).
pub const BEFORE_RESTRIKE: &str = "cut short by a strike inside the impact";

impl Segmentation {
    /// The stretches of the recording to analyse: each impact cut at the strikes found
    /// inside it that re-excited the object ([`Segmentation::cuts`]: a bounce, a roll faster
    /// than the gap, a strike in antiphase to the ring that lowered its energy), so no
    /// analysed stretch mixes two strikes. What a strike leaves on a ringing linear object is the same modes with new
    /// amplitudes and phases: from the strike on the recording is again a sum of damped
    /// sinusoids at the object's frequencies and decays, while a stretch across it has an
    /// envelope that jumps (a roll's merged impact gave a comb of made-up modes and decays
    /// slowed by each new strike). Each stretch ends where the next strike's first samples
    /// begin (one frame, 5 ms, before its onset sample, as between impacts); one shorter
    /// than `min_impact_s` is returned as skipped (its reason starts with
    /// [`BEFORE_RESTRIKE`] when a strike follows it) and the strike after it is analysed.
    /// An impact without a strike inside is returned whole. The stretches keep their
    /// impact's SNR and noise floor. `fs` is the sample rate of the segmented samples.
    pub fn pieces(&self, fs: f64, min_impact_s: f64) -> (Vec<Segment>, Vec<(Segment, String)>) {
        let lead = 2 * hop_len(fs);
        let min_len = (min_impact_s * fs) as usize;
        let (mut kept, mut short) = (Vec::new(), Vec::new());
        for imp in &self.impacts {
            let inside: Vec<usize> = self.cuts.iter().copied().filter(|&r| r > imp.start && r < imp.end).collect();
            if inside.is_empty() {
                kept.push(*imp);
                continue;
            }
            let mut start = imp.start;
            for r in inside.into_iter().chain(std::iter::once(imp.end)) {
                let last = r == imp.end;
                let end = if last { r } else { r.saturating_sub(lead).max(start + 1) };
                let piece = Segment { start, end, ..*imp };
                let ms = 1e3 * (end - start) as f64 / fs;
                if end - start >= min_len {
                    kept.push(piece);
                } else if last {
                    short.push((piece, format!("too short ({ms:.0} ms from a strike inside the impact to its end); leave more time between taps")));
                } else {
                    short.push((
                        piece,
                        format!(
                            "{BEFORE_RESTRIKE} ({ms:.0} ms before it, at {:.3} s): too short to analyse; leave more time between taps",
                            r as f64 / fs
                        ),
                    ));
                }
                start = r;
            }
        }
        (kept, short)
    }
}

/// What [`clear_of_clipping`] did to one analysed piece.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClippedPiece {
    /// The piece's start (its onset, or where its analysis started) before.
    pub start: usize,
    /// The stretch analysed instead, `[from, to)`: the longest without clipping.
    pub from: usize,
    /// See `from`.
    pub to: usize,
    /// Clipped samples inside the piece.
    pub samples: usize,
}

/// Each piece with clipped samples inside it is analysed over its longest stretch without
/// them, if that is at least `min_len` samples long; else it is left out (returned third,
/// with its clipped samples).
///
/// `clipped`: runs `[from, to)` of clipped frames, ascending and apart, as
/// [`crate::wav::Recording::clipped`]. A piece is clipped if two or more such samples lie in
/// it (a value held, or peaks cut off at one extreme value), and then every run in it is
/// left out; one sample at full scale, or two in one run, is a normalised recording's peak
/// (a peak between two samples rounds both onto the top code), and its piece is kept
/// whole. A clipped waveform is cut off: no sum of damped sinusoids explains it (Ren
/// §4's model), and the fits bend to it (ten Rayleigh modes with 12 samples clipped at the
/// first strike: α₂ 33 % low; fitted whole, a 150 ms strike driven 2× over full scale gave
/// α₁ −99.7 %, its clipping's harmonics most of its features). Clipping is at the loud
/// start of a strike, so the stretch kept is mostly the ring after its last clipped sample.
pub fn clear_of_clipping(
    pieces: Vec<Segment>,
    clipped: &[(usize, usize)],
    min_len: usize,
) -> (Vec<Segment>, Vec<ClippedPiece>, Vec<(Segment, usize)>) {
    let mut moved = Vec::new();
    let mut left_out = Vec::new();
    let pieces = pieces
        .into_iter()
        .filter_map(|p| {
            // The runs inside (ascending and apart: a binary search finds the first).
            let first = clipped.partition_point(|r| r.1 <= p.start);
            let runs: Vec<(usize, usize)> = clipped[first..]
                .iter()
                .take_while(|r| r.0 < p.end)
                .map(|r| (r.0.max(p.start), r.1.min(p.end)))
                .collect();
            let samples: usize = runs.iter().map(|r| r.1 - r.0).sum();
            if samples < 2 || runs.len() == 1 && samples == 2 {
                return Some(p);
            }
            // The clean stretches: before the first run, between runs, after the last.
            let mut best = (p.start, p.start);
            let mut at = p.start;
            for &(a, b) in runs.iter().chain(std::iter::once(&(p.end, p.end))) {
                if a > at && a - at > best.1 - best.0 {
                    best = (at, a);
                }
                at = at.max(b);
            }
            if best.1 - best.0 < min_len {
                left_out.push((p, samples));
                return None;
            }
            moved.push(ClippedPiece { start: p.start, from: best.0, to: best.1, samples });
            Some(Segment { start: best.0, end: best.1, ..p })
        })
        .collect();
    (pieces, moved, left_out)
}

/// The segmentation's hop, samples (2.5 ms; its frames are two hops long).
fn hop_len(fs: f64) -> usize {
    ((fs * 0.0025).round() as usize).max(8)
}

/// Whether the sound from frame `j0` up to frame `upto` (exclusive) is a swell, not a strike
/// (`PRECURSOR_SWELL`): it rose `PRECURSOR_SWELL` over its first 10 ms
/// (`PRECURSOR_MIN_FRAMES`), gradually (no 10 ms of it rose half its rise in dB over its level
/// so far: a second strike in a fast roll jumps), never fell 3 dB under its first 10 ms on the
/// way (a struck ring that beats, blooms or swells with a vibraphone's tremolo dips first; a
/// pin pressing the tooth rises from its start), and was at its loudest in its last 10 ms
/// (still rising when what follows came): whatever louder strike ends it is its strike.
fn still_swelling(e: &[f64], j0: usize, upto: usize) -> bool {
    let head_end = (j0 + PRECURSOR_MIN_FRAMES).min(upto);
    let head = e[j0..head_end.max(j0 + 1)].iter().fold(0.0f64, |m, &v| m.max(v));
    let tail = e[head_end..upto].iter().fold(0.0f64, |m, &v| m.max(v));
    let loudest = (head_end..upto).max_by(|&a, &b| e[a].total_cmp(&e[b]));
    let step = (tail / head.max(1e-300)).sqrt();
    let mut so_far = head;
    let gradual = (head_end..upto.saturating_sub(PRECURSOR_MIN_FRAMES)).all(|k| {
        so_far = so_far.max(e[k]);
        e[k + PRECURSOR_MIN_FRAMES] < step * so_far
    });
    let no_dip = loudest.is_some_and(|l| e[head_end..=l].iter().all(|&v| v * PRECURSOR_DECAYED > head));
    tail >= PRECURSOR_SWELL * head && gradual && no_dip && loudest.is_some_and(|k| k + PRECURSOR_MIN_FRAMES >= upto)
}

/// Whether the sound from frame `j0` up to frame `upto` (exclusive) rose `PRECURSOR_SWELL`
/// over its first 10 ms and never fell 3 dB under them (`PRECURSOR_DECAYED`): it never
/// decayed as a struck ring does from its strike. Weaker than [`still_swelling`] (it may
/// have levelled off): for a strike found inside an impact, which the onsets' rules
/// already passed over.
fn rose_and_held(e: &[f64], j0: usize, upto: usize) -> bool {
    let head_end = (j0 + PRECURSOR_MIN_FRAMES).min(upto);
    let head = e[j0..head_end.max(j0 + 1)].iter().fold(0.0f64, |m, &v| m.max(v));
    let tail = &e[head_end..upto];
    tail.iter().fold(0.0f64, |m, &v| m.max(v)) >= PRECURSOR_SWELL * head
        && tail.iter().all(|&v| v * PRECURSOR_DECAYED > head)
}

/// A file's first sound rises gradually (a fade-in, a swell) when it takes at least this
/// long from `FADE_FROM_DB` under its peak to `FADE_TO_DB` under it, s. A struck object's
/// response reaches its level within the contact (well under 1 ms for a hard mallet, 1–2 ms
/// for a soft one on a low bar); an editor's fade-in lasts 5 ms or more.
const FADE_MIN_S: f64 = 0.003;
/// ... and at most this long to reach `FADE_TO_DB` (a longer rise is a swell of the sound
/// itself, the precursor rules' business), s.
const FADE_MAX_S: f64 = 0.1;
/// The rise is measured from this far under the peak, dB ...
const FADE_FROM_DB: f64 = 20.0;
/// ... to this far under it, dB.
const FADE_TO_DB: f64 = 1.0;
/// Half way through the rise (in time) its loudest moment so far is still this far under
/// the peak, dB: a fade rises all along (sine, linear, quadratic and linear-in-dB fades are
/// 5, 6, 8 and 10 dB under there), whereas a strike's response is at its level once the
/// contact is over and may only beat up to a peak later (a bell's partials realigning 6 ms
/// on). The analytic envelope of a sharp onset spreads 1–2 ms to either side of it (the
/// Hilbert transform's 1/t kernel): seven partials struck in sine phase rise over 3.8 ms from
/// −20 to −1 dB, 2.8 dB under the peak half way.
const FADE_MID_DB: f64 = 4.0;
/// The rise from this far under the peak (dB) to `FADE_TO_DB` under it ...
const FADE_NEAR_DB: f64 = 3.0;
/// ... takes at least this share of the whole rise: a fade's top is gradual (10 % of it for
/// one linear in dB from −60 dB, 16–30 % for linear, sine and quadratic ones), a music box's
/// release jumps out of the swell of the pin pressing the tooth.
const FADE_LAST_SHARE: f64 = 0.05;
/// The analysis starts this many times the rise's length after the rise began: a fade's
/// last decibel is as slow as its shape makes it (a linear fade reaches −1 dB at 89 % of its
/// length and its −20 dB at 10 %: 1.5 × the rise ends at 128 %; a sine fade at 100 %, a
/// quadratic one at 125 %, one linear in dB from −60 dB at 114 %).
const FADE_MARGIN: f64 = 1.5;

/// Where the gradual attack of a file's first sound (a fade-in at the start of a trimmed
/// file, a sound that swells in), analysed up to `end`, is over, with a margin: from there a
/// sum of damped sinusoids explains the sound (Ren §4's model; over a fade the
/// modes' amplitudes follow the fade's shape, and the extractor explains it with a comb of
/// fast, made-up modes: a 5 ms linear fade over a four-partial ring gave 6 of them, the
/// strongest a quarter of the fundamental). The envelope is the magnitude of the analytic
/// signal (Hilbert transform by FFT, zero-padded so the end does not wrap onto the start),
/// its power averaged over 0.5 ms, from the file's start over `2 × FADE_MAX_S` (at most to
/// `end`). `None` unless the peak of the first `FADE_MAX_S` is not exceeded later (by more
/// than `FADE_TO_DB`: a swell still rising), and the rise that first reaches `FADE_TO_DB`
/// under it, from the last moment it was `FADE_FROM_DB` under it, takes `FADE_MIN_S` or
/// more, is still `FADE_MID_DB` under the peak half way, and its top is gradual
/// (`FADE_LAST_SHARE`).
fn attack_end(x: &[f32], fs: f64, end: usize) -> Option<usize> {
    let len = ((2.0 * FADE_MAX_S * fs) as usize).min(end).min(x.len());
    if len < 64 {
        return None;
    }
    let n = (2 * len).next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let (fwd, inv) = (planner.plan_fft_forward(n), planner.plan_fft_inverse(n));
    let mut buf = vec![0.0; n];
    for (b, &v) in buf.iter_mut().zip(&x[..len]) {
        *b = f64::from(v);
    }
    let mut spec = fwd.make_output_vec();
    // PANIC: buffer lengths match the plans by construction. (`buf` is scratch after this.)
    fwd.process(&mut buf, &mut spec).expect("fft sizes");
    // The Hilbert transform: −i × the spectrum at positive frequencies, 0 at DC and Nyquist.
    let last = spec.len() - 1;
    for (k, s) in spec.iter_mut().enumerate() {
        *s = if k == 0 || k == last { C64::new(0.0, 0.0) } else { C64::new(s.im, -s.re) / n as f64 };
    }
    let mut h = inv.make_output_vec();
    inv.process(&mut spec, &mut h).expect("fft sizes");
    // Envelope power: x² + H{x}², averaged over the 0.5 ms from each sample on.
    let w = ((0.0005 * fs) as usize).max(1);
    let e2: Vec<f64> = x[..len].iter().zip(&h).map(|(&v, hv)| f64::from(v).powi(2) + hv * hv).collect();
    let mut env = Vec::with_capacity(len.saturating_sub(w) + 1);
    let mut sum: f64 = e2[..w.min(len)].iter().sum();
    for i in 0..=len.saturating_sub(w) {
        env.push(sum / w as f64);
        if i + w < len {
            sum += e2[i + w] - e2[i];
        }
    }
    let head = ((FADE_MAX_S * fs) as usize).min(env.len());
    let peak = env[..head].iter().fold(0.0f64, |m, &v| m.max(v));
    // A sound still rising after `FADE_MAX_S` (louder later by more than its last decibel)
    // is a swell, not a fade.
    let later = env[head..].iter().fold(0.0f64, |m, &v| m.max(v));
    if peak <= 0.0 || later > peak * 10f64.powf(FADE_TO_DB / 10.0) {
        return None;
    }
    let level = |db: f64| peak * 10f64.powf(-db / 10.0);
    let to = env.iter().position(|&v| v >= level(FADE_TO_DB))?;
    // The rise that ends there, from the last moment it was under `FADE_FROM_DB` (noise or
    // a precursor before a strike is not part of the strike's rise).
    let from = env[..to].iter().rposition(|&v| v < level(FADE_FROM_DB)).map_or(0, |i| i + 1);
    let near = from + env[from..=to].iter().position(|&v| v >= level(FADE_NEAR_DB))?;
    let rise = to - from;
    let mid = env[from..=from + rise / 2].iter().fold(0.0f64, |m, &v| m.max(v));
    if (rise as f64) < FADE_MIN_S * fs
        || mid > level(FADE_MID_DB)
        || ((to - near) as f64) < FADE_LAST_SHARE * rise as f64
    {
        return None;
    }
    // Each envelope value is the mean of the `w` samples from its index on.
    Some(from + w / 2 + (FADE_MARGIN * rise as f64).ceil() as usize)
}

/// An impact fades out when its last frames lie this far (dB, on average) under the
/// straight line (in dB) its ring followed before: an editor's fade-out, a gate closing,
/// a hand damping the object. A free ring never falls faster as it goes: a sum of damped
/// sinusoids has a log-convex envelope (its fast components die first), save for beating.
const FADE_OUT_DB: f64 = 10.0;
/// ... and the fade starts after the last frame within this many dB of that line ...
const FADE_OUT_START_DB: f64 = 1.0;
/// ... lasts at least this long (a shorter fade, the few ms an editor puts against a click,
/// changes no decay), s ...
const FADE_OUT_MIN_S: f64 = 0.01;
/// ... and the analysis ends this share of the fade's length before where it starts (where
/// a linear fade is still 1 dB down, 11 % of it has passed).
const FADE_OUT_MARGIN: f64 = 0.25;
/// The line is fitted over the ring from this share of the way to the fade's start on (past
/// the strike's fast first components, which fall faster than the rest) ...
const FADE_OUT_FIT_FROM: f64 = 0.25;
/// ... at first up to this share of the impact (then up to the fade's start, refitted until
/// the start holds).
const FADE_OUT_FIT_TO: f64 = 0.6;
/// The fade's last frames lie this much deeper under the line than the ring dipped under it
/// anywhere before (a beat's nulls), dB ...
const FADE_OUT_DEEPER_DB: f64 = 6.0;
/// A ring that dipped this far under the line before the fade may beat (module docs), dB.
const FADE_OUT_BEAT_DB: f64 = 5.0;
/// An impact is no fade if within this long after its end (before the next strike) the ring
/// comes back (it had beaten to a null in the floor) ...
const FADE_OUT_COMEBACK_S: f64 = 0.5;
/// ... this many times (10 dB) over its last frames' energy.
const FADE_OUT_COMEBACK: f64 = 10.0;
/// The last frames compared with the line: 2.5 % of the impact, 2 (5 ms) to this many (20 ms:
/// a fade of 40 ms at the end of a 2 s ring is half of them).
const FADE_OUT_TAIL_FRAMES: usize = 8;
/// An impact shorter than this many frames (60 ms) is not searched for a fade-out.
const FADE_OUT_MIN_FRAMES: usize = 24;
/// At least this share of the impact is kept, whatever the fade.
const FADE_OUT_KEEP: f64 = 0.2;

/// The frame where the ring of the impact spanning frames `ja..jb` of the frame energies `e`
/// starts to fade out, if it does. Its last frames (2.5 %, 2–`FADE_OUT_TAIL_FRAMES`) lie
/// `FADE_OUT_DB` under the least-squares line (in dB) through its frames from
/// `FADE_OUT_FIT_FROM` of the way to the fade up to the fade (at first up to
/// `FADE_OUT_FIT_TO` of the impact, then refitted up to the fade found, until it holds); the
/// fade starts after the last frame within `FADE_OUT_START_DB` of the line and lasts at
/// least `min_frames`. And it is no free ring's: its end is lower than any frame before; the
/// shortfall grows through it (each quarter's mean deeper than the quarter's before, within
/// `FADE_OUT_START_DB`: a beat's null recovers); it ends `FADE_OUT_DEEPER_DB` deeper than the
/// ring dipped under the line up to a fade's length before it; and if the ring dipped
/// `FADE_OUT_BEAT_DB` there (it may beat), the fade is shorter than a quarter of the time from
/// the last such dip to the end. Energies are floored at
/// `floor` (digital silence after a fade to zero).
fn fade_out_start(e: &[f64], floor: f64, ja: usize, jb: usize, min_frames: usize) -> Option<usize> {
    let k = jb.saturating_sub(ja);
    if k < FADE_OUT_MIN_FRAMES {
        return None;
    }
    let l: Vec<f64> = e[ja..jb].iter().map(|&v| 10.0 * v.max(floor).max(1e-300).log10()).collect();
    let tail = (k / 40).clamp(2, FADE_OUT_TAIL_FRAMES);
    let mut upto = (FADE_OUT_FIT_TO * k as f64) as usize;
    for _ in 0..6 {
        let from = (FADE_OUT_FIT_FROM * upto as f64) as usize;
        if upto < from + 8 {
            return None;
        }
        // The line through frames from..upto (least squares).
        let n = (upto - from) as f64;
        let (mt, ml) = ((from + upto - 1) as f64 / 2.0, l[from..upto].iter().sum::<f64>() / n);
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for (i, &v) in l.iter().enumerate().take(upto).skip(from) {
            sxy += (i as f64 - mt) * (v - ml);
            sxx += (i as f64 - mt).powi(2);
        }
        let slope = sxy / sxx;
        // A ring that does not fall over the fit is no free ring's (a swell, a new strike).
        if slope >= 0.0 {
            return None;
        }
        let short = |i: usize| ml + slope * (i as f64 - mt) - l[i];
        let last = (k - tail..k).map(short).sum::<f64>() / tail as f64;
        if last < FADE_OUT_DB {
            return None;
        }
        let start = (0..k - tail).rposition(|i| short(i) <= FADE_OUT_START_DB)? + 1;
        if start.abs_diff(upto) <= 1 {
            let len = k - start;
            let lowest_before = l[..start].iter().fold(f64::INFINITY, |m, &v| m.min(v));
            let end_level = l[k - tail..].iter().sum::<f64>() / tail as f64;
            let q = |a: usize| {
                let (qa, qb) = (start + a * len / 4, start + (a + 1) * len / 4);
                (qa..qb).map(short).sum::<f64>() / (qb - qa).max(1) as f64
            };
            // (Within a decibel: a gentle fade's first frames hardly fall.)
            let deepening = len >= 4 && (0..3).all(|a| q(a + 1) > q(a) - FADE_OUT_START_DB);
            // A beating ring dips under its line at every null of the beat: a file that ends
            // in one falls away like a fade. The null before came a period earlier, and the
            // fall into a null takes at most half a period: so among the frames from where the
            // line is fitted (the strike's first frames are not the ring's) to a fade's length
            // before it, a fade goes `FADE_OUT_DEEPER_DB` deeper than the ring dipped; and if
            // the ring dipped `FADE_OUT_BEAT_DB` there (it may beat), the fade lasts under a
            // quarter of the time from the last such frame to the end.
            let earlier = from..start.saturating_sub(len).max(from);
            let dipped = earlier.clone().map(short).fold(0.0f64, f64::max);
            let beat_ok =
                earlier.clone().rposition(|i| short(i) >= FADE_OUT_BEAT_DB).is_none_or(|d| 4 * len <= k - (from + d));
            let fade = len >= min_frames
                && end_level < lowest_before
                && deepening
                && last >= dipped + FADE_OUT_DEEPER_DB
                && beat_ok;
            return fade.then_some(ja + start);
        }
        upto = start;
    }
    None
}

/// Starts impact `imp` at `to`, after what came before it in the impact (a precursor, a
/// gradual attack): the strikes reported inside it up to `to` go, the later ones count from
/// `to`.
fn move_start(imp: &mut Segment, to: usize, restrikes: &mut Vec<(usize, usize)>) {
    let old = imp.start;
    restrikes.retain(|&(at, o)| !(o == old && at <= to));
    for r in restrikes.iter_mut().filter(|r| r.1 == old) {
        r.1 = to;
    }
    imp.start = to;
}

/// Takes the impacts at `idx` (ascending indices into `out.impacts`) out of the analysis as
/// skipped, with the reason `why(length in ms)`; the strikes reported and the cuts inside
/// them go with them.
fn skip_impacts(
    out: &mut Segmentation,
    restrikes: &mut Vec<(usize, usize)>,
    idx: &[usize],
    fs: f64,
    why: impl Fn(f64) -> String,
) {
    for &ii in idx.iter().rev() {
        let imp = out.impacts.remove(ii);
        restrikes.retain(|&(_, o)| o != imp.start);
        out.cuts.retain(|&c| !(c > imp.start && c < imp.end));
        let ms = 1e3 * (imp.end - imp.start) as f64 / fs;
        out.skipped.push((imp, why(ms)));
    }
}

/// Power spectra of the frames of a signal.
struct FrameSpectra<'a> {
    x: &'a [f32],
    hop: usize,
    window: Vec<f64>,
    /// Σ window², for the white-noise scaling.
    sw2: f64,
    fft: std::sync::Arc<dyn realfft::RealToComplex<f64>>,
    buf: Vec<f64>,
    out: Vec<C64>,
}

impl<'a> FrameSpectra<'a> {
    fn new(x: &'a [f32], hop: usize, frame: usize) -> Self {
        let m = frame.next_power_of_two();
        let window: Vec<f64> =
            (0..frame).map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / frame as f64).cos()).collect();
        let sw2 = window.iter().map(|w| w * w).sum();
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(m);
        Self { x, hop, window, sw2, buf: vec![0.0; m], out: vec![C64::new(0.0, 0.0); m / 2 + 1], fft }
    }

    fn bins(&self) -> usize {
        self.out.len()
    }

    /// Power per bin of frame j, white noise σ² → σ² per bin.
    fn power(&mut self, j: usize, p: &mut [f64]) {
        let a = j * self.hop;
        let n = self.window.len();
        // Without the frame's mean: the constant left in digital silence by the loader's DC
        // removal is not signal.
        let mean = self.x[a..a + n].iter().map(|&v| f64::from(v)).sum::<f64>() / n as f64;
        self.buf.iter_mut().for_each(|v| *v = 0.0);
        for (i, (b, w)) in self.buf.iter_mut().zip(&self.window).enumerate() {
            *b = (f64::from(self.x[a + i]) - mean) * w;
        }
        // PANIC: buffer lengths match the plan by construction.
        self.fft.process(&mut self.buf, &mut self.out).expect("fft sizes");
        for (pk, o) in p.iter_mut().zip(&self.out) {
            *pk = o.norm_sqr() / self.sw2;
        }
    }
}

/// Flat-noise level of a power spectrum: median / ln 2 (module docs).
fn flat_level(p: &[f64], scratch: &mut Vec<f64>) -> f64 {
    scratch.clear();
    scratch.extend_from_slice(p);
    let mid = scratch.len() / 2;
    let (_, m, _) = scratch.select_nth_unstable_by(mid, f64::total_cmp);
    *m / std::f64::consts::LN_2
}

/// Share of the energy of `p` in bins that exceed their neighbourhood's median (±8 bins) by
/// [`PEAK_OVER_MEDIAN`].
fn tonal_share(p: &[f64]) -> f64 {
    let total: f64 = p.iter().sum();
    if total <= 0.0 {
        return 0.0;
    }
    let mut nb = Vec::with_capacity(17);
    let mut peaks = 0.0;
    for k in 0..p.len() {
        nb.clear();
        nb.extend_from_slice(&p[k.saturating_sub(8)..(k + 9).min(p.len())]);
        let mid = nb.len() / 2;
        let (_, med, _) = nb.select_nth_unstable_by(mid, f64::total_cmp);
        peaks += (p[k] - PEAK_OVER_MEDIAN * *med).max(0.0);
    }
    peaks / total
}

/// [`tonal_share`] of the `len` samples from `a` (fewer at the end of the file; mean removed,
/// Hann window).
fn long_tonal_share(x: &[f32], a: usize, len: usize, fft: &mut std::sync::Arc<dyn realfft::RealToComplex<f64>>) -> f64 {
    let n = len.min(x.len() - a);
    if n < 16 {
        return 0.0;
    }
    let seg = &x[a..a + n];
    let mean = seg.iter().map(|&v| f64::from(v)).sum::<f64>() / n as f64;
    let mut buf = vec![0.0; len];
    for (i, (b, &v)) in buf.iter_mut().zip(seg).enumerate() {
        let w = 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / n as f64).cos();
        *b = (f64::from(v) - mean) * w;
    }
    let mut out = vec![C64::new(0.0, 0.0); len / 2 + 1];
    // PANIC: buffer lengths match the plan by construction.
    fft.process(&mut buf, &mut out).expect("fft sizes");
    let p: Vec<f64> = out.iter().map(|c| c.norm_sqr()).collect();
    tonal_share(&p)
}

/// The window a low drum's tonality is also measured on, in 40 ms windows (module docs).
const LOW_TONAL_WINDOWS: usize = 4;
/// Where a strike that is neither fast nor sharply tonal at 40 ms must have decayed by
/// `onset_db` (any of them; frames of [`DECAY_CHECK_FRAMES`] from there), s.
const DECAY_CHECK_S: [f64; 3] = [0.2, 0.4, 0.8];
/// Frames averaged at each of [`DECAY_CHECK_S`] (25 ms).
const DECAY_CHECK_FRAMES: usize = 10;
/// Where a broad rise that is neither tonal nor fast is checked for a ring that dies away
/// ([`rings_down`]: a cymbal, a gong), s after its onset.
const RING_DOWN_S: [f64; 4] = [0.2, 0.4, 0.8, 1.6];
/// How far (dB under the onset's level) a [`rings_down`] ring must fall by one of
/// [`RING_DOWN_S`]: a noise floor that starts stays where it started.
const RING_DOWN_DB: f64 = 10.0;
/// Most a [`rings_down`] ring may rise from one check to the next (dB): a crash cymbal's
/// energy moves between its bands as it rings (a tester's 18" crash: 6.9 dB under its onset
/// at 0.2 s, 4.6 dB at 0.4 s, then 11 and 18 dB).
const RING_DOWN_REGROW_DB: f64 = 3.0;
/// Most a [`rings_down`] ring may fall from one check to the next (dB): a burst of noise
/// that stops (a noise floor switched off, a gate closing) drops to the floor at once; a
/// struck object's ring falls 5–15 dB per doubling of time.
const RING_DOWN_STEP_DB: f64 = 20.0;

/// Whether the sound from frame `j` (its onset's level `e_on`) dies away as a struck
/// object's ring does, without a tonal spectrum: a cymbal, a gong, a splash whose partials
/// are too dense to be sharp in 40 ms and whose ring blooms for tens of milliseconds, so it
/// is neither tonal nor fast (a black-box tester's 68 real clips: 7 cymbals gave "no impacts
/// found", their onsets taken for a noise floor that starts). At each of [`RING_DOWN_S`]
/// that fits in the file (at least two), the mean energy over [`DECAY_CHECK_FRAMES`]: never
/// over the onset's by more than [`RING_DOWN_REGROW_DB`] (a louder sound after a floor that
/// started is the strike, found at its own onset), falling by [`RING_DOWN_DB`] by one of
/// them (a floor that starts stays), and gradually: no check over the one before by more
/// than [`RING_DOWN_REGROW_DB`] nor under it by more than [`RING_DOWN_STEP_DB`].
fn rings_down(e: &[f64], j: usize, at: &[usize], e_on: f64) -> bool {
    let levels: Vec<f64> = at
        .iter()
        .map(|&d| j + d)
        .filter(|&a| a + DECAY_CHECK_FRAMES <= e.len())
        .map(|a| {
            let mean = e[a..a + DECAY_CHECK_FRAMES].iter().sum::<f64>() / DECAY_CHECK_FRAMES as f64;
            10.0 * (mean / e_on.max(1e-300)).max(1e-30).log10()
        })
        .collect();
    levels.len() >= 2
        && levels.iter().all(|&l| l <= RING_DOWN_REGROW_DB)
        && levels.iter().any(|&l| l <= -RING_DOWN_DB)
        && levels.windows(2).all(|w| w[1] <= w[0] + RING_DOWN_REGROW_DB && w[1] >= w[0] - RING_DOWN_STEP_DB)
}
/// A sound the file starts with that is not the file's loudest, whose mean energy 0.2 s on is
/// within this (dB) of its first 25 ms's and has not fallen this much 0.4, 0.8 or 1.6 s on, is a
/// steady sound (a hum, a room tone), not a strike. A ring that slow (every partial's decay
/// rate under about 0.07 s⁻¹) at the file's start is dropped with it.
const START_STEADY_DB: f64 = 1.0;

/// Frames before a candidate (40 ms) that, all over the onset threshold and none `rise_db`
/// under it, make it a steady sound's ripple, not an onset (module docs).
const STEADY_FRAMES: usize = 16;

/// Order of the linear predictor that follows a ring (12 partials).
const LP_ORDER: usize = 24;
/// Its training window, s: the 40 ms that end a hop before the frame it predicts ...
const LP_TRAIN_S: f64 = 0.04;
/// ... or as much of them as the ring since the onset's first 5 ms fills, this much at
/// least, s: a strike 50–75 ms after the onset is judged on 20–40 ms of ring (with the full
/// 40 ms only, the predictor first fired 75 ms after an onset).
const LP_MIN_TRAIN_S: f64 = 0.02;
/// A strike on a ringing object that re-excites only the partials already ringing: the
/// prediction error of the frame (and the next) rose this far over the largest of the 20 ms
/// before (module docs), dB ...
const LP_JUMP_DB: f64 = 9.0;
/// ... while the frame energy rose by this much over the 12.5 ms before (a strike in phase
/// against the ring may lower it; one on a slowly decaying ring soon after the first may
/// raise it by less than a dB), dB.
const LP_ENERGY_RISE_DB: f64 = 0.5;
/// ... unless the error jumped this far, dB, ...
const LP_CLEAR_JUMP_DB: f64 = 20.0;
/// ... over a ring predicted to this share of its energy ...
const LP_RING_PREDICTED: f64 = 0.01;
/// ... to this share of the frame's energy (a strike on a glass that a roll 25 ms apart built
/// up brings −16 to −27 dB of the frame; a loop's splice in a sampled marimba −34 dB and
/// under) ...
const LP_NEW_SHARE: f64 = 0.001;
/// ... and no sample of its first `ahead` carries more than this share of their error.
const LP_PEAK_SHARE: f64 = 0.25;
/// ... and the error settles to this share of its burst once the regressors have passed the
/// strike (`RingPredictor::settles`).
const LP_SETTLED: f64 = 0.1;
/// Training of the search for strikes inside an impact (`strikes_within`), s: a roll's
/// strikes 25 ms apart leave 8 ms of ring, with the regressors' reach, between them (and 4
/// samples per coefficient at least: 12 ms at 8 kHz).
const LP_SHORT_TRAIN_S: f64 = 0.008;
/// A clear strike leaves the object ringing: the energy after it is at least this share of
/// the energy before.
const LP_LEFT_RINGING: f64 = 0.1;

/// The predictor's `LP_ORDER` regressors are spread over this span, s (see `RingPredictor`).
const LP_SPAN_S: f64 = 0.004;

/// Prediction error of frames by a linear predictor fitted to the ring just before them
/// (covariance method: least squares over the training window, no window function, so a
/// sum of decaying sinusoids is predicted to the noise). It predicts each sample from
/// `LP_ORDER` samples that end half a hop (1.25 ms) before it: a ring is predictable that
/// far ahead whatever its partials' amplitudes or beating, but a strike changes them, so the
/// error jumps where a strike lands even when it re-excites only the partials already
/// ringing, in any phase (issue 10: a soft mallet's second strike on a ringing bell). (A
/// one-step predictor sees only the strike's broadband part: on two of the black-box
/// tester's files, a 1 ms force pulse on partials that start in sine phase, it rose 7 dB over
/// the ring's, against 24–27 dB half a hop ahead; the 1 ms cases of
/// `a_second_soft_strike_on_a_ringing_bell_is_found` are of that kind.)
///
/// The regressors are not consecutive: their lags k + (S − p)(k/(p−1))², k < p, spread
/// them over `LP_SPAN_S` (S samples). 24 consecutive samples span 0.5 ms at 44.1 kHz, over
/// which partials of a few hundred Hz are nearly straight lines: extrapolating them 1.25 ms
/// ahead amplifies the noise, so in 43 dB of noise a roll's ring (partials 220–4,100 Hz) was
/// predicted no better than by zero (error 0.83 of the ring's energy) and no later strike of
/// the roll was found. Spread over 4 ms the same fit leaves 1.8 × 10⁻⁴ and the strike stands
/// 33 dB over it. Quadratic, not even, spacing: even steps of s samples alias partials
/// fs/s apart onto one another (a glockenspiel's ring was predicted 2–6× worse with s = 4).
/// On 237 windows of ring of the 82 real clips (`tests/recordings`), 30 ms to 0.3 s after
/// the peak: median error 10^−1.70 of the energy with consecutive regressors, 10^−2.47 over
/// 4 ms (10^−2.36 over 2.5 ms, 10^−2.44 over 6 ms), better by over 3 dB in 124 windows and
/// worse in none.
struct RingPredictor<'a> {
    x: &'a [f32],
    hop: usize,
    frame: usize,
    /// Longest training window, samples (`LP_TRAIN_S`).
    train: usize,
    /// How far back each regressor lies from its target, samples: half a hop, plus one, plus
    /// its lag (increasing; `reach` is the last).
    offsets: [usize; LP_ORDER],
    reach: usize,
    /// Mean squared error per frame, NaN until computed, and the training window it was
    /// computed with.
    err: Vec<f64>,
    err_train: Vec<usize>,
    /// Covariance over the training window of the target x[n] (index 0) and the regressors
    /// x[n − offsets[k − 1]] (index k ∈ 1..=LP_ORDER): the lower triangle, row-major.
    phi: Vec<f64>,
    /// Power of the samples' quantisation noise, q²/12 with q the smallest nonzero change
    /// between samples (one step of an integer file; negligible in a float one).
    floor: f64,
    /// The training window `phi` holds, and how many times it was updated from another.
    window: (usize, usize),
    updates: usize,
    coef: Vec<f64>,
}

impl<'a> RingPredictor<'a> {
    fn new(x: &'a [f32], fs: f64, hop: usize, frame: usize, nfr: usize) -> Self {
        let n = LP_ORDER + 1;
        let ahead = hop / 2;
        let spread = ((LP_SPAN_S * fs).round() as usize).saturating_sub(LP_ORDER) as f64;
        let mut offsets = [0; LP_ORDER];
        for (k, o) in offsets.iter_mut().enumerate() {
            let u = k as f64 / (LP_ORDER - 1) as f64;
            *o = ahead + 1 + k + (spread * u * u).round() as usize;
        }
        let q = smallest_step(x);
        Self {
            x,
            hop,
            frame,
            floor: if q.is_finite() { q * q / 12.0 } else { 0.0 },
            train: (LP_TRAIN_S * fs) as usize,
            offsets,
            reach: offsets[LP_ORDER - 1],
            err: vec![f64::NAN; nfr],
            err_train: vec![0; nfr],
            phi: vec![0.0; n * n],
            window: (0, 0),
            updates: usize::MAX,
            coef: vec![0.0; LP_ORDER],
        }
    }

    /// First sample of the training window of `train` samples of frame `j` (None when the
    /// file starts later).
    fn train_start(&self, j: usize, train: usize) -> Option<usize> {
        (j * self.hop).checked_sub(self.hop + train).filter(|&t0| t0 > self.reach)
    }

    /// Adds `sign` times the products of the samples `a..b` (targets) and their regressors to
    /// the lower triangle of Φ.
    fn accumulate(&mut self, a: usize, b: usize, sign: f64) {
        const N: usize = LP_ORDER + 1;
        // Four samples per pass over Φ (a rank-4 update: Φ is loaded and stored a quarter as
        // often).
        let mut v = [[0.0f64; N]; 4];
        let mut i = a;
        while i < b {
            let m = (b - i).min(4);
            for (r, vr) in v.iter_mut().enumerate() {
                if r < m {
                    vr[0] = f64::from(self.x[i + r]);
                    for (vk, &o) in vr[1..].iter_mut().zip(&self.offsets) {
                        *vk = f64::from(self.x[i + r - o]);
                    }
                } else {
                    *vr = [0.0; N];
                }
            }
            for l in 0..N {
                let s = [sign * v[0][l], sign * v[1][l], sign * v[2][l], sign * v[3][l]];
                for (k, p) in self.phi[l * N..=l * N + l].iter_mut().enumerate() {
                    *p += s[0] * v[0][k] + s[1] * v[1][k] + s[2] * v[2][k] + s[3] * v[3][k];
                }
            }
            i += m;
        }
    }

    /// Fits the predictor of frame `j` on `train` samples into `coef`; false when the window
    /// is silent.
    fn fit(&mut self, j: usize, train: usize) -> bool {
        let Some(t0) = self.train_start(j, train) else { return false };
        let t1 = t0 + train;
        let n = LP_ORDER + 1;
        // Φ[k][l] = Σ x[i − o_k] x[i − o_l] over the window, o_0 = 0 (the target); the lower
        // triangle (l ≥ k) is kept. From the last window by adding and removing the samples
        // at its edges when they overlap and that is cheaper (the frames of a decision are a
        // hop apart), else directly; directly after 64 updates, or when the window's energy
        // fell 60 dB (the sums then cancel).
        let (c0, c1) = self.window;
        let moved = c0.abs_diff(t0) + c1.abs_diff(t1);
        if self.updates < 64 && c0 < t1 && t0 < c1 && moved < train {
            let before = self.phi[0];
            if t0 < c0 {
                self.accumulate(t0, c0, 1.0);
            } else {
                self.accumulate(c0, t0, -1.0);
            }
            if t1 > c1 {
                self.accumulate(c1, t1, 1.0);
            } else {
                self.accumulate(t1, c1, -1.0);
            }
            self.updates += 1;
            if self.phi[0] < 1e-6 * before {
                self.updates = usize::MAX;
            }
        } else {
            self.updates = usize::MAX;
        }
        if self.updates == usize::MAX {
            self.phi.iter_mut().for_each(|v| *v = 0.0);
            self.accumulate(t0, t1, 1.0);
            self.updates = 0;
        }
        self.window = (t0, t1);
        // Normal equations Σ_l Φ[k][l] c_l = Φ[k][0], k, l ∈ 1..=p, by Cholesky, with a
        // diagonal loading of 1e-9 of the mean power (a ring of few partials in little noise
        // leaves Φ nearly singular).
        let load = 1e-9 * (1..n).map(|k| self.phi[k * n + k]).sum::<f64>() / LP_ORDER as f64;
        if load <= 0.0 || !load.is_finite() {
            return false;
        }
        let p = LP_ORDER;
        let mut l_mat = [[0.0f64; LP_ORDER]; LP_ORDER];
        for i in 0..p {
            for jj in 0..=i {
                let mut s = self.phi[(i + 1) * n + jj + 1] + if i == jj { load } else { 0.0 };
                for k in 0..jj {
                    s -= l_mat[i][k] * l_mat[jj][k];
                }
                if i == jj {
                    if s <= 0.0 {
                        return false;
                    }
                    l_mat[i][i] = s.sqrt();
                } else {
                    l_mat[i][jj] = s / l_mat[jj][jj];
                }
            }
        }
        // L y = b, Lᵀ c = y.
        for i in 0..p {
            let mut s = self.phi[(i + 1) * n];
            for k in 0..i {
                s -= l_mat[i][k] * self.coef[k];
            }
            self.coef[i] = s / l_mat[i][i];
        }
        for i in (0..p).rev() {
            let mut s = self.coef[i];
            for k in i + 1..p {
                s -= l_mat[k][i] * self.coef[k];
            }
            self.coef[i] = s / l_mat[i][i];
        }
        true
    }

    /// Largest share of one sample in the squared prediction error of the `ahead` samples
    /// from `s` on (the fitted coefficients).
    fn peak_share(&self, s: usize) -> f64 {
        let (mut sum, mut max) = (0.0f64, 0.0f64);
        for i in s..(s + self.offsets[0]).min(self.x.len()) {
            let v = self.error_at(i).powi(2);
            sum += v;
            max = max.max(v);
        }
        if sum > 0.0 {
            max / sum
        } else {
            1.0
        }
    }

    /// Whether the error settles after a strike at `s` (the fitted coefficients): over a frame
    /// from a hop after the regressors have all passed `s`, the mean squared error is under
    /// `LP_SETTLED` of the mean over the `ahead` samples from `s`. What a strike leaves is a
    /// ring of the same partials, which the predictor follows again once its regressors hold
    /// it; a fade (a sample's tail faded out over 50 ms) keeps changing the envelope, and the
    /// error stays. False when the file ends first.
    fn settles(&self, s: usize) -> bool {
        let a = s + self.reach + self.hop;
        if a + self.frame > self.x.len() {
            return false;
        }
        let burst = (s..s + self.offsets[0]).map(|i| self.error_at(i).powi(2)).sum::<f64>() / self.offsets[0] as f64;
        let later = (a..a + self.frame).map(|i| self.error_at(i).powi(2)).sum::<f64>() / self.frame as f64;
        later <= LP_SETTLED * burst
    }

    /// Prediction error at sample `i` with the fitted coefficients.
    fn error_at(&self, i: usize) -> f64 {
        let pred: f64 = self.coef.iter().zip(&self.offsets).map(|(c, &o)| c * f64::from(self.x[i - o])).sum();
        f64::from(self.x[i]) - pred
    }

    /// Mean squared prediction error of frame `j`, trained on `train` samples (None before
    /// the first training window or on digital silence).
    fn error(&mut self, j: usize, train: usize) -> Option<f64> {
        if j >= self.err.len() {
            return None;
        }
        if self.err[j].is_nan() || self.err_train[j] != train {
            let a = j * self.hop;
            self.err_train[j] = train;
            self.err[j] = if self.fit(j, train) {
                (a..a + self.frame).map(|i| self.error_at(i).powi(2)).sum::<f64>() / self.frame as f64
            } else {
                f64::INFINITY
            };
        }
        Some(self.err[j]).filter(|v| v.is_finite())
    }

    /// First sample from frame `j − 1` on, to the end of frame `j + 1` (the error that fired
    /// may be that frame's), whose squared prediction error (with the predictor of frame
    /// `j − 1`, trained on `train` samples) exceeds `level`, if any.
    fn first_over(&mut self, j: usize, level: f64, train: usize) -> Option<usize> {
        let jf = j.checked_sub(1)?;
        if !self.fit(jf, train) {
            return None;
        }
        let a = jf * self.hop;
        (a..(a + 2 * self.hop + self.frame).min(self.x.len())).find(|&i| self.error_at(i).powi(2) > level)
    }
}

/// The smallest nonzero change between neighbouring samples: one quantisation step of an
/// integer file (far under any signal in a float one), infinite for a constant signal. Used
/// by the ring predictor's floor and by the click repair (`features::repair_clicks`).
pub(crate) fn smallest_step<T: Copy + Into<f64>>(x: &[T]) -> f64 {
    x.windows(2).map(|w| (w[1].into() - w[0].into()).abs()).filter(|&d| d > 0.0).fold(f64::INFINITY, f64::min)
}

/// Sample-accurate start of an onset found at frame `j`: the first sample that exceeds the
/// level before (the ring of an earlier tap, or the noise) by 30 % of the rise to the local
/// peak.
fn sample_onset(x: &[f32], j: usize, hop: usize, frame: usize) -> usize {
    let a = j.saturating_sub(1) * hop;
    let b = ((j + 3) * hop + frame).min(x.len());
    let pk = x[a..b].iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let before = x[a.saturating_sub(frame)..a].iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let thr = before.min(pk) + 0.3 * (pk - before.min(pk));
    a + x[a..b].iter().position(|v| v.abs() >= thr).unwrap_or(0)
}

/// A strike at frame `j` on an object still ringing from the onset at sample `onset`, seen by
/// its prediction error ([`RingPredictor`]): the error of frame `j` or `j + 1` `LP_JUMP_DB`
/// over the largest of frames `j − 8 ..= j − 2` (all predicted from the ring after the
/// onset's first 5 ms, by windows of one length: `LP_TRAIN_S`, or what frame `j − 8` has of
/// it, `LP_MIN_TRAIN_S` at least), the energy risen `LP_ENERGY_RISE_DB` over frames `j − 6 ..= j − 2`,
/// and the impact's loudest frame `peak_frame` 10 ms before those (its attack is over).
/// Returns the strike's first sample (where the error first exceeds 30 times (15 dB) the
/// earlier frames' largest), else `None`; a sample library's glitch (the energy does not
/// rise) and an attack still building are not strikes.
fn rings_again(
    pred: &mut RingPredictor,
    e: &[f64],
    j: usize,
    onset: Option<usize>,
    peak_frame: usize,
) -> Option<usize> {
    let onset = onset?;
    if j < 12 + peak_frame || j + 4 > e.len() {
        return None;
    }
    // Every frame of the decision is predicted with the same window: the 40 ms, or as much
    // ring as frame j − 8's window finds after the onset's first 5 ms (20 ms at least).
    let ring = (j - 8).checked_mul(pred.hop)?.checked_sub(pred.hop + onset + pred.frame)?;
    let train = ring.min(pred.train);
    if (train as f64) < LP_MIN_TRAIN_S / LP_TRAIN_S * pred.train as f64 || pred.train_start(j - 8, train).is_none() {
        return None;
    }
    lp_strike(pred, e, j, train, j - 8, j - 6, false)
}

/// The decision of [`rings_again`] and of the search for strikes inside an impact
/// ([`strikes_within`]): frames `j` and `j + 1` against the ring's frames `ring_from..j − 1`
/// (the largest prediction error, all with `train` samples), the energy of frames `j ..= j + 3`
/// against that of frames `rise_from..j − 1`. Onsets (`within` false): the error must jump
/// `LP_JUMP_DB` while the energy rose `LP_ENERGY_RISE_DB`. Strikes inside an impact (`within`):
/// energy or not (a strike in antiphase to the ring takes energy from it; one on a ring that
/// built up over a roll adds 2–5 dB), a clear jump: `LP_CLEAR_JUMP_DB` over a ring predicted
/// to `LP_RING_PREDICTED` of its energy, to `LP_NEW_SHARE` of the frame's, spread over the
/// samples (`LP_PEAK_SHARE`) and settling (`RingPredictor::settles`). Returns the strike's
/// first sample.
///
/// A component of the ring that stops is as clear to the predictor as one that starts: the
/// black-box tester's `s60` (strikes 60 ms apart, each rendered for 1 s and cut there) reports
/// a "strike" 40 ms into each impact from 1.1 s on. The energy does not tell them apart (a
/// strike in a roll lowers it as often as not), so such a file is reported as a roll; a real
/// object's ring does not stop in one sample.
fn lp_strike(
    pred: &mut RingPredictor,
    e: &[f64],
    j: usize,
    train: usize,
    ring_from: usize,
    rise_from: usize,
    within: bool,
) -> Option<usize> {
    let mut reference = 0.0f64;
    for jj in ring_from..j - 1 {
        reference = reference.max(pred.error(jj, train)?);
    }
    // No ring is predicted better than its quantisation (a 16-bit sine at 3 kHz sampled at
    // 8 kHz repeats its pattern of steps every 8 samples: predicted to 10⁻²⁴, it "jumped" 20 dB
    // when the decay changed the pattern).
    reference = reference.max(pred.floor);
    let now = pred.error(j, train)?.max(pred.error(j + 1, train).unwrap_or(0.0));
    let before = e[rise_from..j - 1].iter().fold(0.0f64, |m, &v| m.max(v));
    let after = e[j..j + 4].iter().fold(0.0f64, |m, &v| m.max(v));
    // A clear strike: the ring was predicted to a hundredth of its energy, the error jumped
    // 20 dB to −30 dB of the frame's, and no more than a strike can bring: what is new
    // is at most the sum of the ring before and the sound after in amplitude, (√b + √a)² ≤
    // 4 max(b, a) (more is a predictor thrown by a strike inside its training window); and
    // the object still rings (a ring cut short, a truncated sample, is no strike).
    let ring_e = e[ring_from..j - 1].iter().fold(0.0f64, |m, &v| m.max(v));
    let frame_e = e[j..j + 2].iter().fold(0.0f64, |m, &v| m.max(v));
    let clear = now >= reference * 10f64.powf(LP_CLEAR_JUMP_DB / 10.0)
        && reference <= LP_RING_PREDICTED * ring_e
        && now >= LP_NEW_SHARE * frame_e
        && now <= 4.0 * before.max(after)
        && e[j + 2].min(e[j + 3]) >= LP_LEFT_RINGING * before;
    // The onsets' search cuts where the energy rose; the search inside an impact reports
    // clear strikes. (A clear strike that cut an impact without the energy's rise also cut
    // where a component of the ring stops: a truncated sample under a later strike, as in
    // `tests/recordings/restrike.py`'s mixes, lost 83 of their 812 second strikes to a third
    // impact at the first clip's end.)
    let rose = !within && after >= before * 10f64.powf(LP_ENERGY_RISE_DB / 10.0);
    let clear = clear && within;
    if !(rose || clear) || reference <= 0.0 || now < reference * 10f64.powf(LP_JUMP_DB / 10.0) {
        return None;
    }
    match pred.first_over(j, 30.0 * reference, train) {
        // Without the energy's rise, what the ring did not predict must ring: over the
        // `ahead` samples from its first, before any regressor holds it, the error is the
        // new sound itself, which a strike spreads over them (its partials' sines), whereas
        // a glitch (a two-sample pulse, a splice) puts it in a few samples.
        Some(s) if !rose => (pred.peak_share(s) <= LP_PEAK_SHARE && pred.settles(s)).then_some(s),
        Some(s) => Some(s),
        None => Some(sample_onset(pred.x, j, pred.hop, pred.frame)),
    }
}

/// Strikes inside the impact `start..end` that were not cut (a roll faster than the minimum
/// gap, or one whose ring had no 20 ms free of strikes to train on): [`lp_strike`] with
/// `LP_SHORT_TRAIN_S` of training and the two frames 5 ms before as the ring, from 10 ms after
/// the onset on, each training window after the first 5 ms of the onset or of the last strike
/// found (a strike: 23 ms after it at the earliest) and the loudest frame since 5 ms before
/// the ring's frames. Each strike found is 5 ms after the last; `known` (onsets and strikes
/// already reported) are skipped.
fn strikes_within(pred: &mut RingPredictor, e: &[f64], start: usize, end: usize, known: &[usize]) -> Vec<usize> {
    let (hop, frame) = (pred.hop, pred.frame);
    let train = ((LP_SHORT_TRAIN_S / LP_TRAIN_S * pred.train as f64) as usize).max(4 * LP_ORDER);
    let settle = 2 * frame;
    let mut found = Vec::new();
    let mut j = (start + settle).div_ceil(hop);
    while j + 4 <= e.len() && (j + 2) * hop + frame <= end {
        let last = found.last().copied().unwrap_or(start);
        // The attack of the onset or of the last strike is over: its loudest frame lies 5 ms
        // before the ring's frames (a slow attack's end is no strike).
        let loudest = (last / hop..j - 2).max_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap_or(j);
        if loudest + 5 <= j && pred.train_start(j - 3, train).is_some_and(|t0| t0 >= last + frame) {
            // Every frame from j − 3 to j + 1 in time order (frame j − 1 too, which the
            // decision does not use): each fit then moves the window one hop from the last,
            // the covariance's cheap update, not a rebuild.
            for jj in j - 3..=j + 1 {
                let _ = pred.error(jj, train);
            }
            if let Some(s) = lp_strike(pred, e, j, train, j - 3, j - 3, true) {
                if s > last + frame && s < end && !known.iter().any(|&k| k.abs_diff(s) < 2 * frame) {
                    found.push(s);
                    j = (s + 2 * frame) / hop;
                    continue;
                }
            }
        }
        j += 1;
    }
    found
}

/// Finds the impacts in a mono signal `x` sampled at `fs` Hz.
pub fn segment(x: &[f32], fs: f64, opts: &SegmentOptions) -> Segmentation {
    let hop = hop_len(fs);
    let frame = 2 * hop;
    let nfr = if x.len() >= frame { (x.len() - frame) / hop + 1 } else { 0 };
    if nfr == 0 {
        return Segmentation::default();
    }
    // Frame energy about the frame's mean (see `FrameSpectra::power`).
    let e: Vec<f64> = (0..nfr)
        .map(|j| {
            let w = &x[j * hop..j * hop + frame];
            let m = w.iter().map(|&v| f64::from(v)).sum::<f64>() / frame as f64;
            w.iter().map(|&v| (f64::from(v) - m).powi(2)).sum::<f64>() / frame as f64
        })
        .collect();
    // The frames of digital silence before the first sound and after the last (constant: an
    // editor's padding of zeros, with the loader's offset taken out) measure no noise: the
    // floor is read off the frames between (a take padded with a second of zeros read its
    // floor as none, 120 dB under its peak, and its ring's weak partials changed). A gate's
    // silence between strikes still counts, as it always did.
    let first_live = (0..nfr).find(|&j| e[j] > 0.0).unwrap_or(0);
    let last_live = (0..nfr).rev().find(|&j| e[j] > 0.0).unwrap_or(nfr - 1).max(first_live);
    let between = first_live..last_live + 1;
    let mut spec = FrameSpectra::new(x, hop, frame);
    let mut predictor = RingPredictor::new(x, fs, hop, frame, nfr);
    let nb = spec.bins();
    let mut p = vec![0.0; nb];
    let mut scratch = Vec::with_capacity(nb);
    let mut sorted: Vec<f64> = e[between.clone()].to_vec();
    sorted.sort_by(f64::total_cmp);
    let peak_e = sorted[sorted.len() - 1];
    // Flat-noise levels of up to 2,000 frames spread over those, for the floor.
    let stride = between.len().div_ceil(2000).max(1);
    let mut nus: Vec<f64> = between
        .step_by(stride)
        .map(|j| {
            spec.power(j, &mut p);
            flat_level(&p, &mut scratch)
        })
        .collect();
    nus.sort_by(f64::total_cmp);
    // Floored 120 dB under the loudest frame (synthetic or digital silence).
    let noise = sorted[sorted.len() / 10].min(nus[nus.len() / 10]).max(peak_e * 1e-12).max(1e-30);
    let onset_thr = noise * 10f64.powf(opts.onset_db / 10.0);
    let rise = 10f64.powf(opts.rise_db / 10.0);
    let back = ((0.02 * fs) as usize / hop).max(1);
    let gap = ((opts.min_gap_s * fs) as usize / hop).max(1);
    let bin_hz = fs / (2 * (nb - 1)) as f64;
    let min_span = (MIN_NEW_SPAN_HZ / bin_hz).ceil() as usize;
    // Tonality on ~40 ms from the onset (23 Hz bins at 44.1 kHz: modes resolved).
    let tonal_len = ((0.04 * fs) as usize).next_power_of_two();
    let mut long_fft = RealFftPlanner::<f64>::new().plan_fft_forward(tonal_len);
    // ... and on four times that (6 Hz bins) for low partials a few bins apart.
    let mut longer_fft = RealFftPlanner::<f64>::new().plan_fft_forward(LOW_TONAL_WINDOWS * tonal_len);
    let decay_at: Vec<usize> = DECAY_CHECK_S.iter().map(|&t| (t * fs) as usize / hop).collect();
    let ring_down_at: Vec<usize> = RING_DOWN_S.iter().map(|&t| (t * fs) as usize / hop).collect();
    let (late_a, late_b) = ((0.075 * fs) as usize / hop, (0.1 * fs) as usize / hop);
    let file_head = (0.25 * fs) as usize / hop;
    let same_strike = (SAME_STRIKE_S * fs) as usize / hop;
    // Peak frame energy of the current impact so far.
    let mut impact_peak = 0.0f64;
    // ... and its frame.
    let mut peak_frame = 0;

    // Scan: spectra of the previous `back` frames in a ring, flat level of every frame.
    let mut ring: Vec<Vec<f64>> = vec![vec![0.0; nb]; back];
    let mut prev_sum = vec![0.0; nb];
    let mut nu = vec![0.0; nfr];
    let mut onsets: Vec<(usize, usize)> = Vec::new(); // (sample, frame)
    let mut noise_steps = Vec::new();
    // The minimum gap after the last onset, and the hold after a noise step, in frames.
    let (mut gap_until, mut hold_until) = (0, 0);
    let mut ringing = false;
    let mut quiet = 0;
    let mut end_thr = 2.0 * noise;
    // Frame where the last impact's ring fell into the floor.
    let mut ring_end = 0;
    let mut gated_end = false;
    // Onsets dropped as the precursor of a louder strike right after: (sample, dB louder).
    let mut precursors: Vec<(usize, f64)> = Vec::new();
    let mut restrikes: Vec<(usize, usize)> = Vec::new();
    for j in 0..nfr {
        spec.power(j, &mut p);
        nu[j] = flat_level(&p, &mut scratch);
        let nprev = j.min(back);
        let prev_e = if nprev == 0 { 0.0 } else { e[j - nprev..j].iter().sum::<f64>() / nprev as f64 };
        // The ring was in the floor, or `RANG_OUT_DB` under its peak, for the last two frames
        // (7.5 ms of samples): what is left of it is negligible.
        let was_quiet = ringing
            && (quiet >= 2 || (j >= 2 && e[j - 2].max(e[j - 1]) * 10f64.powf(RANG_OUT_DB / 10.0) < impact_peak));
        if ringing {
            // Decayed into the local floor: four frames under twice the floor before the onset.
            quiet = if e[j] < end_thr { quiet + 1 } else { 0 };
            ringing = quiet < 4;
            if !ringing {
                ring_end = j;
                // Ended on digital silence (a gate, a truncated tail), not by decaying.
                gated_end = e[j] <= peak_e * 1e-12;
            }
        }
        // The same strike's swell or beat, not a new one (module docs).
        let soon = onsets.last().is_some_and(|&(_, j0)| j < j0 + same_strike);
        let margin_db = if soon { opts.onset_db } else { RINGING_RESTRIKE_DB };
        // A ring cut to digital silence for a moment (a noise gate's or a sample's
        // truncated tail: runs of zeros) that comes back far under its peak is the same
        // ring, not a strike. (A ring that decayed into noise is over: a soft tap after it
        // is a strike.)
        let resumed = !ringing && gated_end && !onsets.is_empty() && j < ring_end + same_strike;
        let same = (ringing || resumed) && e[j] * 10f64.powf(margin_db / 10.0) < impact_peak;
        if resumed && same && e[j] >= end_thr {
            // The ring is back: it ends again where it next falls into the floor.
            ringing = true;
            quiet = 0;
        }
        // The ring's loudest frame before this one (a strike louder than the ring's peak
        // moves it to itself just below).
        let ring_peak_frame = peak_frame;
        if ringing && e[j] > impact_peak {
            impact_peak = e[j];
            peak_frame = j;
        }
        // Within the minimum gap only a strike that makes the last onset its precursor is
        // looked at (10 dB over anything since, within its first 10 ms), and only once that
        // onset's own first 10 ms are in (a first frame may hold only a strike's first few
        // samples): the gap would otherwise hold its onset back until its rise is over
        // (issue 10: music boxes).
        // The gap holds only while the impact rings (or was cut to digital silence and may
        // come back): once a tick has decayed into the floor or 40 dB under its peak (the last
        // two frames), what rises next is a new strike, not part of it (issue 10: a fast tick
        // and a louder strike 30–40 ms later were one 30 ms impact, the strike dropped unsaid).
        let in_ring = if ringing { !was_quiet } else { gated_end };
        let blocked = (j < gap_until && in_ring) || j < hold_until;
        let over_precursor = blocked
            && onsets.last().is_some_and(|&(_, j0)| {
                let since = e[j0..j].iter().fold(0.0f64, |m, &v| m.max(v));
                let e_on = e[j..(j + 4).min(nfr)].iter().fold(0.0f64, |m, &v| m.max(v));
                j >= j0 + PRECURSOR_MIN_FRAMES && e_on >= PRECURSOR_DB_RATIO * since
            });
        // A second strike inside the minimum gap (module docs): from 15 ms after the onset
        // on, what would be an onset were it not for the gap, or `rise_db` over the 10 ms
        // before (none of them in the impact's first 10 ms: the 20 ms mean of the onset rule
        // still holds the first strike's attack); one per impact.
        // The impact a second strike at `j` would fall in: only after it fell from its peak (a
        // frame after the peak so far `rise_db` under it: a slow attack or a swell still rising
        // has none).
        // (Inside the minimum gap only: the hold after a noise step is no gap.)
        let gap_onset = onsets.last().copied().filter(|&(o, j0)| {
            j < gap_until
                && in_ring
                && !over_precursor
                && ringing
                && j >= j0 + PRECURSOR_MIN_FRAMES + 2
                && restrikes.last().is_none_or(|&(_, at)| at != o)
                && {
                    let jp = (j0..j).max_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap_or(j0);
                    e[jp + 1..j].iter().any(|&v| v * rise <= e[jp])
                }
        });
        let in_gap = gap_onset.is_some();
        if (!blocked || over_precursor || in_gap) && e[j] > onset_thr && !same {
            let total_rise = e[j] > rise * prev_e.max(noise);
            let (mut new_e, mut wide) = (0.0, 0);
            let prev_tot: f64 = if nprev == 0 { 0.0 } else { prev_sum.iter().sum::<f64>() / nprev as f64 };
            // A bin counts towards the breadth of what is new when it rose and is within
            // 30 dB of the frame's strongest bin.
            let significant = onset_thr.max(1e-3 * p.iter().fold(0.0f64, |m, &v| m.max(v)));
            for k in 0..nb {
                let pp = if nprev == 0 { 0.0 } else { prev_sum[k] / nprev as f64 };
                let extra = p[k] - rise * pp;
                if extra > 0.0 {
                    new_e += extra;
                    if p[k] > significant {
                        wide += 1;
                    }
                }
            }
            let bin_rise = new_e >= 0.5 * prev_tot;
            // Broadband: the risen bins add up to `MIN_NEW_SPAN_HZ` (the span from the lowest
            // to the highest was fooled by two beating partials far apart).
            let broadband = wide >= min_span;
            if let Some((o, j0)) = gap_onset {
                let before = e[(j0 + PRECURSOR_MIN_FRAMES).max(j - 4)..j].iter().fold(0.0f64, |m, &v| m.max(v));
                let jump = e[j..(j + 4).min(nfr)].iter().fold(0.0f64, |m, &v| m.max(v)) >= rise * before;
                if (jump || total_rise || bin_rise) && broadband {
                    restrikes.push((sample_onset(x, j, hop, frame), o));
                }
            } else if let Some(s_hint) = if (total_rise || bin_rise) && (!ringing || broadband) {
                Some(None)
            } else if ringing {
                rings_again(&mut predictor, &e, j, onsets.last().map(|o| o.0), ring_peak_frame).map(Some)
            } else {
                None
            } {
                // Tonal or transient, else a noise floor step.
                let e_on = e[j..(j + 4).min(nfr)].iter().fold(0.0f64, |m, &v| m.max(v));
                // A file that starts with the sound (a sample library's trimmed strike: a
                // drum whose partials are neither sharp nor fast, a bell that swells): its
                // first onset is a strike when the file's loudest moment comes within its
                // first 250 ms.
                let file_start =
                    j == 0 && e[..file_head.min(nfr)].iter().fold(0.0f64, |m, &v| m.max(v)) * 10f64.powf(0.6) >= peak_e;
                // A steady sound's ripple, not an onset: every frame of the last 40 ms over
                // the onset threshold (the sound went on all that time) and none `rise_db`
                // under this one (a mains hum's 5 ms frames rise 6 dB over their 20 ms mean
                // every cycle, and a few of those windows read as tonal: a hum that started
                // mid-file gave an impact). A strike after a tick that rang out, or rising
                // just after a noise floor started, has quiet frames in that window.
                // Falls `onset_db` 0.2, 0.4 or 0.8 s on (which a noise floor that starts or
                // changes, or a hum, does not).
                let decays = decay_at.iter().any(|&d| {
                    let (a, b) = (j + d, j + d + DECAY_CHECK_FRAMES);
                    b <= nfr
                        && e[a..b].iter().sum::<f64>() / DECAY_CHECK_FRAMES as f64 * 10f64.powf(opts.onset_db / 10.0)
                            < e_on
                });
                let steady = !(ringing || file_start)
                    && if j >= STEADY_FRAMES {
                        let w = &e[j - STEADY_FRAMES..j];
                        w.iter().all(|&v| v > onset_thr) && w.iter().fold(0.0f64, |m, &v| m.max(v)) * rise >= e_on
                    } else {
                        // The file starts with a sound that is not its loudest: with nothing
                        // before to compare, it is a steady sound (a mains hum or a room tone
                        // running from the first sample, which gave an impact at 0.001 s whose
                        // undamped "modes" went into the fit) when its mean energy 0.2 s on is
                        // within `START_STEADY_DB` of its first frames' and it has not fallen
                        // that much 0.4, 0.8 or 1.6 s on either (a singing bowl struck softly
                        // at sample 0 falls 1–3 dB by then; a later, louder strike only rises).
                        j == 0 && {
                            let db = |a: usize| {
                                let mean = |a: usize| e[a..a + DECAY_CHECK_FRAMES].iter().sum::<f64>();
                                10.0 * (mean(a) / mean(0).max(1e-300)).log10()
                            };
                            let fits = |a: usize| a + DECAY_CHECK_FRAMES <= nfr;
                            let at = |t: f64| (t * fs) as usize / hop;
                            fits(at(0.2))
                                && db(at(0.2)).abs() < START_STEADY_DB
                                && [0.4, 0.8, 1.6].iter().all(|&t| !fits(at(t)) || db(at(t)) > -START_STEADY_DB)
                        }
                    };
                // The loudest frame of the first 100 ms.
                let jp = (j..(j + late_b).min(nfr)).max_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap_or(j);
                let tonal = !steady
                    && (long_tonal_share(x, j * hop, tonal_len, &mut long_fft) >= TONAL_SHARE
                        || (jp > j && long_tonal_share(x, jp * hop, tonal_len, &mut long_fft) >= TONAL_SHARE));
                let transient = if j + late_b <= nfr {
                    let late = e[j + late_a..j + late_b].iter().sum::<f64>() / (late_b - late_a).max(1) as f64;
                    late * 10f64.powf(opts.onset_db / 10.0) < e_on
                } else {
                    true
                };
                // While an impact rings, a rise that passed the rules above (broad, or one
                // that breaks the ring's prediction, within 20 dB of its peak) is a strike
                // even when it is neither sharply tonal nor fast: a tom or a timpani struck
                // again (a noise floor that starts or changes is not that loud).
                // A low drum (a tom's partials 110–290 Hz, ~65 Hz apart, lie within a few of
                // the 40 ms window's bins, whose neighbourhoods they fill, and it falls only a
                // few dB in 100 ms): a strike when it then decays (`onset_db` down 0.2, 0.4 or
                // 0.8 s on, which a noise floor that starts or changes does not) and is tonal
                // on the 4× window.
                let low_drum = !(steady || tonal || transient || file_start || ringing)
                    && decays
                    && long_tonal_share(x, j * hop, LOW_TONAL_WINDOWS * tonal_len, &mut longer_fft) >= TONAL_SHARE;
                // A cymbal, a gong: a rise that is neither tonal nor fast, and then dies away
                // gradually ([`rings_down`]; its first frames may not be broad: a crash's
                // rise is in a few bands first; a bowed ride's first 10 ms are 8 dB under
                // what follows, and the rise 20 ms on is its onset).
                let noisy_ring = !(steady || tonal || transient || file_start || ringing || low_drum)
                    && rings_down(&e, j, &ring_down_at, e_on);
                if (tonal || transient || file_start || ringing || low_drum || noisy_ring) && !steady {
                    let s = s_hint.unwrap_or_else(|| sample_onset(x, j, hop, frame));
                    if onsets.last().is_none_or(|&(o, _)| s > o) {
                        // A quiet onset followed within `SAME_STRIKE_S` by one whose first
                        // 10 ms peak 10 dB over anything since was its precursor (a music box's pin lifting
                        // the tooth before it is released, a mallet's graze): the strike
                        // starts here.
                        if let Some(&(o, j0)) = onsets.last() {
                            // Its level before this onset's rise (the last 20 ms, which the
                            // minimum gap may have let pass before the onset was taken).
                            // (At least its own first 10 ms.)
                            let upto = j.saturating_sub(back).max(j0 + PRECURSOR_MIN_FRAMES).min(j);
                            let pre_peak = e[j0..upto.max(j0 + 1)].iter().fold(0.0f64, |m, &v| m.max(v));
                            // A strike of its own, not a precursor: it peaked in its first 10
                            // ms and did not rise again by 0.5 dB (a struck object's ring
                            // decays; a pin's scrape rises), and this onset is less than 15 dB
                            // over it (a harder strike of the same object). A flat graze
                            // passes the first test: only the 15 dB keeps it a precursor.
                            let head_end = (j0 + PRECURSOR_MIN_FRAMES).min(upto);
                            let head = e[j0..head_end.max(j0 + 1)].iter().fold(0.0f64, |m, &v| m.max(v));
                            let tail = e[head_end..upto].iter().fold(0.0f64, |m, &v| m.max(v));
                            // However much louder the strike: one that decayed 3 dB from its
                            // first 10 ms by its last 10 ms (a soft strike 20–26 dB under a hard
                            // one 120–240 ms later; a graze stays flat, a scrape rises).
                            let last = e[upto.saturating_sub(PRECURSOR_MIN_FRAMES).max(head_end)..upto]
                                .iter()
                                .fold(0.0f64, |m, &v| m.max(v));
                            let decayed = last * PRECURSOR_DECAYED <= head;
                            let struck = upto >= head_end + PRECURSOR_MIN_FRAMES
                                && tail <= PRECURSOR_REGROWTH * head
                                && (e_on < PRECURSOR_STRUCK_DB_RATIO * pre_peak || decayed);
                            // A swell, not a strike: it rose `PRECURSOR_SWELL` over its first
                            // 10 ms, gradually (no 10 ms of it rose half its rise in dB over
                            // its level so far: a second strike in a fast roll jumps), and was
                            // at its loudest in its last 10 ms (still rising when this onset
                            // came): whatever louder onset ends it is its strike.
                            let swelling = still_swelling(&e, j0, upto);
                            let louder = e_on >= PRECURSOR_DB_RATIO * pre_peak || (swelling && e_on > pre_peak);
                            if j < j0 + same_strike && louder && !struck {
                                precursors.push((o, 10.0 * (e_on / pre_peak).log10()));
                                onsets.pop();
                            }
                        }
                        onsets.push((s, j));
                        // The floor this impact decays into: the one just before it.
                        let pre = if nprev == 0 {
                            noise
                        } else {
                            let mut v: Vec<f64> = nu[j - nprev..j].to_vec();
                            v.sort_by(f64::total_cmp);
                            v[v.len() / 2]
                        };
                        end_thr = 2.0 * noise.max(pre.min(prev_e));
                        ringing = true;
                        quiet = 0;
                        impact_peak = e[j];
                        peak_frame = j;
                    }
                    gap_until = gap_until.max(j + gap);
                } else if !over_precursor && !steady {
                    noise_steps.push(j * hop);
                    hold_until = hold_until.max(j + back);
                }
            }
        }
        // Ring of previous spectra.
        let slot = j % back;
        for k in 0..nb {
            prev_sum[k] += p[k] - if j >= back { ring[slot][k] } else { 0.0 };
        }
        ring[slot].copy_from_slice(&p);
    }

    let mut out = Segmentation { noise_var: noise, noise_steps, ..Default::default() };
    for &(o, db) in &precursors {
        // The reason starts with `PRECURSOR` ([`is_precursor`]).
        let next = onsets.iter().find(|p| p.0 > o).map_or(o + 1, |p| p.0);
        let seg = Segment { start: o, end: next, snr_db: 0.0, noise_var: noise };
        out.skipped.push((
            seg,
            format!("{PRECURSOR} of the strike at {:.3} s ({db:.0} dB quieter): taken as part of it", next as f64 / fs),
        ));
    }
    let max_len = (opts.max_impact_s * fs) as usize;
    let min_len = (opts.min_impact_s * fs) as usize;
    for (i, &(s, j0)) in onsets.iter().enumerate() {
        // Up to 5 ms before the next onset: the onset sample is where the next tap has
        // risen 30 % of the way, so its first samples come a little earlier.
        let next = onsets.get(i + 1).map(|o| o.0.saturating_sub(frame).max(s + 1)).unwrap_or(x.len());
        let mut end = next.min(s + max_len).min(x.len());
        // Local floor: the noise just before the onset, else the file's floor.
        let pre_a = j0.saturating_sub(back);
        let pre = if j0 > pre_a {
            let mut v: Vec<f64> = nu[pre_a..j0].iter().zip(&e[pre_a..j0]).map(|(a, b)| a.min(*b)).collect();
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        } else {
            noise
        };
        let end_thr = 2.0 * noise.max(pre);
        // Decayed into the noise: four consecutive frames under 2 × the local floor.
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
        // Short decays (d up to ~1000 s⁻¹ fall into the floor within ~20 ms) are analysed
        // over at least `min_impact_s`, up to the next onset.
        end = end.max((s + min_len).min(next).min(x.len()));
        snr = snr.max(e[(s / hop).min(nfr - 1)]);
        // The impact's own floor: the quieter of its frames' energy and flat level (10th
        // percentiles), not under the file's.
        let fa = (s / hop).min(nfr - 1);
        let fb = (end / hop).max(fa + 1).min(nfr);
        let mut ev: Vec<f64> = e[fa..fb].to_vec();
        let mut nv: Vec<f64> = nu[fa..fb].to_vec();
        ev.sort_by(f64::total_cmp);
        nv.sort_by(f64::total_cmp);
        // ... and never above the floor just before the onset: a segment that rings to its
        // end (a trimmed file, one cut at the next tap) would otherwise measure its ring.
        let local = ev[ev.len() / 10].min(nv[nv.len() / 10]).min(pre.max(noise)).max(noise);
        let seg = Segment { start: s, end, snr_db: 10.0 * (snr / local).log10(), noise_var: local };
        if end - s < min_len {
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
    // Only restrikes inside an analysed impact, before its end (so never a strike that became
    // an onset of its own right after the gap, nor one in a skipped segment or in the
    // precursor of a later strike).
    restrikes.retain(|&(r, o)| out.impacts.iter().any(|i| i.start == o && r < i.end));
    // Strikes the onsets and the gap's rules did not see, inside each analysed impact.
    let known: Vec<usize> = onsets.iter().map(|o| o.0).chain(restrikes.iter().map(|r| r.0)).collect();
    for imp in &out.impacts {
        for s in strikes_within(&mut predictor, &e, imp.start, imp.end, &known) {
            restrikes.push((s, imp.start));
        }
    }
    restrikes.sort_unstable();
    // Where the spectrum rose: a strike re-excites each partial with its own phase against
    // the ring, so some rise even when the sum loses energy (module docs: antiphase); a
    // component that stops only takes away.
    let span = RESTRIKE_SPECTRUM_FRAMES;
    let mut before = vec![0.0; nb];
    let mut after = vec![0.0; nb];
    for &(r, o) in &restrikes {
        let j = r / hop;
        if j < span + 2 || j + 1 + span > nfr {
            continue;
        }
        // Bins at the floor rise 3 dB by chance (a sum of four frames, 15–20 % of them): a
        // bin counts only well over the impact's floor (σ² per bin and frame).
        let floor = out.impacts.iter().find(|i| i.start == o).map_or(noise, |i| i.noise_var);
        let floor = RESTRIKE_BIN_OVER_FLOOR * span as f64 * floor;
        before.iter_mut().for_each(|v| *v = 0.0);
        after.iter_mut().for_each(|v| *v = 0.0);
        for k in 0..span {
            spec.power(j - 2 - k, &mut p);
            before.iter_mut().zip(&p).for_each(|(b, v)| *b += v);
            spec.power(j + 1 + k, &mut p);
            after.iter_mut().zip(&p).for_each(|(a, v)| *a += v);
        }
        let total: f64 = after.iter().sum();
        let rose: f64 = after
            .iter()
            .zip(&before)
            .filter(|(a, b)| **a >= RESTRIKE_BIN_RISE * **b && **a >= floor)
            .map(|(a, _)| a)
            .sum();
        if rose >= RESTRIKE_RISE_SHARE * total && total > 0.0 {
            out.cuts.push(r);
        }
    }
    // A cut within `SAME_STRIKE_S` of its impact's onset, louder than anything before it,
    // after a sound that rose and never decayed (`rose_and_held`: no struck ring) is that
    // sound's strike: the impact starts there, the sound is its precursor (FluidR3's music
    // box at key 73: the pin presses the tooth, rising 13 dB over 35 ms and holding to the
    // release 62 ms in, which is only 1.4 dB over it but 35 dB up above 6 kHz).
    // (The swell up to the frame before the one holding the cut's first samples, as the
    // spectra's "before".)
    let min_len = (opts.min_impact_s * fs) as usize;
    let mut too_short = Vec::new();
    for (ii, imp) in out.impacts.iter_mut().enumerate() {
        let Some(ci) = out.cuts.iter().position(|&r| r > imp.start && r < imp.end) else { continue };
        let r = out.cuts[ci];
        let (j0, j) = (imp.start / hop, r / hop);
        let upto = j - 1;
        let e_on = e[j..(j + 4).min(nfr)].iter().fold(0.0f64, |m, &v| m.max(v));
        let pre_peak = e[j0..upto.max(j0 + 1)].iter().fold(0.0f64, |m, &v| m.max(v));
        if j < j0 + same_strike
            && upto >= j0 + 2 * PRECURSOR_MIN_FRAMES
            && e_on > pre_peak
            && rose_and_held(&e, j0, upto)
        {
            out.skipped.push((
                Segment { start: imp.start, end: r, ..*imp },
                format!(
                    "{PRECURSOR} of the strike at {:.3} s ({:.0} dB quieter): taken as part of it",
                    r as f64 / fs,
                    10.0 * (e_on / pre_peak.max(1e-300)).log10()
                ),
            ));
            out.cuts.remove(ci);
            // Strikes reported in the swell are part of it; later ones are now the strike's.
            move_start(imp, r, &mut restrikes);
            if imp.end - r < min_len {
                too_short.push(ii);
            }
        }
    }
    skip_impacts(&mut out, &mut restrikes, &too_short, fs, |ms| {
        format!("too short ({ms:.0} ms); leave more time between taps")
    });
    // A gradual attack of the file's first sound (a fade-in at the start of a trimmed file, a
    // sound that swells in) is left out of the analysis, which starts where the damped
    // sinusoids' model holds (`attack_end`), before the first strike reported inside the
    // impact. The first sound: the first impact, within `FADE_MAX_S` of the file's start,
    // with nothing before it but its precursors.
    let head = (FADE_MAX_S * fs) as usize;
    let first_sound = out.impacts.first().is_some_and(|i| {
        i.start < head && out.skipped.iter().all(|(k, why)| k.start >= i.start || (is_precursor(why) && k.start < head))
    });
    let mut all_attack = false;
    if let Some(imp) = out.impacts.first_mut().filter(|_| first_sound) {
        // Up to its first strike inside: a louder one is not the first sound's peak.
        let until = restrikes.iter().filter(|r| r.1 == imp.start).map(|r| r.0).fold(imp.end, usize::min);
        if let Some(to) = attack_end(x, fs, until).filter(|&to| to > imp.start && to < until) {
            // The strikes inside (all after `to`) count from the analysis' start
            // (`Segmentation::attacks` maps it back to the onset for what is said of them).
            let onset = imp.start;
            move_start(imp, to, &mut restrikes);
            all_attack = imp.end - to < min_len;
            if !all_attack {
                out.attacks.push((onset, to));
            }
        }
    }
    if all_attack {
        skip_impacts(&mut out, &mut restrikes, &[0], fs, |ms| {
            format!("too short after its gradual attack ({ms:.0} ms left)")
        });
    }
    // A ring that falls away faster than it rang, to its end (an editor's fade-out, a gate, a
    // hand damping the object) is analysed up to where that began (`fade_out_start`): over
    // the fade the partials' amplitudes follow its shape, which no damped sinusoid does.
    let fade_min = (FADE_OUT_MIN_S * fs / hop as f64).round() as usize;
    let back_after = (FADE_OUT_COMEBACK_S * fs) as usize;
    for imp in &mut out.impacts {
        // The frames wholly inside the impact, after the last cut inside it (a bounce's ring
        // is a new level, not the line the first strike's ring followed; a strike reported
        // where the ring only fell may be the fade's own start).
        let from =
            out.cuts.iter().filter(|&&c| c > imp.start && c < imp.end).map(|&c| c + frame).fold(imp.start, usize::max);
        let (ja, jb) = (from.div_ceil(hop), ((imp.end.saturating_sub(frame)) / hop + 1).min(nfr));
        let Some(jf) = fade_out_start(&e, noise, ja, jb, fade_min) else { continue };
        // A ring that comes back after the impact ended in the floor had only beaten to a null
        // there: the frames from its end up to `FADE_OUT_COMEBACK_S` on, wholly before the next
        // strike's first samples (a frame before its onset sample).
        let next = onsets.iter().map(|o| o.0).find(|&o| o > imp.start).unwrap_or(x.len());
        let until = next.saturating_sub(frame).min(imp.end + back_after).min(x.len());
        let (ka, kb) = (jb, (until.saturating_sub(frame) / hop + 1).min(nfr));
        let end_e = e[jb.saturating_sub(2).max(ja)..jb].iter().fold(0.0f64, |m, &v| m.max(v)).max(noise);
        if until > imp.end && ka < kb && e[ka..kb].iter().any(|&v| v > FADE_OUT_COMEBACK * end_e) {
            continue;
        }
        // Kept: a share of the impact, and the minimum impact after the last cut inside it
        // (a bounce's part is not left too short by the fade).
        let fall = jf * hop;
        let keep =
            (imp.start + ((FADE_OUT_KEEP * (imp.end - imp.start) as f64) as usize).max(min_len)).max(from + min_len);
        let to = fall.saturating_sub((FADE_OUT_MARGIN * imp.end.saturating_sub(fall) as f64) as usize).max(keep);
        if to < imp.end {
            out.fades.push((imp.start, fall, to));
            restrikes.retain(|&(r, o)| o != imp.start || r < to);
            out.cuts.retain(|&c| !(c >= to && c < imp.end));
            imp.end = to;
        }
    }
    out.restrikes = restrikes;
    out
}
