#!/usr/bin/env python3
"""`struck bank capture` on real clips: does the captured bank start at the note?

A bank captured from a recording (`struck bank capture`, the recording's own modes) is
played with keys tuning its lowest mode, so that mode must be the object's fundamental,
not the mallet's thump or the room's rumble under it. For every clip of a tuned
instrument whose sample states its pitch, this captures a bank with the command's
defaults and compares the bank's lowest mode with the sample's nominal pitch:

  * FluidR3 (SoundFont 2): the sample's root key as the SoundFont plays it (the zone's
    overriding root key, else the sample's original pitch, less its coarse and fine
    tuning and the sample's pitch correction), read here from the SoundFont with sf2.py;
  * FreePats (GUS patches): the patch's root frequency, as fetch.py put it in the
    manifest ("root 523.2 Hz").

Nothing of the reference analysis or of Struck's is used for the truth. Tubular bells are
left out: their strike note is a virtual pitch, with no partial at it.

Reported: per clip, the bank's lowest mode, its distance to the note in semitones, and the
share within a semitone (`--min-share X` exits 1 below X, a share or a percentage).

Usage: python capture.py [--struck PATH] [--cache DIR] [--min-share X] [-- OPTIONS...]
Options after `--` are passed to `struck bank capture` (e.g. `-- --min-q 0 --below-db 200`,
every partial within 40 dB as before stop 41).
"""

import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import sf2  # noqa: E402
from validate import default_struck  # noqa: E402

TUNED = ("glockenspiel", "celesta", "music box", "vibraphone", "kalimba", "steel drum", "marimba", "xylophone")


def sf2_root_hz(clip, fonts={}):
    """The pitch the SoundFont says this clip's sample has (as fetch.py chose the zone)."""
    path = clip["source_file"]
    if path not in fonts:
        fonts[path] = sf2.SoundFont(path)
    f = fonts[path]
    bank, prog = map(int, clip["preset"].split()[0].split(":"))
    _, zones = f.preset_zones(bank, prog)
    z = next(z for z in zones
             if z.key[0] <= clip["key"] <= z.key[1] and z.vel[0] <= clip["velocity"] <= z.vel[1]
             and f.samples[z.sample_id].type in (1, 4))
    s = f.samples[z.sample_id]
    root = z.gens.get(sf2.GEN_ROOTKEY, s.pitch)
    corr = s.corr - 256 if s.corr > 127 else s.corr
    midi = root - (z.signed(51) + (z.signed(52) + corr) / 100.0)  # coarseTune 51, fineTune 52
    return 440.0 * 2 ** ((midi - 69) / 12)


def nominal_hz(clip):
    m = re.search(r"root ([0-9.]+) Hz", clip.get("sample", ""))
    if m:
        return float(m.group(1))
    if clip.get("source_file", "").endswith(".sf2") and "preset" in clip:
        return sf2_root_hz(clip)
    return None


def main():
    argv = sys.argv[1:]
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    ap = argparse.ArgumentParser(description="bank capture on real clips: the lowest mode vs the sample's note")
    ap.add_argument("--struck", default=default_struck())
    ap.add_argument("--cache", default=os.environ.get("STRUCK_REC_CACHE", "/work/rec-cache"))
    ap.add_argument("--min-share", type=float, default=None)
    ap.add_argument("--json", dest="json_out")
    a = ap.parse_args(argv)
    with open(os.path.join(a.cache, "manifest.json")) as f:
        clips = [c for c in json.load(f)["clips"] if "wav" in c and c["object"] in TUNED]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "bank.json")
        for c in clips:
            note = nominal_hz(c)
            if note is None:
                continue
            if os.path.exists(out):
                os.remove(out)
            p = subprocess.run([a.struck, "bank", "capture", os.path.join(a.cache, c["wav"]), "--out", out, *extra],
                               capture_output=True, text=True)
            if p.returncode != 0:
                rows.append({"clip": c["id"], "note_hz": note, "error": (p.stderr.strip().splitlines() or ["?"])[-1]})
                print(f"{c['id']:36s} note {note:8.1f} Hz  FAILED: {rows[-1]['error']}")
                continue
            with open(out) as f:
                bank = json.load(f)
            low = math.sqrt(bank["lambdas"][0]) / (2 * math.pi)
            st = 12 * math.log2(low / note)
            rows.append({"clip": c["id"], "note_hz": note, "lowest_hz": low, "semitones": st,
                         "modes": len(bank["lambdas"])})
            print(f"{c['id']:36s} note {note:8.1f} Hz  lowest mode {low:8.1f} Hz  {st:+7.2f} st  "
                  f"{'ok' if abs(st) <= 1 else 'OFF'}  ({len(bank['lambdas'])} modes)")
    good = sum(1 for r in rows if abs(r.get("semitones", 99)) <= 1)
    share = good / len(rows) if rows else 0.0
    print(f"lowest mode within a semitone of the note: {good}/{len(rows)} ({100 * share:.0f} %)")
    if a.json_out:
        with open(a.json_out, "w") as f:
            json.dump({"clips": rows, "within_semitone": good, "of": len(rows)}, f, indent=1)
    if a.min_share is not None:
        want = a.min_share / 100 if a.min_share > 1 else a.min_share
        if share < want:
            print(f"capture: share {share:.2f} below {want:.2f}")
            sys.exit(1)


if __name__ == "__main__":
    main()
