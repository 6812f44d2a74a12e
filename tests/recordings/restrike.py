#!/usr/bin/env python3
"""Second strikes on real ringing objects: does the segmentation find them?

For every clip fetched by fetch.py (one real strike each), a second real strike
is mixed in while the first still rings: the same clip again, `--lags` seconds
later (0.15, 0.3, 0.6 s; only where the clip lasts 0.1 s past the lag), at 0.5
and 1.0 of its level, and (the "soft" variant) low-passed at 1.5 kHz
(second-order Butterworth) and brought back to the clip's peak, the spectrum of
a softer mallet that re-excites the low partials without a bright click. The
mix is normalised to a 0.9 peak and written as 32-bit float.

`struck features FILE --json` must then give exactly two impacts, the second
starting between 3 ms before the lag and 3 ms after the lag plus the first
onset (the clip's own lead-in before its strike). Reported: the share found,
per lag, level and variant, and the clips that failed.

Usage:
  python restrike.py [--struck PATH] [--cache DIR] [--json OUT] [--min-found X]
X is a share (0.6) or a percentage (60); with it the exit code is 1 below it.
"""

import argparse
import json
import os
import sys
import tempfile
import time

import numpy as np
import soundfile as sf
from scipy.signal import butter, sosfilt

from validate import default_struck, load_manifest, struck_features


def main():
    ap = argparse.ArgumentParser(description="second strikes on real ringing objects")
    ap.add_argument("--struck", default=default_struck())
    ap.add_argument("--cache", default=os.environ.get("STRUCK_REC_CACHE", "/work/rec-cache"))
    ap.add_argument("--json", dest="json_out")
    ap.add_argument("--lags", default="0.15,0.3,0.6")
    ap.add_argument("--min-found", type=float)
    a = ap.parse_args()
    clips = [c for c in load_manifest("restrike.py", a.cache, a.struck)["clips"] if "wav" in c]
    lags = [float(v) for v in a.lags.split(",")]
    t_start = time.time()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        wav = os.path.join(tmp, "twice.wav")
        for c in clips:
            x, fs = sf.read(os.path.join(a.cache, c["wav"]), dtype="float64")
            if x.ndim > 1:
                x = x.mean(axis=1)
            low = sosfilt(butter(2, 1500 / (fs / 2), output="sos"), x)
            low *= np.abs(x).max() / max(np.abs(low).max(), 1e-12)
            for lag in lags:
                n = int(round(lag * fs))
                if len(x) < n + int(0.1 * fs):
                    continue
                for level in (0.5, 1.0):
                    for soft in (False, True):
                        y = np.zeros(len(x) + n)
                        y[: len(x)] += x
                        y[n:] += level * (low if soft else x)
                        y *= 0.9 / np.abs(y).max()
                        sf.write(wav, y.astype(np.float32), fs, subtype="FLOAT")
                        report, _, _ = struck_features(a.struck, wav)
                        onsets = None if report is None else [i["onset_s"] for i in report["impacts"]]
                        ok = (
                            onsets is not None
                            and len(onsets) == 2
                            and lag - 0.003 <= onsets[1] <= lag + onsets[0] + 0.003
                        )
                        rows.append(
                            {"clip": c["id"], "category": c["category"], "lag": lag, "level": level,
                             "soft": soft, "onsets": onsets, "found": ok}
                        )
    found = sum(r["found"] for r in rows)
    print(f"second strikes found: {found}/{len(rows)} ({100 * found / max(len(rows), 1):.1f} %)")
    for soft in (False, True):
        for level in (0.5, 1.0):
            cells = []
            for lag in lags:
                s = [r for r in rows if r["soft"] == soft and r["level"] == level and r["lag"] == lag]
                cells.append(f"{lag} s {sum(r['found'] for r in s)}/{len(s)}")
            print(f"{'soft' if soft else 'same'} mallet, level {level}: " + ", ".join(cells))
    for cat in sorted({r["category"] for r in rows}):
        s = [r for r in rows if r["category"] == cat]
        print(f"{cat}: {sum(r['found'] for r in s)}/{len(s)}")
    missed = {}
    for r in rows:
        if not r["found"]:
            missed.setdefault(r["clip"], []).append((r["lag"], r["level"], r["soft"], r["onsets"]))
    for clip, m in sorted(missed.items(), key=lambda kv: -len(kv[1])):
        print(f"  {clip}: {len(m)} missed, e.g. {m[0]}")
    print(f"time: {time.time() - t_start:.0f} s")
    if a.json_out:
        with open(a.json_out, "w") as f:
            json.dump(rows, f, indent=1)
    if a.min_found is not None:
        target = a.min_found / 100 if a.min_found > 1 else a.min_found
        share = found / max(len(rows), 1)
        print(f"restrike: {'passed' if share >= target else 'failed'} (found {share:.3f}, target {target:.3f})")
        return 0 if share >= target else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
