#!/usr/bin/env python3
"""`estimate --object` with a bank captured from the same recording: is it fitted at its own pitch?

`struck bank capture` makes a bank of a recording's own modes (their λ as recorded, the
bank's reference specific modulus as given), and `struck estimate CLIP --object BANK` then
records each mode's support as recorded. The pitch fit of that estimate (γ/γ₀, the scale
on the bank's λ) must be 1 by construction: every mode of the bank is a partial of the
clip. The truth here is that construction, not an analysis.

For every clip (fetch.py's manifest, or every WAV in `--clips DIR`): capture with the
command's defaults, estimate against it, and report the fitted pitch in cents from the
bank's own (600·log2(γ/γ₀)); a clip counts when within 50 cents. `--min-share X` exits 1
below X (a share or a percentage).

Usage: python ownpitch.py [--struck PATH] [--cache DIR | --clips DIR] [--min-share X]
"""

import argparse
import glob
import json
import math
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from validate import default_struck, load_manifest  # noqa: E402


def last_line(text):
    """The last line of a command's output, or "(nothing said)"."""
    lines = text.strip().splitlines()
    return lines[-1] if lines else "(nothing said)"


def own_pitch(struck, clip, work):
    """Cents of the fitted pitch from the bank's own, or (None, why)."""
    name = os.path.splitext(os.path.basename(clip))[0]
    bank, mat = os.path.join(work, f"{name}.bank.json"), os.path.join(work, f"{name}.mat.json")
    r = subprocess.run([struck, "bank", "capture", clip, "--out", bank], capture_output=True, text=True)
    if r.returncode:
        return None, "capture: " + last_line(r.stderr)
    r = subprocess.run([struck, "estimate", clip, "--object", bank, "--out", mat], capture_output=True, text=True)
    if r.returncode:
        return None, "estimate: " + last_line(r.stderr)
    with open(bank) as f:
        g0 = json.load(f)["reference"]["specific_modulus"]
    with open(mat) as f:
        g = json.load(f).get("specific_modulus")
    if g is None:
        return None, "no pitch stored (" + last_line(r.stderr)[:120] + ")"
    return 600.0 * math.log2(g / g0), ""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--struck", default=default_struck())
    ap.add_argument("--cache", default=os.environ.get("STRUCK_REC_CACHE", "/work/rec-cache"))
    ap.add_argument("--clips", help="every WAV in this folder instead of fetch.py's clips")
    ap.add_argument("--min-share", type=float)
    a = ap.parse_args()
    if a.clips:
        clips = sorted(glob.glob(os.path.join(a.clips, "*.wav")))
    else:
        manifest = load_manifest("ownpitch", a.cache, a.struck)
        clips = [os.path.join(a.cache, c["wav"]) for c in manifest["clips"] if "wav" in c]
    if not clips:
        sys.exit("ownpitch: no clips")
    ok = 0
    with tempfile.TemporaryDirectory() as work:
        for clip in clips:
            cents, why = own_pitch(a.struck, clip, work)
            good = cents is not None and abs(cents) <= 50.0
            ok += good
            shown = f"{cents:+9.1f} c" if cents is not None else "        —  "
            print(f"{os.path.basename(clip):50s} {shown}  {'' if good else 'OFF ' + why}")
    share = ok / len(clips)
    print(f"own banks fitted within 50 cents of their own pitch: {ok}/{len(clips)} ({100 * share:.1f} %)")
    if a.min_share is not None:
        want = a.min_share / 100 if a.min_share > 1 else a.min_share
        sys.exit(0 if share >= want else 1)


if __name__ == "__main__":
    main()
