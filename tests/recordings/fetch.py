#!/usr/bin/env python3
"""Fetch the real recordings of single struck objects used by validate.py.

Every clip comes from a Debian package (installed with apt-get when missing
and when run as root) and is cut out by this script's own readers
(sf2.py for SoundFont 2, gus_pat.py for GUS patches; FLAC via the PyPI
package soundfile). Output: mono 32-bit float WAV files at the source's own
rate in CACHE/clips/, and CACHE/manifest.json listing, for every clip, the
package and version, the file and sample it came from, its licence, category
and object, and whether it is used or excluded (and why).

Deterministic: the clip list below is fixed (chosen by instrument and key,
not by listening or by any analysis result), the cut is a fixed rule, and the
manifest records a SHA-256 of every written clip.

Cut rule, the same for every clip:
  * one channel: a mono sample, the left sample of a SoundFont stereo pair,
    or channel 0 of a stereo file;
  * start: the sample's own start (as the library trims it); only when the
    first sample reaching 1 % of the peak comes later than 5 ms is the lead-in
    cut to 1 ms before it;
  * end: the sample's end, or its loop start when the instrument plays it
    looped (what follows the loop start is the synthesiser's loop, not the
    recording), at most MAX_S seconds;
  * exclusion rules (decided before any result of Struck was seen): a clip
    shorter than MIN_S seconds after the cut (too short for a 0.5 s reference
    analysis), or one with more than MAX_CLIPPED samples at full scale
    (|x| >= 0.999: a clipped recording is not a sum of damped sinusoids), is
    listed in the manifest as excluded and not analysed.

Usage: python fetch.py [--cache DIR] [--no-install]
"""

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import gus_pat  # noqa: E402
import sf2  # noqa: E402
from subspace import write_wav_float  # noqa: E402

MIN_S = 0.25
MAX_S = 4.0
MAX_CLIPPED = 10

FLUID = "/usr/share/sounds/sf2/FluidR3_GM.sf2"
MSCORE = "/usr/share/sounds/sf2/MuseScore_General_Full.sf2"
SONICPI = "/usr/share/sonic-pi/samples"
FREEPATS = "/usr/share/midi/freepats"

PACKAGES = {
    "fluid-soundfont-gm": {"file": FLUID, "licence": "MIT (Frank Wen, Fluid R3 GM SoundFont)"},
    "musescore-general-soundfont-lossless": {
        "file": MSCORE,
        "licence": "MIT (MuseScore_General; Temple Blocks (c) 2002 Ethan Winer, part of it)"},
    "sonic-pi-samples": {"file": SONICPI + "/drum_cowbell.flac", "licence": "CC0 (freesound.org, see the package's README.md)"},
    "freepats": {"file": FREEPATS + "/Tone_000/009_Glockenspiel.pat", "licence": "GPL-2+ with the freepats exception"},
}


def _clips():
    c = []

    def sf(pkg, path, cat, obj, bank, prog, key, vel=127, expect=None):
        c.append({"category": cat, "object": obj, "package": pkg, "kind": "sf2", "path": path,
                  "bank": bank, "program": prog, "key": key, "velocity": vel, "expect": expect})

    F = "fluid-soundfont-gm"
    # metal
    for k in (79, 84, 91, 96, 103):
        sf(F, FLUID, "metal", "glockenspiel", 0, 9, k)
    for k in (59, 65, 71, 77, 83):
        sf(F, FLUID, "metal", "celesta", 0, 8, k)
    for k in (44, 50, 60, 64, 73):
        sf(F, FLUID, "metal", "music box", 0, 10, k)
    sf(F, FLUID, "metal", "vibraphone", 0, 11, 57)
    sf(F, FLUID, "metal", "vibraphone", 0, 11, 66)
    sf(F, FLUID, "metal", "tubular bell", 0, 14, 60)
    for k in (56, 65, 78):
        sf(F, FLUID, "metal", "kalimba", 0, 108, k)
    for k in (66, 72, 78, 84):
        sf(F, FLUID, "metal", "steel drum", 0, 114, k)
    sf(F, FLUID, "metal", "tinkle bell", 0, 112, 100)
    sf(F, FLUID, "metal", "cowbell", 128, 0, 56)
    sf(F, FLUID, "metal", "agogo high", 128, 0, 67)
    sf(F, FLUID, "metal", "agogo low", 128, 0, 68)
    sf(F, FLUID, "metal", "triangle", 128, 0, 81)
    sf(F, FLUID, "metal", "ride cymbal bell", 128, 0, 53)
    # wood
    for k in (53, 65, 71, 77, 83, 100):
        sf(F, FLUID, "wood", "marimba", 0, 12, k)
    for k in (59, 65, 71, 77, 83, 89, 95, 101):
        sf(F, FLUID, "wood", "xylophone", 0, 13, k)
    sf(F, FLUID, "wood", "woodblock high", 128, 0, 76)
    sf(F, FLUID, "wood", "woodblock low", 128, 0, 77)
    sf(F, FLUID, "wood", "claves", 128, 0, 75)
    # membrane
    for k in (36, 42, 50):
        sf(F, FLUID, "membrane", "timpani", 0, 47, k)
    for k in (41, 43, 45, 47, 48, 50):
        sf(F, FLUID, "membrane", "tom", 128, 0, k)
    sf(F, FLUID, "membrane", "taiko", 0, 116, 60)

    M = "musescore-general-soundfont-lossless"
    for k in (58, 59, 60, 61, 62):
        sf(M, MSCORE, "wood", "temple block", 1, 115, k, 127)
    sf(M, MSCORE, "wood", "castanets", 8, 115, 60)

    S = "sonic-pi-samples"
    for name, cat, obj in (("drum_cowbell", "metal", "cowbell"), ("perc_bell", "metal", "bell"),
                           ("perc_bell2", "metal", "bell"), ("perc_till", "metal", "till bell"),
                           ("drum_tom_hi_hard", "membrane", "tom"), ("drum_tom_mid_hard", "membrane", "tom"),
                           ("drum_tom_lo_hard", "membrane", "tom"), ("tabla_na", "membrane", "tabla"),
                           ("tabla_tun1", "membrane", "tabla"), ("tabla_tas1", "membrane", "tabla")):
        c.append({"category": cat, "object": obj, "package": S, "kind": "flac",
                  "path": f"{SONICPI}/{name}.flac", "sample": name})

    P = "freepats"
    for rel, idx, cat, obj in (("Tone_000/008_Celesta.pat", 0, "metal", "celesta"),
                               ("Tone_000/008_Celesta.pat", 1, "metal", "celesta"),
                               ("Tone_000/009_Glockenspiel.pat", 0, "metal", "glockenspiel"),
                               ("Tone_000/009_Glockenspiel.pat", 2, "metal", "glockenspiel"),
                               ("Tone_000/009_Glockenspiel.pat", 4, "metal", "glockenspiel"),
                               ("Tone_000/014_Tubular_Bells.pat", 0, "metal", "tubular bell"),
                               ("Tone_000/114_Steel_Drums.pat", 1, "metal", "steel drum"),
                               ("Tone_000/114_Steel_Drums.pat", 2, "metal", "steel drum"),
                               ("Drum_000/056_Cow_Bell.pat", 0, "metal", "cowbell"),
                               ("Drum_000/081_Triangle_2_Open.pat", 0, "metal", "triangle"),
                               ("Tone_000/013_Xylophone.pat", 0, "wood", "marimba"),
                               ("Tone_000/013_Xylophone.pat", 3, "wood", "marimba"),
                               ("Tone_000/013_Xylophone.pat", 4, "wood", "xylophone"),
                               ("Tone_000/013_Xylophone.pat", 7, "wood", "xylophone"),
                               ("Tone_000/013_Xylophone.pat", 9, "wood", "xylophone"),
                               ("Tone_000/115_Wood_Block.pat", 0, "wood", "woodblock"),
                               ("Tone_000/047_Timpani.pat", 0, "membrane", "timpani")):
        c.append({"category": cat, "object": obj, "package": P, "kind": "pat",
                  "path": f"{FREEPATS}/{rel}", "index": idx})
    return c


CLIPS = _clips()


def ensure_packages(install):
    missing = [p for p, v in PACKAGES.items() if not os.path.exists(v["file"])]
    if not missing:
        return
    cmd = ["apt-get", "install", "-y", "--no-install-recommends"] + missing
    if not install or os.geteuid() != 0 or shutil.which("apt-get") is None:
        sys.exit("fetch.py: missing packages; run as root: apt-get update && " + " ".join(cmd))
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    if subprocess.run(cmd, env=env).returncode != 0:
        subprocess.run(["apt-get", "update"], env=env, check=True)
        subprocess.run(cmd, env=env, check=True)


def pkg_version(pkg):
    try:
        out = subprocess.run(["dpkg-query", "-W", "-f=${Version}", pkg], capture_output=True, text=True)
        return out.stdout.strip() or None
    except OSError:
        return None


def load_sf2(c, cache={}):
    if c["path"] not in cache:
        cache[c["path"]] = sf2.SoundFont(c["path"])
    f = cache[c["path"]]
    name, zones = f.preset_zones(c["bank"], c["program"])
    cand = [z for z in zones if z.key[0] <= c["key"] <= z.key[1] and z.vel[0] <= c["velocity"] <= z.vel[1]]
    # a mono sample (type 1) or the left one of a pair (type 4); never the right
    cand = [z for z in cand if f.samples[z.sample_id].type in (1, 4)]
    if not cand:
        raise RuntimeError(f"no sample for {c}")
    z = cand[0]
    s = f.samples[z.sample_id]
    x, loop = f.sample_data(s, z)
    return x, s.rate, {"preset": f"{c['bank']}:{c['program']} {name}", "instrument": z.instrument,
                       "sample": s.name}, loop


def load_flac(c):
    import soundfile
    x, fs = soundfile.read(c["path"], dtype="float64", always_2d=True)
    return x[:, 0], fs, {"sample": c["sample"], "channels": x.shape[1]}, None


def load_pat(c):
    s = gus_pat.read_pat(c["path"])[c["index"]]
    loop = s.loop_start if s.looping and 0 < s.loop_start < len(s.data) else None
    return s.data, s.rate, {"sample": f"#{c['index']} '{s.name}' root {s.root_hz:.1f} Hz"}, loop


def cut(x, fs, loop):
    """The cut rule of the module docstring. Returns (clip, start, end, notes)."""
    notes = []
    end = len(x)
    if loop is not None:
        end = min(end, loop)
        notes.append("truncated at loop start")
    end = min(end, int(MAX_S * fs))
    peak = np.max(np.abs(x[:end])) if end > 0 else 0.0
    start = 0
    if peak > 0:
        first = int(np.argmax(np.abs(x[:end]) >= 0.01 * peak))
        if first > 0.005 * fs:
            start = max(0, first - int(0.001 * fs))
            notes.append(f"lead-in of {1000 * first / fs:.1f} ms cut")
    return x[start:end], start, end, notes


def main():
    ap = argparse.ArgumentParser(description="Fetch real struck-object recordings for validate.py")
    ap.add_argument("--cache", default=os.environ.get("STRUCK_REC_CACHE", "/work/rec-cache"))
    ap.add_argument("--no-install", action="store_true", help="never call apt-get")
    a = ap.parse_args()
    t0 = time.time()
    ensure_packages(not a.no_install)
    clipdir = os.path.join(a.cache, "clips")
    os.makedirs(clipdir, exist_ok=True)
    manifest = []
    used = 0
    for c in CLIPS:
        loader = {"sf2": load_sf2, "flac": load_flac, "pat": load_pat}[c["kind"]]
        x, fs, info, loop = loader(c)
        clip, start, end, notes = cut(x, fs, loop)
        obj = c["object"].replace(" ", "-")
        src = {"fluid-soundfont-gm": "fluid", "musescore-general-soundfont-lossless": "msgen",
               "sonic-pi-samples": "sonicpi", "freepats": "freepats"}[c["package"]]
        tag = c.get("key", c.get("index", c.get("sample")))
        cid = f"{c['category']}-{obj}-{src}-{tag}"
        rec = {"id": cid, "category": c["category"], "object": c["object"], "package": c["package"],
               "version": pkg_version(c["package"]), "licence": PACKAGES[c["package"]]["licence"],
               "source_file": c["path"], **info, "sample_rate": int(fs),
               "source_samples": len(x), "cut": [int(start), int(end)], "duration_s": round(len(clip) / fs, 4),
               "peak": round(float(np.max(np.abs(clip))) if len(clip) else 0.0, 4),
               "full_scale_samples": int(np.sum(np.abs(clip) >= 0.999)), "notes": notes}
        if "key" in c:
            rec["key"] = c["key"]
            rec["velocity"] = c["velocity"]
        if len(clip) < MIN_S * fs:
            rec["excluded"] = f"shorter than {MIN_S} s after the cut"
        elif rec["full_scale_samples"] > MAX_CLIPPED:
            rec["excluded"] = f"clipped ({rec['full_scale_samples']} samples at full scale)"
        else:
            path = os.path.join(clipdir, cid + ".wav")
            write_wav_float(path, clip, fs)
            with open(path, "rb") as f:
                rec["sha256"] = hashlib.sha256(f.read()).hexdigest()
            rec["wav"] = os.path.relpath(path, a.cache)
            used += 1
        manifest.append(rec)
    for old in os.listdir(clipdir):
        if old.endswith(".wav") and old[:-4] not in {m["id"] for m in manifest if "wav" in m}:
            os.remove(os.path.join(clipdir, old))
    with open(os.path.join(a.cache, "manifest.json"), "w") as f:
        json.dump({"clips": manifest, "min_s": MIN_S, "max_s": MAX_S, "max_clipped": MAX_CLIPPED}, f, indent=1)
    excl = [m for m in manifest if "excluded" in m]
    print(f"fetch: {used} clips written to {clipdir}, {len(excl)} excluded "
          f"({', '.join(m['id'] for m in excl)}), {time.time() - t0:.1f} s")


if __name__ == "__main__":
    main()
