#!/usr/bin/env python3
"""Independent modal analysis of a struck-object recording: sub-band ESPRIT.

Written for Struck's real-recording validation (issue 10, part 7) and kept
apart from the project's extractor on purpose: a different method (subspace
fitting of the waveform, not spectrogram fitting), different code,
numpy/scipy only.

Method
------
1. Onset: the first sample whose magnitude reaches 10 % of the clip's peak.
   Window: from SKIP_S (10 ms) after the onset (past the mallet's contact
   and the filter's start-up) for WINDOW_S (0.5 s), or 80 % of what is left
   of the clip if that is shorter.
2. Sub-bands 250 Hz wide (centres 125, 375, ... Hz up to min(20 kHz,
   0.45 fs)). Each band: complex demodulation to 0 Hz, a Kaiser low-pass FIR
   (pass +-150 Hz, stop 475 Hz, 80 dB) evaluated at a decimated rate of about
   625 Hz. A linear filter maps each damped exponential z^n to H(z) z^n once
   its impulse response has passed the onset, so frequencies and decays are
   untouched and amplitudes are recovered exactly by dividing by H(z).
3. LS-ESPRIT on the Hankel matrix (L = N/3 rows) of each band, the model
   order the larger of ESTER's (Badeau et al. 2006: the largest order whose
   shift-invariance criterion is within 10x of its best) and the number of
   singular values within 30 dB of the largest and above 3x the noise
   (median of the lower half), at most 12;
   complex amplitudes by least squares. Poles are kept in the band's own
   250 Hz only, so each is reported once.
4. Partials: real partials are seldom one exponential (beating doublets,
   two-stage decays, pitch glides), and a subspace fit then splits one
   partial into a few close poles. So poles are grouped: the strongest pole
   takes every pole within 0.5 % of its frequency (the matching tolerance of
   validate.py), and the partial is the sum of its poles. Its frequency is
   the energy-weighted mean of theirs; its decay d is the slope of the
   energy-weighted least-squares fit of log|envelope| over the window (the
   single exponential that best follows the partial's envelope); its
   amplitude is that fit's value at the window start (a real cosine
   a e^{-d t} cos(2 pi f t + phi)).
5. A partial counts if 20 Hz <= f <= min(20 kHz, 0.45 fs), 0 < d <= 300 1/s
   (T60 >= 23 ms) and Q = pi f / d >= 10. The strongest five are the
   reference. Also given: the recording's lowest strong partial, the
   lowest-frequency partial of all those that count whose amplitude at the
   window start is within 20 dB of the strongest's (`lowest_strong`; within
   30 dB: `lowest_strong_30db`), the pitch the object fit is measured
   against (e2e.py --objects).
6. Reliability flags: `stable` when a repeat analysis on a window 70 % as
   long with the model order two higher gives the same partial (0.1 % or
   0.5 Hz) with a decay within 10 % (or 0.3 1/s); `single` when the
   envelope fits one exponential (its first and second halves give decays
   within 25 % of each other); `crowded` when another partial of at least a
   quarter of its amplitude lies within 1 % (a feature between the two may
   match either). `reliable` = stable and single and not crowded.
7. A third opinion, `decay_stft`: the slope of the short-time spectrum's
   magnitude at the partial's frequency (40 ms frames, same window), and
   `stft_agrees` when it is within 20 % of the ESPRIT decay.

Run `python subspace.py --self-test` for the synthetic check, or
`python subspace.py FILE.wav` to print the strongest partials of a file.
"""

import argparse
import json
import os
import sys

# one BLAS thread: the matrices are small, and threads only contend on 2 cores
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402
from scipy import linalg, signal  # noqa: E402

WINDOW_S = 0.5
SKIP_S = 0.010
BAND_HZ = 250.0
PASS_HZ = 150.0
STOP_HZ = 475.0
DEC_RATE = 625.0
MAX_ORDER = 12
ESTER_THRESHOLD = 0.1
SV_RANGE_DB = 30.0
MAX_DECAY = 300.0
MIN_Q = 10.0


def read_wav(path):
    """Mono float64 samples and the rate of a PCM (16/24/32-bit) or float WAV."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"RIFF" or data[8:12] != b"WAVE":
        raise ValueError(f"{path}: not a WAV file")
    off = 12
    fmt = None
    pcm = None
    while off + 8 <= len(data):
        cid = data[off:off + 4]
        size = int.from_bytes(data[off + 4:off + 8], "little")
        body = data[off + 8:off + 8 + size]
        if cid == b"fmt ":
            tag = int.from_bytes(body[0:2], "little")
            ch = int.from_bytes(body[2:4], "little")
            rate = int.from_bytes(body[4:8], "little")
            bits = int.from_bytes(body[14:16], "little")
            if tag == 0xFFFE:
                tag = int.from_bytes(body[24:26], "little")
            fmt = (int(tag), int(ch), rate, bits)
        elif cid == b"data":
            pcm = body
        off += 8 + size + (size & 1)
    if fmt is None or pcm is None:
        raise ValueError(f"{path}: no fmt or data chunk")
    tag, ch, rate, bits = fmt
    if tag == 3 and bits == 32:
        x = np.frombuffer(pcm, "<f4").astype(np.float64)
    elif tag == 3 and bits == 64:
        x = np.frombuffer(pcm, "<f8").copy()
    elif tag == 1 and bits == 16:
        x = np.frombuffer(pcm, "<i2") / 32768.0
    elif tag == 1 and bits == 24:
        b = np.frombuffer(pcm[:len(pcm) // 3 * 3], np.uint8).reshape(-1, 3).astype(np.int32)
        v = b[:, 0] | (b[:, 1] << 8) | (b[:, 2] << 16)
        x = np.where(v >= 1 << 23, v - (1 << 24), v) / float(1 << 23)
    elif tag == 1 and bits == 32:
        x = np.frombuffer(pcm, "<i4") / float(1 << 31)
    else:
        raise ValueError(f"{path}: unsupported WAV format tag {tag}, {bits} bits")
    x = x[:len(x) // ch * ch].reshape(-1, ch).mean(axis=1)
    return x, rate


def write_wav_float(path, x, rate):
    """Mono 32-bit float WAV."""
    x = np.asarray(x, dtype="<f4")
    with open(path, "wb") as f:
        n = x.nbytes
        f.write(b"RIFF" + (4 + 26 + 12 + 8 + n).to_bytes(4, "little") + b"WAVE")
        f.write(b"fmt " + (18).to_bytes(4, "little"))
        f.write((3).to_bytes(2, "little") + (1).to_bytes(2, "little") + int(rate).to_bytes(4, "little"))
        f.write((int(rate) * 4).to_bytes(4, "little") + (4).to_bytes(2, "little") + (32).to_bytes(2, "little") + (0).to_bytes(2, "little"))
        f.write(b"fact" + (4).to_bytes(4, "little") + len(x).to_bytes(4, "little"))
        f.write(b"data" + n.to_bytes(4, "little"))
        f.write(x.tobytes())


def onset_index(x, frac=0.1):
    a = np.abs(x)
    return int(np.argmax(a >= frac * a.max()))


def _lowpass(fs):
    ripple_db = 80.0
    width = (STOP_HZ - PASS_HZ) / (fs / 2)
    n, beta = signal.kaiserord(ripple_db, width)
    n |= 1
    return signal.firwin(n, (PASS_HZ + STOP_HZ) / 2, window=("kaiser", beta), fs=fs)


def _signal_subspace(y, pmax):
    """The pmax dominant left singular vectors of the Hankel matrix of y, and
    all its singular values (largest first)."""
    n = len(y)
    L = n // 3
    idx = np.arange(L)[:, None] + np.arange(n - L + 1)[None, :]
    Y = y[idx]
    R = Y @ Y.conj().T
    pmax = min(pmax, L - 2)
    w, V = linalg.eigh(R, driver="evd")
    s = np.sqrt(np.maximum(w[::-1], 0.0))
    return V[:, ::-1][:, :pmax], s


def ester_order(V, threshold=ESTER_THRESHOLD):
    """Model order by ESTER (Badeau, David & Richard 2006): the largest p whose
    shift-invariance criterion J(p) = 1 / ||W_up - W_down Phi(p)||^2 reaches
    `threshold` times its maximum over p."""
    J = np.zeros(V.shape[1])
    for p in range(1, V.shape[1] + 1):
        W = V[:, :p]
        phi = np.linalg.lstsq(W[:-1], W[1:], rcond=None)[0]
        J[p - 1] = 1.0 / max(np.linalg.norm(W[1:] - W[:-1] @ phi, 2) ** 2, 1e-300)
    ok = np.nonzero(J >= threshold * J.max())[0]
    return int(ok[-1]) + 1


def esprit(y, order=None, order_bonus=0, pmax=MAX_ORDER):
    """LS-ESPRIT of a complex sequence. Returns (poles z, amplitudes c) with
    y[n] ~ sum_k c_k z_k^n; the order by ESTER unless given."""
    V, s = _signal_subspace(y, pmax + max(order_bonus, 0))
    if order is None:
        # ESTER's order, or more if more singular values stand out: those
        # within SV_RANGE_DB of the largest and above 3x the median of the
        # lower half (the noise); grouping (see partials) makes a generous
        # order harmless
        noise = np.median(s[len(s) // 2:])
        strong = int(np.sum((s >= s[0] * 10 ** (-SV_RANGE_DB / 20)) & (s > 3 * noise)))
        order = max(ester_order(V[:, :pmax]), min(strong, pmax)) + order_bonus
    order = max(1, min(order, V.shape[1]))
    U = V[:, :order]
    phi = np.linalg.lstsq(U[:-1], U[1:], rcond=None)[0]
    z = np.linalg.eigvals(phi)
    z = z[np.abs(z) > 1e-6]
    # A pole growing e^300-fold over the window (a noise-free render's spurious
    # pole) would overflow the Vandermonde matrix and stall the solver: not a
    # partial (poles growing at all are dropped below), so not fitted.
    z = z[np.log(np.abs(z)) * len(y) < 300.0]
    Vm = z[None, :] ** np.arange(len(y))[:, None]
    c = np.linalg.lstsq(Vm, y, rcond=None)[0]
    return z, c


def poles(x, fs, window_s=WINDOW_S, order_bonus=0, onset=None, skip_s=SKIP_S):
    """All poles of all sub-bands. Returns (list of (f_hz, d, c)), t0, T)
    where c is the analytic complex amplitude at the window start (the real
    component is 2 Re(c e^{(-d + 2 pi i f) t})), t0 the window start after
    the onset and T the window length, s."""
    x = np.asarray(x, dtype=np.float64)
    if onset is None:
        onset = onset_index(x)
    h = _lowpass(fs)
    D = max(1, int(fs // DEC_RATE))
    fsd = fs / D
    start = onset + max(len(h), int(skip_s * fs))
    avail = len(x) - start
    nwin = int(min(window_s * fs, 0.8 * avail))
    if nwin < int(0.05 * fs):
        return [], (start - onset) / fs, 0.0
    fmax = min(20000.0, 0.45 * fs)
    seg = x[start - len(h) + 1:start + nwin]
    nseg = np.arange(len(seg)) + (start - len(h) + 1)
    hr = h[::-1]
    k = np.arange(len(h))
    out = []
    fc = BAND_HZ / 2
    while fc - BAND_HZ / 2 < fmax:
        xd = seg * np.exp(-2j * np.pi * fc * (nseg - start) / fs)
        # filtered samples y[m] at original indices start + m D
        win = np.lib.stride_tricks.sliding_window_view(xd, len(h))[::D]
        y = win @ hr
        z, c = esprit(y, order_bonus=order_bonus)
        for zk, ck in zip(z, c):
            sd = np.log(zk) * fsd  # continuous pole of the demodulated signal
            d = -sd.real
            fr = sd.imag / (2 * np.pi)
            if abs(fr) > BAND_HZ / 2 or not (-20.0 < d < 3000.0):
                continue
            # the filter maps z^n to H(z) z^n: undo its gain (original rate)
            zo = np.exp((-d + 2j * np.pi * fr) / fs)
            H = np.sum(h * zo ** (-k))
            cin = ck / H
            if np.isfinite(cin):
                out.append((fc + fr, d, cin))
        fc += BAND_HZ
    return out, (start - onset) / fs, nwin / fs


def _envelope_decay(group, t):
    """Energy-weighted LS fit of log|s(t)| = log A - d t for the sum s of a
    group of poles. Returns (d, A) with A the real-cosine amplitude at t=0."""
    s = np.zeros(len(t), complex)
    for f, d, c in group:
        s += c * np.exp((-d + 2j * np.pi * f) * t)
    e = np.abs(s)
    w = e ** 2
    ok = e > 0
    if ok.sum() < 3:
        return np.nan, 0.0
    le = np.log(e[ok])
    tw, ww = t[ok], w[ok]
    A = np.vstack([np.ones(ok.sum()), -tw]).T * np.sqrt(ww)[:, None]
    sol = np.linalg.lstsq(A, le * np.sqrt(ww), rcond=None)[0]
    return float(sol[1]), float(2 * np.exp(sol[0]))


def partials(pl, T, fmax):
    """Group poles into partials (see the module docstring), strongest first."""
    pl = sorted(pl, key=lambda p: -abs(p[2]))
    used = [False] * len(pl)
    t = np.linspace(0.0, T, max(50, int(T * 1000)))
    out = []
    for i, (f, d, c) in enumerate(pl):
        if used[i] or d <= 0:
            continue
        group = []
        for j, q in enumerate(pl):
            if not used[j] and abs(q[0] - f) <= 0.005 * f:
                used[j] = True
                group.append(q)
        dd, amp = _envelope_decay(group, t)
        half = len(t) // 2
        d1, _ = _envelope_decay(group, t[:half])
        d2, _ = _envelope_decay(group, t[half:])
        energy = np.array([abs(q[2]) ** 2 / max(q[1], 1e-3) for q in group])
        fw = float(np.sum(energy * np.array([q[0] for q in group])) / np.sum(energy))
        if not (np.isfinite(dd) and 20.0 <= fw <= fmax and 0 < dd <= MAX_DECAY and np.pi * fw / dd >= MIN_Q):
            continue
        out.append({"freq_hz": fw, "decay_per_s": dd, "amplitude": amp, "poles": len(group),
                    "decay_first_half": d1, "decay_second_half": d2})
    out.sort(key=lambda p: -p["amplitude"])
    return out


def analyse(x, fs, window_s=WINDOW_S, order_bonus=0, onset=None, skip_s=SKIP_S):
    """All partials of a clip, strongest first; each with `t0_s`, the time of
    its amplitude after the onset."""
    pl, t0, T = poles(x, fs, window_s, order_bonus, onset, skip_s)
    if T <= 0:
        return []
    ps = partials(pl, T, min(20000.0, 0.45 * fs))
    for p in ps:
        p["t0_s"] = t0
    return ps


def _close(p, q):
    df = abs(p["freq_hz"] - q["freq_hz"])
    dd = abs(p["decay_per_s"] - q["decay_per_s"])
    return df <= max(0.001 * p["freq_hz"], 0.5) and dd <= max(0.1 * p["decay_per_s"], 0.3)


def _single(p):
    a, b = p["decay_first_half"], p["decay_second_half"]
    if not (np.isfinite(a) and np.isfinite(b)):
        return False
    return abs(a - b) <= 0.25 * max(abs(a), abs(b), 1e-9) or abs(a - b) <= 0.3


def stft_decay(x, fs, f, onset, t0=SKIP_S, T=WINDOW_S, frame_s=0.04):
    """A third, plainer opinion on a partial's decay: short-time DTFT
    magnitude at f (best of 9 frequencies within +-0.2 %) in 40 ms Hann
    frames every 5 ms over the reference window, and the energy-weighted
    least-squares slope of its log. Blind to partials closer than ~50 Hz."""
    n = int(frame_s * fs)
    hop = max(1, int(0.005 * fs))
    w = np.hanning(n)
    k = np.arange(n)
    start = onset + int(t0 * fs)
    end = min(len(x) - n, start + int(T * fs) - n)
    if end <= start + 4 * hop:
        return float("nan")
    freqs = f * (1 + np.linspace(-0.002, 0.002, 9))
    E = np.exp(-2j * np.pi * freqs[:, None] * k[None, :] / fs) * w[None, :]
    ts, mags = [], []
    for s0 in range(start, end, hop):
        mags.append(np.max(np.abs(E @ x[s0:s0 + n])))
        ts.append((s0 - onset + n / 2) / fs)
    ts, m = np.array(ts), np.array(mags)
    ok = m > 1e-3 * m.max()
    if ok.sum() < 4:
        return float("nan")
    A = np.vstack([np.ones(ok.sum()), -ts[ok]]).T * m[ok, None]
    return float(np.linalg.lstsq(A, np.log(m[ok]) * m[ok], rcond=None)[0][1])


LOWEST_STRONG_DB = 20.0
LOWEST_STRONG_WIDE_DB = 30.0


def lowest_strong(parts, range_db):
    """The lowest-frequency partial of `parts` (all partials that count, strongest first)
    whose amplitude at the window start is within `range_db` of the strongest's; None if
    there are none. `rank`: its place by amplitude (1 = the strongest)."""
    if not parts:
        return None
    top = parts[0]["amplitude"]
    ok = [(i, p) for i, p in enumerate(parts) if p["amplitude"] >= top * 10 ** (-range_db / 20)]
    i, p = min(ok, key=lambda ip: ip[1]["freq_hz"])
    return {"freq_hz": p["freq_hz"], "decay_per_s": p["decay_per_s"],
            "amplitude_db_re_strongest": 20 * np.log10(p["amplitude"] / top), "rank": i + 1,
            "range_db": range_db}


def reference(x, fs, top=5):
    """The `top` strongest partials of a clip with their reliability flags
    (module docstring, step 6)."""
    onset = onset_index(x)
    parts = analyse(x, fs, onset=onset)
    rep = analyse(x, fs, window_s=0.7 * WINDOW_S, order_bonus=2, onset=onset)
    avail = (len(x) - onset) / fs
    best = parts[:top]
    for p in best:
        p["stable"] = any(_close(p, q) for q in rep)
        p["single"] = _single(p)
        p["crowded"] = any(q is not p and abs(q["freq_hz"] - p["freq_hz"]) <= 0.01 * p["freq_hz"]
                           and q["amplitude"] >= 0.25 * p["amplitude"] for q in parts)
        p["reliable"] = p["stable"] and p["single"] and not p["crowded"]
        p["decay_stft"] = stft_decay(x, fs, p["freq_hz"], onset, p["t0_s"], WINDOW_S)
        p["stft_agrees"] = bool(abs(p["decay_stft"] - p["decay_per_s"]) <= 0.2 * p["decay_per_s"])
    return {"onset_s": onset / fs, "clip_s": avail, "partials": best, "all_partials": len(parts),
            "lowest_strong": lowest_strong(parts, LOWEST_STRONG_DB),
            "lowest_strong_30db": lowest_strong(parts, LOWEST_STRONG_WIDE_DB)}


def self_test(verbose=True):
    """Synthetic damped sinusoids with known f and d (plus a click and noise)."""
    rng = np.random.default_rng(1234)
    ok = True
    worst_f = worst_d = 0.0
    cases = 0
    for fs in (44100, 32000):
        for trial in range(6):
            k = 6
            f = np.exp(rng.uniform(np.log(60), np.log(min(15000, 0.4 * fs)), k))
            d = np.exp(rng.uniform(np.log(0.5), np.log(200), k))
            a = np.exp(rng.uniform(np.log(0.05), np.log(1.0), k))
            ph = rng.uniform(0, 2 * np.pi, k)
            pre = int(0.01 * fs)
            t = np.arange(int(1.0 * fs)) / fs
            x = np.zeros(pre + len(t))
            for i in range(k):
                x[pre:] += a[i] * np.exp(-d[i] * t) * np.cos(2 * np.pi * f[i] * t + ph[i])
            x[pre:pre + 40] += 0.3 * rng.standard_normal(40) * np.hanning(40)  # contact click
            x += 10 ** (-70 / 20) * rng.standard_normal(len(x))
            onset = pre
            parts = analyse(x, fs, onset=onset)
            t0 = parts[0]["t0_s"] if parts else 0.0
            a0 = a * np.exp(-d * t0)
            for i in range(k):
                # partials that qualify and are within 20 dB of the strongest
                # at the window start
                if not (d[i] <= MAX_DECAY and np.pi * f[i] / d[i] >= MIN_Q and a0[i] >= 0.1 * a0.max()):
                    continue
                m = [p for p in parts if abs(p["freq_hz"] - f[i]) < 0.002 * f[i] + 1]
                cases += 1
                if not m:
                    ok = False
                    if verbose:
                        print(f"  MISSED f={f[i]:.2f} d={d[i]:.3f} a={a[i]:.3f} fs={fs}")
                    continue
                p = max(m, key=lambda p: p["amplitude"])
                ef = abs(p["freq_hz"] - f[i]) / f[i]
                ed = abs(p["decay_per_s"] - d[i]) / d[i]
                ea = abs(p["amplitude"] - a[i] * np.exp(-d[i] * p["t0_s"])) / a[i]
                worst_f, worst_d = max(worst_f, ef), max(worst_d, ed)
                bad = ef > 1e-4 or ed > 0.05 or ea > 0.10
                if bad:
                    ok = False
                if verbose and bad:
                    print(f"  f={f[i]:9.2f} d={d[i]:8.3f} a={a[i]:.3f} -> f={p['freq_hz']:9.2f} "
                          f"d={p['decay_per_s']:8.3f} a={p['amplitude']:.3f}  fs={fs}")
    if verbose:
        print(f"self-test: {cases} partials, worst error f {100 * worst_f:.4f} %, d {100 * worst_d:.3f} %"
              f" -> {'ok' if ok else 'FAILED'}")
    return ok


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="*")
    ap.add_argument("--self-test", action="store_true")
    ap.add_argument("--top", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    if a.self_test:
        sys.exit(0 if self_test() else 1)
    res = {}
    for path in a.files:
        x, fs = read_wav(path)
        res[path] = reference(x, fs, a.top)
        if not a.json:
            print(path)
            for p in res[path]["partials"]:
                flags = " ".join(k for k in ("stable", "single", "crowded", "reliable", "stft_agrees") if p[k])
                print(f"  {p['freq_hz']:10.2f} Hz  d {p['decay_per_s']:8.3f} 1/s  a {p['amplitude']:.4f}"
                      f"  poles {p['poles']}  {flags}")
            for key in ("lowest_strong", "lowest_strong_30db"):
                q = res[path][key]
                if q:
                    print(f"  {key}: {q['freq_hz']:.2f} Hz  d {q['decay_per_s']:.3f} 1/s"
                          f"  {q['amplitude_db_re_strongest']:.1f} dB (rank {q['rank']})")
    if a.json:
        print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
