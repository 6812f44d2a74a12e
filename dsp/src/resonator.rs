//! A bank of exact (impulse-invariant) damped complex one-pole resonators.
//!
//! Each mode is a complex state `y` with pole `p = e^{(−d + iω)/fs}`; per sample
//! `y ← p·(y + b·x)` and the mode's output is `Im(y)`. An impulse of height `A` added to `y`
//! rings as `A·e^{−d t}·sin(ω t)`, exactly the damped sinusoid of SCIENCE.md §1, so frequency
//! and decay are exact up to `f32` rounding of the pole.
//!
//! Layout is structure-of-arrays padded to [`LANES`]; the kernel is time-blocked: groups of
//! up to [`GROUP`] modes are held in registers while it loops over a block's samples (as
//! Mutable Instruments Plaits does with batches of 4), and each sample's sum is accumulated
//! lane-wise and reduced once per block. An AVX2/FMA kernel is chosen at run time; the
//! portable kernel computes the same operations in the same order, so both give the same
//! output up to FMA rounding.

/// SIMD width in `f32` lanes; arrays are padded to a multiple of it.
pub const LANES: usize = 8;
/// Modes held in registers at once by the time-blocked kernel (4 AVX vectors).
pub const GROUP: usize = 4 * LANES;
/// Longest block the kernel processes at once (the accumulator buffer's length).
pub const MAX_KERNEL_BLOCK: usize = 64;

/// Coefficients of one mode, computed at control rate.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ModeCoeffs {
    /// Real part of the pole.
    pub pr: f32,
    /// Imaginary part of the pole.
    pub pi: f32,
}

impl ModeCoeffs {
    /// The pole of a mode with decay rate `d` (s⁻¹) and damped angular frequency `omega_d`
    /// (rad/s) at `sample_rate` (Hz).
    #[inline]
    pub fn new(d: f64, omega_d: f64, sample_rate: f64) -> Self {
        let r = (-d / sample_rate).exp();
        let (s, c) = (omega_d / sample_rate).sin_cos();
        ModeCoeffs { pr: (r * c) as f32, pi: (r * s) as f32 }
    }
}

/// State and coefficients of up to `capacity` modes.
#[derive(Clone, Debug)]
pub struct ResonatorBank {
    re: Vec<f32>,
    im: Vec<f32>,
    pr: Vec<f32>,
    pi: Vec<f32>,
    len: usize,
    /// Forcing coefficients of each mode (see [`process_forced`](Self::process_forced)):
    /// complex weights of the two pulse signals and the real weight of the noise signal.
    fpr: Vec<f32>,
    fpi: Vec<f32>,
    fqr: Vec<f32>,
    fqi: Vec<f32>,
    fb: Vec<f32>,
    /// Lane-wise per-sample accumulators, `MAX_KERNEL_BLOCK × LANES`.
    acc: Vec<f32>,
    /// Use the AVX2/FMA kernel: decided in [`new`](Self::new), so the audio thread never runs
    /// the CPU and environment checks.
    avx2: bool,
}

impl ResonatorBank {
    /// Reserves room for `capacity` modes. Allocates.
    pub fn new(capacity: usize) -> Self {
        let padded = capacity.div_ceil(LANES).max(1) * LANES;
        ResonatorBank {
            re: vec![0.0; padded],
            im: vec![0.0; padded],
            pr: vec![0.0; padded],
            pi: vec![0.0; padded],
            len: 0,
            fpr: vec![0.0; padded],
            fpi: vec![0.0; padded],
            fqr: vec![0.0; padded],
            fqi: vec![0.0; padded],
            fb: vec![0.0; padded],
            acc: vec![0.0; MAX_KERNEL_BLOCK * LANES],
            avx2: avx2_available(),
        }
    }

    /// Whether this bank runs the AVX2/FMA kernel (else the portable one).
    pub fn uses_avx2(&self) -> bool {
        self.avx2
    }

    /// Chooses the kernel: `true` for AVX2/FMA, honoured only where the CPU has them; `false`
    /// for the portable kernel (tests compare the two). Realtime-safe.
    pub fn set_avx2(&mut self, on: bool) {
        self.avx2 = on && avx2_available();
    }

    /// Maximum number of modes.
    pub fn capacity(&self) -> usize {
        self.re.len()
    }

    /// Number of modes in use.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Number of [`LANES`]-mode vectors the kernels advance (the modes rounded up).
    pub fn vectors(&self) -> usize {
        self.len.div_ceil(LANES)
    }

    /// [`process_lanes`](Self::process_lanes) for the first `count` vectors only (a multiple
    /// of [`BATCH_VECTORS`] in the engine: whole kernel groups, run in place; the rest go
    /// through a [`VectorBatch`]).
    pub fn process_first_vectors_lanes(&mut self, count: usize, lanes: &mut [f32]) {
        let n = (lanes.len() / LANES).min(MAX_KERNEL_BLOCK);
        let m = (count * LANES).min(self.len.div_ceil(LANES) * LANES);
        if m == 0 || n == 0 {
            return;
        }
        let (re, im, pr, pi) = (&mut self.re[..m], &mut self.im[..m], &self.pr[..m], &self.pi[..m]);
        run_free(self.avx2, [re, im], [pr, pi], &mut lanes[..n * LANES], n);
    }

    /// Sets the state of the slots from `first` on (what a [`VectorBatch`] hands back).
    pub fn store_modes(&mut self, first: usize, re: &[f32], im: &[f32]) {
        let c = re.len().min(im.len());
        let (dr, di) = (&mut self.re[first..first + c], &mut self.im[first..first + c]);
        // One loop: a few slots each (see `VectorBatch::push_modes`).
        #[allow(clippy::manual_memcpy)]
        for j in 0..c {
            dr[j] = re[j];
            di[j] = im[j];
        }
    }

    /// True when no mode is in use.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Removes every mode and zeroes the state. Realtime-safe.
    pub fn clear(&mut self) {
        self.re.fill(0.0);
        self.im.fill(0.0);
        self.pr.fill(0.0);
        self.pi.fill(0.0);
        self.clear_forcing();
        self.len = 0;
    }

    /// Zeroes every mode's forcing coefficients. Realtime-safe.
    pub fn clear_forcing(&mut self) {
        self.fpr.fill(0.0);
        self.fpi.fill(0.0);
        self.fqr.fill(0.0);
        self.fqi.fill(0.0);
        self.fb.fill(0.0);
    }

    /// Sets how slot `k` is driven by [`process_forced`](Self::process_forced): complex
    /// weights `p` and `q` of the two pulse signals and real weight `b` of the noise signal.
    #[inline]
    pub fn set_forcing(&mut self, k: usize, p: (f32, f32), q: (f32, f32), b: f32) {
        self.fpr[k] = p.0;
        self.fpi[k] = p.1;
        self.fqr[k] = q.0;
        self.fqi[k] = q.1;
        self.fb[k] = b;
    }

    /// Sets the complex weights `p` and `q` of slot `k`'s two pulse signals, keeping its noise
    /// weight (a lasting contact uses them for its interpolated gains).
    #[inline]
    pub fn set_pulse_forcing(&mut self, k: usize, p: (f32, f32), q: (f32, f32)) {
        self.fpr[k] = p.0;
        self.fpi[k] = p.1;
        self.fqr[k] = q.0;
        self.fqi[k] = q.1;
    }

    /// Adds the complex value `re + i·im` to slot `k`'s state (an exact correction of the
    /// state at a sample boundary).
    #[inline]
    pub fn excite_complex(&mut self, k: usize, re: f32, im: f32) {
        self.re[k] += re;
        self.im[k] += im;
    }

    /// The complex state of slot `k`.
    #[inline]
    pub fn state(&self, k: usize) -> (f32, f32) {
        (self.re[k], self.im[k])
    }

    /// Sets the complex state of slot `k`.
    #[inline]
    pub fn set_state(&mut self, k: usize, re: f32, im: f32) {
        self.re[k] = re;
        self.im[k] = im;
    }

    /// The complex pole of slot `k`.
    #[inline]
    pub fn pole(&self, k: usize) -> (f32, f32) {
        (self.pr[k], self.pi[k])
    }

    /// Appends a mode at rest and returns its slot, or `None` when full. Realtime-safe.
    pub fn push(&mut self, coeffs: ModeCoeffs) -> Option<usize> {
        if self.len >= self.re.len() {
            return None;
        }
        let k = self.len;
        self.pr[k] = coeffs.pr;
        self.pi[k] = coeffs.pi;
        self.re[k] = 0.0;
        self.im[k] = 0.0;
        self.len += 1;
        Some(k)
    }

    /// Replaces the coefficients of slot `k` (state is kept, so a ringing mode glides).
    #[inline]
    pub fn set_coeffs(&mut self, k: usize, coeffs: ModeCoeffs) {
        self.pr[k] = coeffs.pr;
        self.pi[k] = coeffs.pi;
    }

    /// Adds a real impulse of height `a` to slot `k` (a strike): the mode then rings as
    /// `a·e^{−d t}·sin(ω t)` on top of whatever it was doing.
    #[inline]
    pub fn excite(&mut self, k: usize, a: f32) {
        self.re[k] += a;
    }

    /// Sum of |y|² over all modes: an upper bound of the squared output amplitude's scale,
    /// used to end silent voices.
    pub fn energy(&self) -> f32 {
        self.energy_first(self.len)
    }

    /// Sum of |y|² over the first `count` slots, in slot order: the start of
    /// [`energy`](Self::energy)'s sum, which [`add_energy`] over the next slots' states
    /// continues bit for bit.
    pub fn energy_first(&self, count: usize) -> f32 {
        let n = count.min(self.len);
        add_energy(0.0, &self.re[..n], &self.im[..n])
    }

    /// Advances every mode by `out.len()` samples (at most [`MAX_KERNEL_BLOCK`]) with no
    /// input and adds the summed output into `out`. Realtime-safe.
    pub fn process(&mut self, out: &mut [f32]) {
        self.run(None, out);
    }

    /// Like [`process`](Self::process) but drives mode `k` with `drive[k]·x[n]`
    /// (`drive` has at least `len()` entries).
    pub fn process_driven(&mut self, x: &[f32], drive: &[f32], out: &mut [f32]) {
        debug_assert!(x.len() >= out.len() && drive.len() >= self.len);
        self.run(Some((x, drive)), out);
    }

    /// Advances every mode by `out.len()` samples (at most [`MAX_KERNEL_BLOCK`]) driven by
    /// three signals and adds the summed output into `out`. Per sample, before the advance
    /// (like [`excite`](Self::excite)): `y += P·u[0][n] + Q·u[1][n] + b·u[2][n]` with each
    /// mode's complex P, Q and real b from [`set_forcing`](Self::set_forcing). The engine's
    /// force pulse, noise burst and lasting contacts. The AVX2/FMA kernel when the bank uses
    /// it, else the portable one: the same operations in the same order, equal up to FMA
    /// rounding. Realtime-safe.
    pub fn process_forced(&mut self, u: [&[f32]; 3], out: &mut [f32]) {
        let n = out.len().min(MAX_KERNEL_BLOCK);
        if self.len == 0 || n == 0 {
            return;
        }
        let mut acc = std::mem::take(&mut self.acc);
        acc[..n * LANES].fill(0.0);
        self.process_forced_lanes(u, &mut acc[..n * LANES]);
        reduce_lanes(&acc[..n * LANES], &mut out[..n]);
        self.acc = acc;
    }

    /// [`process_forced`](Self::process_forced) adding each sample's eight lane sums into
    /// `lanes` (n × [`LANES`] floats) instead of their total into an output: see
    /// [`process_lanes`](Self::process_lanes). Realtime-safe.
    pub fn process_forced_lanes(&mut self, u: [&[f32]; 3], lanes: &mut [f32]) {
        let n = (lanes.len() / LANES).min(MAX_KERNEL_BLOCK);
        if self.len == 0 || n == 0 {
            return;
        }
        let padded = self.len.div_ceil(LANES) * LANES;
        #[cfg(target_arch = "x86_64")]
        {
            if self.avx2 {
                // SAFETY: AVX2 and FMA were detected at run time; every array holds `padded`
                // modes, the signals n samples and `lanes` n × LANES floats.
                unsafe {
                    avx2::run_forced(
                        (&mut self.re[..padded], &mut self.im[..padded]),
                        (&self.pr[..padded], &self.pi[..padded]),
                        [
                            &self.fpr[..padded],
                            &self.fpi[..padded],
                            &self.fqr[..padded],
                            &self.fqi[..padded],
                            &self.fb[..padded],
                        ],
                        [&u[0][..n], &u[1][..n], &u[2][..n]],
                        &mut lanes[..n * LANES],
                    )
                };
                return;
            }
        }
        portable::run_forced(
            (&mut self.re[..padded], &mut self.im[..padded]),
            (&self.pr[..padded], &self.pi[..padded]),
            [&self.fpr[..padded], &self.fpi[..padded], &self.fqr[..padded], &self.fqi[..padded], &self.fb[..padded]],
            [&u[0][..n], &u[1][..n], &u[2][..n]],
            &mut lanes[..n * LANES],
        );
    }

    /// [`process`](Self::process) adding each sample's eight lane sums into `lanes`
    /// (n × [`LANES`] floats for n ≤ [`MAX_KERNEL_BLOCK`] samples) instead of their total
    /// into an output. The engine lets every voice add into one accumulator and sums its
    /// lanes once per block ([`reduce_lanes`]): a voice of a few modes then costs its modes,
    /// not a block of clearing and summing. Realtime-safe.
    pub fn process_lanes(&mut self, lanes: &mut [f32]) {
        let n = (lanes.len() / LANES).min(MAX_KERNEL_BLOCK);
        if self.len == 0 || n == 0 {
            return;
        }
        self.run_lanes(None, &mut lanes[..n * LANES], n);
    }

    fn run(&mut self, input: Option<(&[f32], &[f32])>, out: &mut [f32]) {
        let n = out.len().min(MAX_KERNEL_BLOCK);
        if self.len == 0 || n == 0 {
            return;
        }
        let mut acc = std::mem::take(&mut self.acc);
        acc[..n * LANES].fill(0.0);
        self.run_lanes(input, &mut acc[..n * LANES], n);
        reduce_lanes(&acc[..n * LANES], &mut out[..n]);
        self.acc = acc;
    }

    /// Advances every mode by `n` samples, adding each sample's lane sums into `acc`.
    fn run_lanes(&mut self, input: Option<(&[f32], &[f32])>, acc: &mut [f32], n: usize) {
        let padded = self.len.div_ceil(LANES) * LANES;
        #[cfg(target_arch = "x86_64")]
        {
            if self.avx2 {
                // SAFETY: AVX2 and FMA were detected at run time; all slices hold `padded`
                // modes (capacity is a multiple of LANES) and `acc` holds n × LANES floats.
                unsafe {
                    avx2::run(
                        &mut self.re[..padded],
                        &mut self.im[..padded],
                        &self.pr[..padded],
                        &self.pi[..padded],
                        input.map(|(x, d)| (&x[..n], &d[..padded.min(d.len())])),
                        acc,
                        n,
                    )
                };
                return;
            }
        }
        portable::run(
            &mut self.re[..padded],
            &mut self.im[..padded],
            &self.pr[..padded],
            &self.pi[..padded],
            input.map(|(x, d)| (&x[..n], d)),
            acc,
            n,
        );
    }
}

/// Modes of several banks advanced together: up to [`BATCH_LANES`] free-running modes,
/// whatever bank they come from, packed lane by lane into full kernel groups, so that voices
/// of a few modes fill the kernel's lanes and its independent chains instead of each running
/// a part-empty vector alone (a single vector's recurrence is latency-bound). The batch holds
/// many groups, so that only its very last group is part-filled, and that one joins the group
/// before it when they make 5 or 6 vectors (see `avx2::run`).
///
/// Each mode's state advances exactly as in its own bank (the recurrence is per mode), so the
/// states handed back are bit for bit the bank's own. The lane a mode adds into depends on
/// the packing: whole vectors pushed at a vector boundary keep their lanes (a batch of only
/// those gives bit for bit each bank's [`ResonatorBank::process_lanes`] in turn); packed
/// ranges change which modes share a lane sum, so the output differs from the banks in turn
/// by rounding only, and is a fixed function of what was pushed in which order.
/// Realtime-safe (fixed-size arrays).
#[derive(Clone, Debug)]
pub struct VectorBatch {
    re: [f32; BATCH_LANES],
    im: [f32; BATCH_LANES],
    pr: [f32; BATCH_LANES],
    pi: [f32; BATCH_LANES],
    /// (owner, first slot in its bank, first lane in the batch, modes) of each pushed range;
    /// the owner is the caller's.
    from: [(u32, u32, u32, u32); BATCH_LANES],
    ranges: usize,
    /// Lanes filled.
    len: usize,
    avx2: bool,
}

/// Vectors of one kernel group (the AVX2 kernel's usual group size): the engine runs a
/// voice's whole groups in place and packs only the rest into a [`VectorBatch`].
pub const BATCH_VECTORS: usize = 4;
/// Modes a [`VectorBatch`] holds (8 kernel groups).
pub const BATCH_LANES: usize = 8 * BATCH_VECTORS * LANES;

impl VectorBatch {
    /// An empty batch run by the AVX2 kernel if `avx2` and the CPU has AVX2 and FMA
    /// ([`avx2_available`], cached after [`ResonatorBank::new`]'s first call).
    pub fn new(avx2: bool) -> Self {
        let z = [0.0; BATCH_LANES];
        let avx2 = avx2 && avx2_available();
        let from = [(0, 0, 0, 0); BATCH_LANES];
        VectorBatch { re: z, im: z, pr: z, pi: z, from, ranges: 0, len: 0, avx2 }
    }

    /// Whether the batch is full (run it).
    pub fn is_full(&self) -> bool {
        self.len == BATCH_LANES
    }

    /// Adds vector `k` of `bank` (state and pole of its [`LANES`] slots), remembering `owner`,
    /// at the next free lanes; returns how many were taken (fewer than [`LANES`] only when
    /// the batch had less room: see [`push_modes`](Self::push_modes)). Tests push whole
    /// vectors; the engine pushes ranges ([`BatchSet::push_modes`]).
    #[cfg(test)]
    pub fn push(&mut self, owner: usize, bank: &ResonatorBank, k: usize) -> usize {
        self.push_modes(owner, bank, k * LANES, LANES)
    }

    /// Adds slots `first..first + count` of `bank` (state and pole) at the next free lanes,
    /// as many as there is room for; returns how many were taken (run the batch when it is
    /// full, then push the rest).
    pub fn push_modes(&mut self, owner: usize, bank: &ResonatorBank, first: usize, count: usize) -> usize {
        let c = count.min(BATCH_LANES - self.len).min(bank.capacity().saturating_sub(first));
        if c == 0 {
            return 0;
        }
        let (o, d) = (first, self.len);
        // One loop over the four arrays: a few lanes each, where library copies cost more
        // than the copying.
        let src = (&bank.re[o..o + c], &bank.im[o..o + c], &bank.pr[o..o + c], &bank.pi[o..o + c]);
        let (re, im) = (&mut self.re[d..d + c], &mut self.im[d..d + c]);
        let (pr, pi) = (&mut self.pr[d..d + c], &mut self.pi[d..d + c]);
        #[allow(clippy::manual_memcpy)]
        for j in 0..c {
            re[j] = src.0[j];
            im[j] = src.1[j];
            pr[j] = src.2[j];
            pi[j] = src.3[j];
        }
        // Lossless: the batch holds BATCH_LANES (< 2³²) modes; owners are voice indices.
        self.from[self.ranges] = (owner as u32, first as u32, d as u32, c as u32);
        self.ranges += 1;
        self.len += c;
        c
    }

    /// Advances the pushed modes by `acc.len() / LANES` samples (at most
    /// [`MAX_KERNEL_BLOCK`]) adding into the lane accumulator `acc`, then hands each pushed
    /// range's new state back through `store(owner, first, re, im)` and empties the batch
    /// (tests; the engine keeps the modes: [`advance`](Self::advance)).
    #[cfg(test)]
    pub fn run(&mut self, acc: &mut [f32], mut store: impl FnMut(usize, usize, &[f32], &[f32])) {
        self.advance(acc);
        for (owner, first, re, im) in self.ranges() {
            store(owner, first, re, im);
        }
        self.clear();
    }

    /// Advances the pushed modes by `acc.len() / LANES` samples (at most
    /// [`MAX_KERNEL_BLOCK`]) adding into the lane accumulator `acc`; the batch keeps them
    /// (their states are then [`ranges`](Self::ranges)', not their banks').
    pub fn advance(&mut self, acc: &mut [f32]) {
        let n = (acc.len() / LANES).min(MAX_KERNEL_BLOCK);
        let m = self.len.div_ceil(LANES) * LANES;
        if m == 0 || n == 0 {
            return;
        }
        // The lanes after the last range run silent: zero state and pole add +0.
        for a in [&mut self.re, &mut self.im, &mut self.pr, &mut self.pi] {
            a[self.len..m].fill(0.0);
        }
        let (re, im, pr, pi) = (&mut self.re[..m], &mut self.im[..m], &self.pr[..m], &self.pi[..m]);
        run_free(self.avx2, [re, im], [pr, pi], &mut acc[..n * LANES], n);
    }

    /// Each pushed range in push order: (owner, first slot in its bank, state re, state im).
    pub fn ranges(&self) -> impl Iterator<Item = (usize, usize, &[f32], &[f32])> + '_ {
        self.from[..self.ranges].iter().map(|&(owner, first, d, c)| {
            let (d, c) = (d as usize, c as usize);
            (owner as usize, first as usize, &self.re[d..d + c], &self.im[d..d + c])
        })
    }

    /// Empties the batch (the states it held are dropped).
    pub fn clear(&mut self) {
        self.len = 0;
        self.ranges = 0;
    }
}

/// [`VectorBatch`]es filled in turn, each run at the end of a span, for a set of modes that
/// outgrows one batch; allocated once, for a fixed number of modes. The engine keeps the free
/// voices' modes here between spans (see `dsp::engine`). Realtime-safe after
/// [`new`](Self::new).
#[derive(Clone, Debug)]
pub struct BatchSet {
    batches: Vec<VectorBatch>,
    /// Batches holding modes (the last one maybe part-filled).
    used: usize,
}

impl BatchSet {
    /// Room for `modes` modes, run by the AVX2 kernel if `avx2` and the CPU has it. Allocates.
    pub fn new(modes: usize, avx2: bool) -> Self {
        let batches = (0..modes.div_ceil(BATCH_LANES).max(1)).map(|_| VectorBatch::new(avx2)).collect();
        BatchSet { batches, used: 0 }
    }

    /// Whether its batches run the AVX2 kernel.
    pub fn uses_avx2(&self) -> bool {
        self.batches[0].avx2
    }

    /// Adds slots `first..first + count` of `bank` after the modes held, filling batch after
    /// batch; returns how many were taken (fewer than `count` only when the set is full).
    pub fn push_modes(&mut self, owner: usize, bank: &ResonatorBank, first: usize, count: usize) -> usize {
        let mut taken = 0;
        while taken < count {
            if self.used == 0 || self.batches[self.used - 1].is_full() {
                if self.used == self.batches.len() {
                    break;
                }
                self.used += 1;
            }
            let c = self.batches[self.used - 1].push_modes(owner, bank, first + taken, count - taken);
            if c == 0 {
                break;
            }
            taken += c;
        }
        taken
    }

    /// Advances every held mode by `acc.len() / LANES` samples adding into `acc`, batch after
    /// batch (see [`VectorBatch::advance`]).
    pub fn advance(&mut self, acc: &mut [f32]) {
        for batch in &mut self.batches[..self.used] {
            batch.advance(acc);
        }
    }

    /// Each pushed range in push order (see [`VectorBatch::ranges`]).
    pub fn ranges(&self) -> impl Iterator<Item = (usize, usize, &[f32], &[f32])> + '_ {
        self.batches[..self.used].iter().flat_map(VectorBatch::ranges)
    }

    /// Drops every held mode.
    pub fn clear(&mut self) {
        for batch in &mut self.batches[..self.used] {
            batch.clear();
        }
        self.used = 0;
    }
}

/// The free kernel over states `y` and poles `p` (equal lengths, a multiple of [`LANES`]) for
/// `n` samples into `acc` (n × [`LANES`]): the AVX2 one when `avx2`, which callers set only
/// where [`avx2_available`] (`ResonatorBank::new`, `VectorBatch::new`).
#[inline]
fn run_free(avx2: bool, y: [&mut [f32]; 2], p: [&[f32]; 2], acc: &mut [f32], n: usize) {
    let [re, im] = y;
    let [pr, pi] = p;
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: AVX2 and FMA were detected at run time (the callers' flag); the slices hold
        // equal multiples of LANES floats and `acc` holds n × LANES (callers slice it so).
        unsafe { avx2::run(re, im, pr, pi, None, acc, n) };
        return;
    }
    let _ = avx2;
    portable::run(re, im, pr, pi, None, acc, n);
}

/// `e` plus |y|² of each mode in order (one sum for [`ResonatorBank::energy`] and its parts).
#[inline]
pub fn add_energy(mut e: f32, re: &[f32], im: &[f32]) -> f32 {
    for (r, i) in re.iter().zip(im) {
        e += r * r + i * i;
    }
    e
}

/// [`reduce_lanes`] by the AVX2 kernel (eight samples at a time, the same additions in the
/// same order: bit for bit the same sums) where `avx2` and the CPU has it. Realtime-safe.
#[inline]
pub fn reduce_lanes_with(acc: &[f32], out: &mut [f32], avx2: bool) {
    #[cfg(target_arch = "x86_64")]
    if avx2 && avx2_available() {
        // SAFETY: AVX2 was detected at run time.
        unsafe { avx2::reduce_lanes(acc, out) };
        return;
    }
    let _ = avx2;
    reduce_lanes(acc, out);
}

/// Adds the lane sums of each sample's accumulator (`acc`: [`LANES`] floats per sample) into
/// `out` (fixed order: deterministic).
#[inline]
pub fn reduce_lanes(acc: &[f32], out: &mut [f32]) {
    for (o, a) in out.iter_mut().zip(acc.chunks_exact(LANES)) {
        let s = ((a[0] + a[4]) + (a[1] + a[5])) + ((a[2] + a[6]) + (a[3] + a[7]));
        *o += s;
    }
}

/// Whether the AVX2/FMA kernel is used on this machine (cached after the first call; set
/// `STRUCK_NO_SIMD` to force the portable kernel). Reads the environment on its first call:
/// not for the audio thread ([`ResonatorBank::new`] calls it).
#[cfg(target_arch = "x86_64")]
pub fn avx2_available() -> bool {
    use std::sync::atomic::{AtomicU8, Ordering};
    static STATE: AtomicU8 = AtomicU8::new(0);
    match STATE.load(Ordering::Relaxed) {
        1 => true,
        2 => false,
        _ => {
            let ok = std::is_x86_feature_detected!("avx2")
                && std::is_x86_feature_detected!("fma")
                && std::env::var_os("STRUCK_NO_SIMD").is_none();
            STATE.store(if ok { 1 } else { 2 }, Ordering::Relaxed);
            ok
        }
    }
}

/// Whether the AVX2/FMA kernel is used on this machine.
#[cfg(not(target_arch = "x86_64"))]
pub fn avx2_available() -> bool {
    false
}

mod portable {
    use super::LANES;

    /// One group of `LANES` modes per pass over the block; the compiler vectorises the lane
    /// loops with whatever the baseline target offers.
    #[allow(clippy::needless_range_loop)] // lane loops index several arrays in lockstep
    pub fn run(
        re: &mut [f32],
        im: &mut [f32],
        pr: &[f32],
        pi: &[f32],
        input: Option<(&[f32], &[f32])>,
        acc: &mut [f32],
        n: usize,
    ) {
        for g in (0..re.len()).step_by(LANES) {
            let mut r = [0.0f32; LANES];
            let mut i = [0.0f32; LANES];
            let mut cr = [0.0f32; LANES];
            let mut ci = [0.0f32; LANES];
            let mut b = [0.0f32; LANES];
            r.copy_from_slice(&re[g..g + LANES]);
            i.copy_from_slice(&im[g..g + LANES]);
            cr.copy_from_slice(&pr[g..g + LANES]);
            ci.copy_from_slice(&pi[g..g + LANES]);
            if let Some((_, d)) = input {
                for l in 0..LANES {
                    b[l] = d.get(g + l).copied().unwrap_or(0.0);
                }
            }
            for s in 0..n {
                let xs = input.map_or(0.0, |(x, _)| x[s]);
                let a = &mut acc[s * LANES..(s + 1) * LANES];
                for l in 0..LANES {
                    // The input is added before the advance, like `excite`.
                    if input.is_some() {
                        r[l] = b[l].mul_add(xs, r[l]);
                    }
                    let nr = cr[l].mul_add(r[l], -(ci[l] * i[l]));
                    let ni = cr[l].mul_add(i[l], ci[l] * r[l]);
                    r[l] = nr;
                    i[l] = ni;
                    a[l] += ni;
                }
            }
            re[g..g + LANES].copy_from_slice(&r);
            im[g..g + LANES].copy_from_slice(&i);
        }
    }

    /// The forced kernel (see `ResonatorBank::process_forced`): `f` holds the forcing
    /// coefficients P re, P im, Q re, Q im, b; `u` the three signals of `n` samples.
    #[allow(clippy::needless_range_loop)] // lane loops index several arrays in lockstep
    pub fn run_forced(
        (re, im): (&mut [f32], &mut [f32]),
        (pr, pi): (&[f32], &[f32]),
        f: [&[f32]; 5],
        u: [&[f32]; 3],
        acc: &mut [f32],
    ) {
        let n = u[0].len();
        for g in (0..re.len()).step_by(LANES) {
            let mut r = [0.0f32; LANES];
            let mut i = [0.0f32; LANES];
            let mut cr = [0.0f32; LANES];
            let mut ci = [0.0f32; LANES];
            let mut c = [[0.0f32; LANES]; 5];
            r.copy_from_slice(&re[g..g + LANES]);
            i.copy_from_slice(&im[g..g + LANES]);
            cr.copy_from_slice(&pr[g..g + LANES]);
            ci.copy_from_slice(&pi[g..g + LANES]);
            for (cj, fj) in c.iter_mut().zip(&f) {
                cj.copy_from_slice(&fj[g..g + LANES]);
            }
            for s in 0..n {
                let (u0, u1, u2) = (u[0][s], u[1][s], u[2][s]);
                let a = &mut acc[s * LANES..(s + 1) * LANES];
                for l in 0..LANES {
                    // Plain products (no mul_add): without the FMA target feature, mul_add
                    // is a library call, and this kernel runs on every CPU.
                    let xr = c[0][l] * u0 + c[2][l] * u1 + c[4][l] * u2;
                    let xi = c[1][l] * u0 + c[3][l] * u1;
                    let (yr, yi) = (r[l] + xr, i[l] + xi);
                    let nr = cr[l] * yr - ci[l] * yi;
                    let ni = cr[l] * yi + ci[l] * yr;
                    r[l] = nr;
                    i[l] = ni;
                    a[l] += ni;
                }
            }
            re[g..g + LANES].copy_from_slice(&r);
            im[g..g + LANES].copy_from_slice(&i);
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{GROUP, LANES};
    use std::arch::x86_64::*;

    /// [`super::reduce_lanes`] eight samples at a time: each sample's halves added (lane k +
    /// lane k + 4), then neighbours twice by horizontal adds, so every sum is
    /// ((a0 + a4) + (a1 + a5)) + ((a2 + a6) + (a3 + a7)) as in the portable loop.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn reduce_lanes(acc: &[f32], out: &mut [f32]) {
        let n = out.len().min(acc.len() / LANES);
        let mut s = 0;
        // SAFETY (whole body): every load reads acc[(s + k)·LANES..][..LANES] with s + 8 ≤ n,
        // every store out[s..s + 8].
        unsafe {
            let order = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
            while s + 8 <= n {
                let p = acc.as_ptr().add(s * LANES);
                let row = |k: usize| _mm256_loadu_ps(p.add(k * LANES));
                // Two samples' (a0 + a4, a1 + a5, a2 + a6, a3 + a7), one per 128-bit half.
                let halves = |a: __m256, b: __m256| {
                    _mm256_add_ps(_mm256_permute2f128_ps::<0x20>(a, b), _mm256_permute2f128_ps::<0x31>(a, b))
                };
                let (b01, b23) = (halves(row(0), row(1)), halves(row(2), row(3)));
                let (b45, b67) = (halves(row(4), row(5)), halves(row(6), row(7)));
                // Sums of samples 0, 2, 4, 6 in the low half, 1, 3, 5, 7 in the high half.
                let h = _mm256_hadd_ps(_mm256_hadd_ps(b01, b23), _mm256_hadd_ps(b45, b67));
                let sums = _mm256_permutevar8x32_ps(h, order);
                let o = out.as_mut_ptr().add(s);
                _mm256_storeu_ps(o, _mm256_add_ps(_mm256_loadu_ps(o), sums));
                s += 8;
            }
        }
        super::reduce_lanes(&acc[s * LANES..], &mut out[s..]);
    }

    /// Time-blocked AVX2/FMA kernel: up to 4 vectors (32 modes) of state stay in registers
    /// across the block's samples; the pole coefficients are memory operands.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA. `re`, `im`, `pr`, `pi` have equal length, a multiple
    /// of `LANES`; `acc` holds `n × LANES` floats; `input.0` holds `n` samples.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn run(
        re: &mut [f32],
        im: &mut [f32],
        pr: &[f32],
        pi: &[f32],
        input: Option<(&[f32], &[f32])>,
        acc: &mut [f32],
        n: usize,
    ) {
        let len = re.len();
        let mut g = 0;
        while g < len {
            let left = (len - g) / LANES;
            // A last group of 1 or 2 vectors is latency-bound (each sample waits for the
            // previous one's multiply and FMA: as long as a whole group's throughput), so the
            // last 5 or 6 vectors run as one wider group instead of 4 + 1 or 4 + 2. Each lane
            // sum still adds the vectors in the same order: bit for bit the same output.
            let vecs = if input.is_none() && (left == 5 || left == 6) { left } else { left.min(GROUP / LANES) };
            // SAFETY: all indices below stay inside the slices (checked by the loop bounds).
            unsafe {
                match vecs {
                    6 => wide_group::<6>(re, im, pr, pi, acc, n, g),
                    5 => wide_group::<5>(re, im, pr, pi, acc, n, g),
                    4 => group::<4>(re, im, pr, pi, input, acc, n, g),
                    3 => group::<3>(re, im, pr, pi, input, acc, n, g),
                    2 => group::<2>(re, im, pr, pi, input, acc, n, g),
                    _ => group::<1>(re, im, pr, pi, input, acc, n, g),
                }
            }
            g += vecs * LANES;
        }
    }

    /// [`group`] without input for 5 or 6 vectors: the states stay in registers, the poles
    /// are memory operands (16 registers hold no more), the operations and their order are
    /// [`group`]'s.
    ///
    /// # Safety
    /// As [`group`].
    #[target_feature(enable = "avx2,fma")]
    #[allow(clippy::needless_range_loop)]
    unsafe fn wide_group<const V: usize>(
        re: &mut [f32],
        im: &mut [f32],
        pr: &[f32],
        pi: &[f32],
        acc: &mut [f32],
        n: usize,
        g: usize,
    ) {
        // SAFETY (whole body): the caller guarantees g + V·LANES ≤ len and acc ≥ n·LANES.
        unsafe {
            let mut r = [_mm256_setzero_ps(); V];
            let mut i = [_mm256_setzero_ps(); V];
            for v in 0..V {
                let o = g + v * LANES;
                r[v] = _mm256_loadu_ps(re.as_ptr().add(o));
                i[v] = _mm256_loadu_ps(im.as_ptr().add(o));
            }
            let (prp, pip) = (pr.as_ptr().add(g), pi.as_ptr().add(g));
            let accp = acc.as_mut_ptr();
            for s in 0..n {
                let ap = accp.add(s * LANES);
                let mut a = _mm256_loadu_ps(ap);
                for v in 0..V {
                    let cr = _mm256_loadu_ps(prp.add(v * LANES));
                    let ci = _mm256_loadu_ps(pip.add(v * LANES));
                    let nr = _mm256_fmsub_ps(cr, r[v], _mm256_mul_ps(ci, i[v]));
                    let ni = _mm256_fmadd_ps(cr, i[v], _mm256_mul_ps(ci, r[v]));
                    r[v] = nr;
                    i[v] = ni;
                    a = _mm256_add_ps(a, ni);
                }
                _mm256_storeu_ps(ap, a);
            }
            for v in 0..V {
                let o = g + v * LANES;
                _mm256_storeu_ps(re.as_mut_ptr().add(o), r[v]);
                _mm256_storeu_ps(im.as_mut_ptr().add(o), i[v]);
            }
        }
    }

    /// The forced kernel (see `ResonatorBank::process_forced`), time-blocked like [`run`]:
    /// up to 4 vectors of state in registers across the samples, the forcing coefficients
    /// (`f`: P re, P im, Q re, Q im, b) and poles as memory operands. The portable kernel's
    /// operations in its order, with FMA.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA. Every state, pole and coefficient slice has the same
    /// length, a multiple of `LANES`; the three signals have n samples; `acc` n × `LANES`.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn run_forced(
        (re, im): (&mut [f32], &mut [f32]),
        (pr, pi): (&[f32], &[f32]),
        f: [&[f32]; 5],
        u: [&[f32]; 3],
        acc: &mut [f32],
    ) {
        let len = re.len();
        let mut g = 0;
        while g < len {
            let vecs = ((len - g) / LANES).min(GROUP / LANES);
            // SAFETY: all indices below stay inside the slices (checked by the loop bounds).
            unsafe {
                match vecs {
                    4 => forced_group::<4>((re, im), (pr, pi), f, u, acc, g),
                    3 => forced_group::<3>((re, im), (pr, pi), f, u, acc, g),
                    2 => forced_group::<2>((re, im), (pr, pi), f, u, acc, g),
                    _ => forced_group::<1>((re, im), (pr, pi), f, u, acc, g),
                }
            }
            g += vecs * LANES;
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[allow(clippy::needless_range_loop)]
    unsafe fn forced_group<const V: usize>(
        (re, im): (&mut [f32], &mut [f32]),
        (pr, pi): (&[f32], &[f32]),
        f: [&[f32]; 5],
        u: [&[f32]; 3],
        acc: &mut [f32],
        g: usize,
    ) {
        // SAFETY (whole body): the caller guarantees g + V·LANES ≤ len, equal lengths and
        // acc ≥ n·LANES.
        unsafe {
            let n = u[0].len();
            let mut r = [_mm256_setzero_ps(); V];
            let mut i = [_mm256_setzero_ps(); V];
            for v in 0..V {
                let o = g + v * LANES;
                r[v] = _mm256_loadu_ps(re.as_ptr().add(o));
                i[v] = _mm256_loadu_ps(im.as_ptr().add(o));
            }
            let ld = |x: &[f32], v: usize| _mm256_loadu_ps(x.as_ptr().add(g + v * LANES));
            let accp = acc.as_mut_ptr();
            for s in 0..n {
                let u0 = _mm256_set1_ps(*u[0].get_unchecked(s));
                let u1 = _mm256_set1_ps(*u[1].get_unchecked(s));
                let u2 = _mm256_set1_ps(*u[2].get_unchecked(s));
                let ap = accp.add(s * LANES);
                let mut a = _mm256_loadu_ps(ap);
                for v in 0..V {
                    let xr = _mm256_fmadd_ps(
                        ld(f[4], v),
                        u2,
                        _mm256_fmadd_ps(ld(f[2], v), u1, _mm256_mul_ps(ld(f[0], v), u0)),
                    );
                    let xi = _mm256_fmadd_ps(ld(f[3], v), u1, _mm256_mul_ps(ld(f[1], v), u0));
                    let (yr, yi) = (_mm256_add_ps(r[v], xr), _mm256_add_ps(i[v], xi));
                    let (cr, ci) = (ld(pr, v), ld(pi, v));
                    let nr = _mm256_fmsub_ps(cr, yr, _mm256_mul_ps(ci, yi));
                    let ni = _mm256_fmadd_ps(cr, yi, _mm256_mul_ps(ci, yr));
                    r[v] = nr;
                    i[v] = ni;
                    a = _mm256_add_ps(a, ni);
                }
                _mm256_storeu_ps(ap, a);
            }
            for v in 0..V {
                let o = g + v * LANES;
                _mm256_storeu_ps(re.as_mut_ptr().add(o), r[v]);
                _mm256_storeu_ps(im.as_mut_ptr().add(o), i[v]);
            }
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[allow(clippy::too_many_arguments, clippy::needless_range_loop)]
    unsafe fn group<const V: usize>(
        re: &mut [f32],
        im: &mut [f32],
        pr: &[f32],
        pi: &[f32],
        input: Option<(&[f32], &[f32])>,
        acc: &mut [f32],
        n: usize,
        g: usize,
    ) {
        // SAFETY (whole body): the caller guarantees g + V·LANES ≤ len and acc ≥ n·LANES.
        unsafe {
            let mut r = [_mm256_setzero_ps(); V];
            let mut i = [_mm256_setzero_ps(); V];
            let mut cr = [_mm256_setzero_ps(); V];
            let mut ci = [_mm256_setzero_ps(); V];
            for v in 0..V {
                let o = g + v * LANES;
                r[v] = _mm256_loadu_ps(re.as_ptr().add(o));
                i[v] = _mm256_loadu_ps(im.as_ptr().add(o));
                cr[v] = _mm256_loadu_ps(pr.as_ptr().add(o));
                ci[v] = _mm256_loadu_ps(pi.as_ptr().add(o));
            }
            let accp = acc.as_mut_ptr();
            match input {
                None => {
                    for s in 0..n {
                        let ap = accp.add(s * LANES);
                        let mut a = _mm256_loadu_ps(ap);
                        for v in 0..V {
                            // Same operations as the portable kernel: cr·r − ci·i is one fused
                            // multiply-subtract of the rounded ci·i, as its `mul_add(…, −(ci·i))`.
                            // (An FMA on a negated product put a subtraction on the chain of
                            // dependent operations: 3 instead of 2, latency-bound in every group.)
                            let nr = _mm256_fmsub_ps(cr[v], r[v], _mm256_mul_ps(ci[v], i[v]));
                            let ni = _mm256_fmadd_ps(cr[v], i[v], _mm256_mul_ps(ci[v], r[v]));
                            r[v] = nr;
                            i[v] = ni;
                            a = _mm256_add_ps(a, ni);
                        }
                        _mm256_storeu_ps(ap, a);
                    }
                }
                Some((x, d)) => {
                    let mut b = [_mm256_setzero_ps(); V];
                    for v in 0..V {
                        let o = g + v * LANES;
                        let mut tmp = [0.0f32; LANES];
                        for (l, t) in tmp.iter_mut().enumerate() {
                            *t = d.get(o + l).copied().unwrap_or(0.0);
                        }
                        b[v] = _mm256_loadu_ps(tmp.as_ptr());
                    }
                    for s in 0..n {
                        let xs = _mm256_set1_ps(*x.get_unchecked(s));
                        let ap = accp.add(s * LANES);
                        let mut a = _mm256_loadu_ps(ap);
                        for v in 0..V {
                            // The input is added before the advance, like `excite`.
                            r[v] = _mm256_fmadd_ps(b[v], xs, r[v]);
                            let nr = _mm256_fmsub_ps(cr[v], r[v], _mm256_mul_ps(ci[v], i[v]));
                            let ni = _mm256_fmadd_ps(cr[v], i[v], _mm256_mul_ps(ci[v], r[v]));
                            r[v] = nr;
                            i[v] = ni;
                            a = _mm256_add_ps(a, ni);
                        }
                        _mm256_storeu_ps(ap, a);
                    }
                }
            }
            for v in 0..V {
                let o = g + v * LANES;
                _mm256_storeu_ps(re.as_mut_ptr().add(o), r[v]);
                _mm256_storeu_ps(im.as_mut_ptr().add(o), i[v]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two identical sets of banks of `sizes` modes run by the chosen kernel: one to run each
    /// bank on its own, one to run through a [`VectorBatch`].
    fn twin_banks(sizes: &[usize], avx2: bool) -> (Vec<ResonatorBank>, Vec<ResonatorBank>) {
        let mut own = banks(sizes);
        for bank in &mut own {
            bank.avx2 = avx2;
        }
        (own.clone(), own)
    }

    /// Each bank's own `process_lanes` in turn over `block` samples: the lane sums.
    fn lanes_of_each_in_turn(banks: &mut [ResonatorBank], block: usize) -> Vec<f32> {
        let mut lanes = vec![0.0f32; block * LANES];
        for bank in banks {
            bank.process_lanes(&mut lanes);
        }
        lanes
    }

    /// Banks of `sizes` modes excited with distinct amplitudes.
    fn banks(sizes: &[usize]) -> Vec<ResonatorBank> {
        sizes
            .iter()
            .enumerate()
            .map(|(b, &n)| {
                let mut bank = ResonatorBank::new(32);
                for m in 0..n {
                    let f = 200.0 + 173.0 * m as f64 + 50.0 * b as f64;
                    let k =
                        bank.push(ModeCoeffs::new(3.0 + m as f64, 2.0 * std::f64::consts::PI * f, 48_000.0)).unwrap();
                    bank.excite(k, 1.0 / (1.0 + m as f32 + b as f32));
                }
                bank
            })
            .collect()
    }

    /// A `VectorBatch` of the vectors of several banks, pushed in bank order, gives bit for
    /// bit the lane sums and the states of each bank's own `process_lanes` in that order,
    /// with either kernel, over several blocks.
    #[test]
    fn a_batch_across_banks_is_bit_identical_to_each_bank_in_turn() {
        for avx2 in [false, avx2_available()] {
            let (mut own, mut batched) = twin_banks(&[3, 10, 17], avx2);
            for block in [64usize, 17, 64, 5] {
                let lanes_own = lanes_of_each_in_turn(&mut own, block);
                let mut batch = VectorBatch::new(avx2);
                let mut lanes_batch = vec![0.0f32; block * LANES];
                // The batch holds copies: states are handed back after the pass.
                let snapshot: Vec<ResonatorBank> = batched.clone();
                let mut states: Vec<(usize, usize, Vec<f32>, Vec<f32>)> = Vec::new();
                for (b, bank) in snapshot.iter().enumerate() {
                    for k in 0..bank.vectors() {
                        assert_eq!(batch.push(b, bank, k), LANES);
                        if batch.is_full() {
                            batch.run(&mut lanes_batch, |o, k, re, im| states.push((o, k, re.to_vec(), im.to_vec())));
                        }
                    }
                }
                batch.run(&mut lanes_batch, |o, k, re, im| states.push((o, k, re.to_vec(), im.to_vec())));
                for (o, k, re, im) in &states {
                    batched[*o].store_modes(*k, re, im);
                }
                assert_eq!(
                    lanes_own.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    lanes_batch.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    "avx2 {avx2}, block {block}"
                );
                for (a, b) in own.iter().zip(&batched) {
                    assert_eq!(a.re, b.re, "avx2 {avx2}");
                    assert_eq!(a.im, b.im, "avx2 {avx2}");
                }
            }
        }
    }

    /// Modes packed lane by lane (a few from each bank, ranges split across two runs of the
    /// batch) advance bit for bit as in their own banks, and the summed output equals each
    /// bank's own within rounding (the lane a mode adds into changes, nothing else), with
    /// either kernel, over several blocks.
    #[test]
    fn modes_packed_across_banks_advance_exactly_as_in_their_banks() {
        // 295 modes: one full batch, the rest (39: 5 vectors, one wide group) in a second run.
        let sizes: Vec<usize> = [3usize, 10, 17, 6, 9, 1, 13].repeat(5);
        assert!(sizes.iter().sum::<usize>() > BATCH_LANES);
        for avx2 in [false, avx2_available()] {
            let (mut own, mut packed) = twin_banks(&sizes, avx2);
            for block in [64usize, 17, 64, 5] {
                let lanes_own = lanes_of_each_in_turn(&mut own, block);
                let mut batch = VectorBatch::new(avx2);
                let mut lanes_packed = vec![0.0f32; block * LANES];
                let snapshot: Vec<ResonatorBank> = packed.clone();
                let mut states: Vec<(usize, usize, Vec<f32>, Vec<f32>)> = Vec::new();
                let mut runs = 0;
                for (b, bank) in snapshot.iter().enumerate() {
                    let mut first = 0;
                    while first < bank.len() {
                        first += batch.push_modes(b, bank, first, bank.len() - first);
                        if batch.is_full() {
                            batch.run(&mut lanes_packed, |o, k, re, im| states.push((o, k, re.to_vec(), im.to_vec())));
                            runs += 1;
                        }
                    }
                }
                batch.run(&mut lanes_packed, |o, k, re, im| states.push((o, k, re.to_vec(), im.to_vec())));
                assert_eq!(runs, 1, "one full batch, the rest in a second run");
                assert!(states.len() > sizes.len(), "a range was split across the two runs");
                for (o, k, re, im) in &states {
                    packed[*o].store_modes(*k, re, im);
                }
                for (a, b) in own.iter().zip(&packed) {
                    assert_eq!(a.re, b.re, "avx2 {avx2}, block {block}");
                    assert_eq!(a.im, b.im, "avx2 {avx2}, block {block}");
                }
                let (mut out_own, mut out_packed) = (vec![0.0f32; block], vec![0.0f32; block]);
                reduce_lanes(&lanes_own, &mut out_own);
                reduce_lanes(&lanes_packed, &mut out_packed);
                let peak = out_own.iter().fold(0.0f32, |p, x| p.max(x.abs()));
                assert!(peak > 0.1, "the modes sound: {peak}");
                for (a, b) in out_own.iter().zip(&out_packed) {
                    assert!((a - b).abs() <= 1e-6 * peak.max(1.0), "avx2 {avx2}, block {block}: {a} vs {b}");
                }
            }
        }
    }

    /// The AVX2 lane reduction gives bit for bit the portable one's sums (any length, tails
    /// of 1–7 samples, sums that cancel, huge and tiny values).
    #[test]
    fn lane_reductions_agree() {
        if !avx2_available() {
            eprintln!("lane_reductions_agree: no AVX2 on this CPU, nothing to compare");
            return;
        }
        let mut x = 0x1234_5678u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let m = (x >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
            m * [1.0, 1e-30, 1e30, 3.0][(x & 3) as usize]
        };
        for n in [0usize, 1, 7, 8, 9, 37, 64] {
            let acc: Vec<f32> = (0..n * LANES).map(|_| next()).collect();
            let start: Vec<f32> = (0..n).map(|_| next()).collect();
            let (mut portable, mut simd) = (start.clone(), start.clone());
            reduce_lanes(&acc, &mut portable);
            reduce_lanes_with(&acc, &mut simd, true);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&portable), bits(&simd), "{n} samples");
        }
    }

    /// A slow oracle: the direct sum of damped sinusoids in f64, against each kernel on its
    /// own — the AVX2/FMA kernel (where the CPU has it) and the portable one.
    #[test]
    fn impulse_response_matches_direct_sum() {
        let fs = 48_000.0;
        let modes: Vec<(f64, f64, f32)> = (0..37)
            .map(|k| {
                (2.0 + 3.0 * k as f64, 2.0 * std::f64::consts::PI * (100.0 + 411.0 * k as f64), 0.1 + 0.02 * k as f32)
            })
            .collect();
        for avx2 in [true, false] {
            let mut bank = ResonatorBank::new(64);
            bank.set_avx2(avx2);
            assert_eq!(bank.uses_avx2(), avx2 && avx2_available());
            for &(d, w, a) in &modes {
                let k = bank.push(ModeCoeffs::new(d, w, fs)).unwrap();
                bank.excite(k, a);
            }
            let total = 1000;
            let mut out = vec![0.0f32; total];
            for chunk in out.chunks_mut(MAX_KERNEL_BLOCK) {
                bank.process(chunk);
            }
            for (n, &y) in out.iter().enumerate() {
                let t = (n + 1) as f64 / fs;
                let want: f64 = modes.iter().map(|&(d, w, a)| a as f64 * (-d * t).exp() * (w * t).sin()).sum();
                assert!((y as f64 - want).abs() < 2e-4, "avx2 {avx2}, sample {n}: {y} vs {want}");
            }
        }
    }

    /// The forced kernel (pulse, noise and lasting contact) on AVX2/FMA and portable: the
    /// same sums up to FMA rounding, for 45 modes (whole groups and a part group), every
    /// forcing weight and signal non-zero, over blocks of 64 and 13 samples.
    #[test]
    fn forced_kernels_agree() {
        if !avx2_available() {
            return;
        }
        let fs = 48_000.0;
        let mut a = ResonatorBank::new(45);
        for k in 0..45 {
            let s = a.push(ModeCoeffs::new(2.0 + k as f64, 2.0 * std::f64::consts::PI * (90.0 + 377.0 * k as f64), fs));
            let s = s.unwrap();
            let w = |j: usize| ((k * 7 + j * 3) % 11) as f32 / 11.0 - 0.45;
            a.set_forcing(s, (w(0), w(1)), (w(2), w(3)), w(4));
        }
        let mut b = a.clone();
        a.set_avx2(true);
        b.set_avx2(false);
        assert!(a.uses_avx2() && !b.uses_avx2());
        let mut noise = crate::exciter::Noise::new(3);
        let (mut ya, mut yb) = (Vec::new(), Vec::new());
        for block in [64usize, 13, 64, 64, 13] {
            let u: Vec<Vec<f32>> = (0..3).map(|_| (0..block).map(|_| noise.next_sample()).collect()).collect();
            let (mut oa, mut ob) = (vec![0.0f32; block], vec![0.0f32; block]);
            a.process_forced([&u[0], &u[1], &u[2]], &mut oa);
            b.process_forced([&u[0], &u[1], &u[2]], &mut ob);
            ya.extend(oa);
            yb.extend(ob);
        }
        let scale = yb.iter().fold(0.0f32, |m, y| m.max(y.abs()));
        assert!(scale > 0.1);
        for (n, (x, y)) in ya.iter().zip(&yb).enumerate() {
            assert!((x - y).abs() <= 1e-5 * scale, "sample {n}: {x} vs {y}");
        }
    }

    /// Every grouping of the AVX2 kernel (1 to 4 vectors, and the wide groups of 5 and 6 that
    /// end a bank of 5, 6, 9, 10, 13 or 14 vectors) against the portable kernel's one vector
    /// at a time: bit for bit.
    #[test]
    fn portable_and_simd_kernels_agree() {
        let fs = 44_100.0;
        for modes in [5usize, 12, 20, 32, 33, 41, 48, 72, 80, 100, 112, 130] {
            let mut a = ResonatorBank::new(modes);
            for k in 0..modes {
                let s = a.push(ModeCoeffs::new(1.0 + k as f64, 300.0 + 900.0 * k as f64, fs)).unwrap();
                a.excite(s, 1.0 / (1.0 + k as f32));
            }
            let mut b = a.clone();
            let mut out_a = vec![0.0f32; 64];
            let mut out_b = vec![0.0f32; 64];
            a.process(&mut out_a);
            let padded = b.len.div_ceil(LANES) * LANES;
            let mut acc = vec![0.0f32; 64 * LANES];
            let (re, im, pr, pi) = (&mut b.re[..padded], &mut b.im[..padded], &b.pr[..padded], &b.pi[..padded]);
            portable::run(re, im, pr, pi, None, &mut acc, 64);
            reduce_lanes(&acc, &mut out_b);
            assert!(out_b.iter().any(|&y| y.abs() > 0.01), "{modes} modes sound");
            // Bit for bit: the same operations in the same order, each FMA the portable
            // kernel's `mul_add` (cr·r − ci·i a fused multiply-subtract of the rounded ci·i).
            for (x, y) in out_a.iter().zip(&out_b) {
                assert_eq!(x.to_bits(), y.to_bits(), "{modes} modes: {x} vs {y}");
            }
            for k in 0..a.len {
                let (sa, sb) = ((a.re[k].to_bits(), a.im[k].to_bits()), (b.re[k].to_bits(), b.im[k].to_bits()));
                assert_eq!(sa, sb, "{modes} modes: mode {k}");
            }
        }
    }

    #[test]
    fn driven_impulse_equals_excite() {
        let fs = 48_000.0;
        let mut a = ResonatorBank::new(8);
        let mut b = ResonatorBank::new(8);
        for k in 0..5 {
            let c = ModeCoeffs::new(3.0, 1000.0 * (k + 1) as f64, fs);
            a.push(c);
            b.push(c);
            a.excite(k, 0.5);
        }
        let mut x = [0.0f32; 32];
        x[0] = 1.0;
        let drive = [0.5f32; 8];
        let mut oa = [0.0f32; 32];
        let mut ob = [0.0f32; 32];
        a.process(&mut oa);
        b.process_driven(&x, &drive, &mut ob);
        for (p, q) in oa.iter().zip(&ob) {
            assert!((p - q).abs() < 1e-6);
        }
    }
}
