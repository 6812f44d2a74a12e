#!/usr/bin/env python3
"""End to end on real clips: capture a material per instrument, then compare
the decay it gives the recording's own strong partials with the recording.

For every instrument (the clips fetch.py took from one package for one
object, e.g. FluidR3's glockenspiel: 5 strikes on 5 bars), `struck estimate`
captures one material from all its clips. For each clip's 5 strongest
reference partials (subspace.py), the material's damping law gives
d = c(lambda)/2 at lambda = (2 pi f)^2 + d_ref^2 (the recording's own modes,
as the issue's "or on the recording's own modes" allows); T60 = ln(1000)/d.
Reported: the ratio T60(material) / T60(recording) per partial, its median
per instrument and overall, and the share within 25 %.

With --render, each instrument's first clip is also played through the
plugin (`struck render`) on a bank made of that clip's own reference partials
(keys do not tune, gamma = size = 1, so the modes sound at the recorded
frequencies), the render is analysed by subspace.py, and its T60s are
compared with the recording's; this checks that the render path gives what
the law predicts.

Usage: python e2e.py [--struck PATH] [--cache DIR] [--model M] [--method M]
                     [--render] [--json OUT]
"""

import argparse
import json
import math
import os
import re
import struct
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import subspace  # noqa: E402
from validate import default_struck, reference_for  # noqa: E402

LN1000 = math.log(1000.0)


def c_of_lambda(damping, lam):
    m, p = damping["model"], damping["params"]
    if m == "rayleigh":
        return p[0] + p[1] * lam
    if m == "power":
        return p[0] * lam ** p[1]
    if m == "hybrid":
        return p[0] + p[1] * lam ** p[2]
    if m == "caughey":
        return sum(a * lam ** j for j, a in enumerate(p))
    raise ValueError(f"unknown damping model {m}")


MASK = (1 << 64) - 1


def support_quantile(m, lam):
    """Mode m's fixed unit-exponential draw, as dsp::engine::support_quantile computes it
    (SplitMix64 of the mode index and the bank eigenvalue's f32 bits), so the law path
    predicts what the plugin plays on the render check's bank."""
    key = ((m << 32) ^ struct.unpack("<I", struct.pack("<f", lam))[0]) & MASK
    z = ((key + 1) * 0x9E3779B97F4A7C15) & MASK
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    u = ((z ^ (z >> 31)) >> 11) / float(1 << 53)
    return -math.log(1.0 - u)


def median(v):
    v = sorted(v)
    if not v:
        return None
    n = len(v)
    return v[n // 2] if n % 2 else math.sqrt(v[n // 2 - 1] * v[n // 2])


def render_partials(struck, obj, mat_path, tmp, sets):
    """Key 60 struck once on `obj` with the material, 3 s at 48 kHz, keys not tuning, γ and
    size 1, no noise, every mode rung, plus `sets` (`--set id=value`); the render's partials
    (subspace.py) and None, or None and the error's last line."""
    out = os.path.join(tmp, "render.wav")
    cmd = [struck, "render", "--object", obj, "--material", mat_path, "--notes", "60:100",
           "--seconds", "3", "--sample-rate", "48000", "--out", out]
    for kv in ["keytune=0", "gamma=1", "size=1", "noise=0", "quality=120", "pressdamp=0", "release=0",
               "hard=1", *sets]:
        cmd += ["--set", kv]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        return None, (p.stderr.strip().splitlines() or ["?"])[-1]
    x, fs = subspace.read_wav(out)
    return subspace.analyse(x, fs), None


def render_check(struck, mat_path, clip, ref, tmp):
    """Render the clip's own partials with the material; T60 ratios render/recording."""
    parts = ref["partials"]
    lambdas = [(2 * math.pi * p["freq_hz"]) ** 2 for p in parts]
    order = sorted(range(len(parts)), key=lambda i: lambdas[i])
    bank = {
        "schema_version": 1, "id": "recorded-modes", "name": "Recorded modes",
        "description": f"the 5 strongest partials of {clip['id']} (validation only)",
        "provenance": "tests/recordings/e2e.py from subspace.py's reference",
        "reference": {"specific_modulus": 1.0, "poisson": 0.3, "density": 1000.0,
                      "dimensions_m": [1.0, 0.1, 0.1], "size_m": 1.0},
        "lambdas": [lambdas[i] for i in order],
        "points": [{"label": "p", "xy": [0.5, 0.5], "position_m": [0.5, 0.05, 0.1]}],
        "gains": [[float(parts[i]["amplitude"] / max(q["amplitude"] for q in parts)) for i in order]],
        "mode_labels": [f"{parts[i]['freq_hz']:.1f} Hz" for i in order],
    }
    bpath = os.path.join(tmp, "bank.json")
    with open(bpath, "w") as f:
        json.dump(bank, f)
    # Without the residual layer (issue 15, on by default since stop 23): the material carries
    # the first clip's residual (its attack, e.g. the glockenspiel's 3.7-4.1 kHz in its first
    # 0.1 s), which is not the law's and made subspace.py's 0.5 s window see a partial at
    # 4160 Hz decay at 0.86 s^-1 where the plugin plays 0.44 (the render median 0.94 -> 1.26).
    got, error = render_partials(struck, bpath, mat_path, tmp, ["matpitch=0", "residual=0"])
    if error:
        return {"error": error}
    rows = []
    for q in parts:
        m = [g for g in got if abs(g["freq_hz"] - q["freq_hz"]) <= 0.005 * q["freq_hz"]]
        if not m:
            rows.append({"freq_hz": q["freq_hz"], "rendered": False})
            continue
        g = max(m, key=lambda g: g["amplitude"])
        rows.append({"freq_hz": q["freq_hz"], "rendered": True, "decay_render": g["decay_per_s"],
                     "t60_ratio": q["decay_per_s"] / g["decay_per_s"]})
    return {"partials": rows}


# Instruments with a factory object of their own (issue 10 part 6: "rendered on the matched
# object"): each clip is captured with `--object`, so its support is recorded mode by mode.
OBJECTS = {
    "tubular bell": "fem-tubular-chime",
    "glockenspiel": "fem-glockenspiel-bar",
    "marimba": "fem-marimba-bar",
    "xylophone": "fem-xylophone-bar",
    "vibraphone": "fem-vibraphone-bar",
}


# Bars whose lowest partial is their note: the pitch fit is also checked against the
# sample's nominal pitch.
TUNED_BARS = ("marimba", "xylophone", "vibraphone")
PITCH_CLASS = {"C": 0, "D": 2, "E": 4, "F": 5, "G": 7, "A": 9, "B": 11}


def nominal_hz(clip):
    """The sample's nominal pitch: a patch's root (freepats: "#4 'Xylo C3' root 523.2 Hz") or
    a SoundFont sample's name ("Marimba F# 6(L)": FluidR3 names middle C "C 5", so F# 6 is
    MIDI 78, 740 Hz); None if neither."""
    s = clip.get("sample", "")
    m = re.search(r"root ([0-9.]+) Hz", s)
    if m:
        return float(m.group(1))
    m = re.search(r"([A-G])(#?) ?(\d)", s)
    if not m:
        return None
    midi = 12 * int(m.group(3)) + PITCH_CLASS[m.group(1)] + (1 if m.group(2) else 0)
    return 440.0 * 2 ** ((midi - 69) / 12)


def own_modes_bank(struck, clip, cache, tmp, top=24):
    """A bank of the clip's own modes as Struck extracts them (`struck bank capture`: the
    first impact's strongest partials, at most `top`, within 30 dB of the strongest, at one
    strike point with gains = amplitudes): the issue's "or on the recording's own modes",
    with nothing from the reference analysis."""
    path = os.path.join(tmp, "own-bank.json")
    if os.path.exists(path):
        os.remove(path)
    p = subprocess.run([struck, "bank", "capture", os.path.join(cache, clip["wav"]), "--modes", str(top),
                        "--range-db", "30", "--id", "own-modes", "--out", path], capture_output=True, text=True)
    return path if p.returncode == 0 and os.path.exists(path) else None


def object_check(struck, clip, obj, ref, cache, tmp):
    """One clip captured with --object OBJ and rendered on OBJ at the recorded pitch, three
    ways: support as recorded mode by mode (the material as written), the mean's draws only
    (the per-mode record taken out) and the free material. Each of the clip's reference
    partials is looked for in each render (subspace.py, within 0.5 %); T60 ratios
    render/recording, one per reference partial (None where that render does not hold it)."""
    mat = os.path.join(tmp, "obj-mat.json")
    rep = os.path.join(tmp, "obj-rep.json")
    for pth in (mat, rep):
        if os.path.exists(pth):
            os.remove(pth)
    p = subprocess.run([struck, "estimate", os.path.join(cache, clip["wav"]), "--object", obj, "--out", mat,
                        "--report", rep, "--no-residual"], capture_output=True, text=True)
    if p.returncode != 0 or not os.path.exists(mat):
        return {"error": (p.stderr.strip().splitlines() or ["?"])[-1]}
    with open(mat) as f:
        material = json.load(f)
    # The pitch fit (issue 10 part 5's target: the object's lowest mode within a semitone of
    # the recording's lowest strong partial): the object's lowest mode at the fitted gamma
    # against the lowest of the reference's 5 strongest partials (subspace.py, not Struck's
    # own features), against the recording's lowest strong partial as subspace.py defines it
    # (the lowest of all its partials within 20 dB of the strongest at the window start; within
    # 30 dB, for information), against the lowest partial the match itself used and, for tuned
    # bars, against the sample's nominal pitch.
    pitch = {}
    if os.path.exists(rep):
        with open(rep) as f:
            match = json.load(f).get("object") or {}
        low_obj = match.get("object_lowest_hz")
        low_ref = min(q["freq_hz"] for q in ref["partials"]) if ref["partials"] else None
        if low_obj and low_ref:
            pitch = {"object_lowest_hz": low_obj, "reference_lowest_hz": low_ref,
                     "cents_vs_reference": 1200 * math.log2(low_obj / low_ref)}
            for key, suffix in (("lowest_strong", ""), ("lowest_strong_30db", "_30db")):
                ls = ref.get(key)
                if ls:
                    pitch[f"reference_lowest_strong{suffix}_hz"] = ls["freq_hz"]
                    pitch[f"reference_lowest_strong{suffix}_db"] = ls["amplitude_db_re_strongest"]
                    pitch[f"cents_vs_lowest_strong{suffix}"] = 1200 * math.log2(low_obj / ls["freq_hz"])
            if match.get("lowest_partial_hz"):
                pitch["cents_vs_match"] = 1200 * math.log2(low_obj / match["lowest_partial_hz"])
            nominal = nominal_hz(clip) if clip["object"] in TUNED_BARS else None
            if nominal:
                pitch["nominal_hz"] = nominal
                pitch["cents_vs_nominal"] = 1200 * math.log2(low_obj / nominal)
    recorded = ((material.get("support") or {}).get("recorded_modes") or {}).get("modes", [])
    mean_only = json.loads(json.dumps(material))
    if mean_only.get("support"):
        mean_only["support"].pop("recorded_modes", None)
    mean_path = os.path.join(tmp, "obj-mat-mean.json")
    with open(mean_path, "w") as f:
        json.dump(mean_only, f)
    out = {"object": obj, "recorded_modes": len(recorded), "pitch": pitch}
    for label, path, extra in (("recorded", mat, []), ("mean", mean_path, []), ("free", mat, ["support=0"])):
        got, error = render_partials(struck, obj, path, tmp, ["matpitch=1", *extra])
        if error:
            return {"error": error}
        ratios = []
        for q in ref["partials"]:
            m = [g for g in got if abs(g["freq_hz"] - q["freq_hz"]) <= 0.005 * q["freq_hz"]]
            if m:
                g = max(m, key=lambda g: g["amplitude"])
                ratios.append(q["decay_per_s"] / g["decay_per_s"] if g["decay_per_s"] > 0 else float("inf"))
            else:
                ratios.append(None)
        out[label] = ratios
    return out


def main():
    ap = argparse.ArgumentParser(description="End to end: captured material vs the recording's decays")
    ap.add_argument("--struck", default=default_struck())
    ap.add_argument("--cache", default=os.environ.get("STRUCK_REC_CACHE", "/work/rec-cache"))
    ap.add_argument("--model", default=None)
    ap.add_argument("--method", default=None)
    ap.add_argument("--render", action="store_true")
    ap.add_argument("--objects", action="store_true",
                    help="also capture each clip of an instrument with a factory object of its own on that object "
                         "and compare renders there (support as recorded mode by mode, the mean only, free)")
    ap.add_argument("--own-modes", action="store_true",
                    help="with --objects: every clip on a bank of its own modes (`struck bank capture`), "
                         "instead of the instruments' factory objects")
    ap.add_argument("--json", dest="json_out")
    a = ap.parse_args()
    a.objects = a.objects or a.own_modes
    with open(os.path.join(a.cache, "manifest.json")) as f:
        clips = [c for c in json.load(f)["clips"] if "wav" in c]
    groups = {}
    for c in clips:
        groups.setdefault((c["package"], c["object"]), []).append(c)
    t0 = time.time()
    results = []
    all_ratios = []
    all_free = []
    render_ratios = []
    with tempfile.TemporaryDirectory() as tmp:
        for (pkg, obj), cs in groups.items():
            name = f"{obj} ({pkg})"
            mat = os.path.join(tmp, "mat.json")
            rep = os.path.join(tmp, "rep.json")
            for pth in (mat, rep):
                if os.path.exists(pth):
                    os.remove(pth)
            cmd = [a.struck, "estimate", *[os.path.join(a.cache, c["wav"]) for c in cs], "--out", mat,
                   "--report", rep]
            if a.model:
                cmd += ["--model", a.model]
            if a.method:
                cmd += ["--method", a.method]
            p = subprocess.run(cmd, capture_output=True, text=True)
            res = {"instrument": name, "category": cs[0]["category"], "clips": len(cs)}
            if p.returncode != 0 or not os.path.exists(mat):
                res["error"] = (p.stderr.strip().splitlines() or ["?"])[-1]
                results.append(res)
                print(f"{name:40s} {len(cs)} clips  ESTIMATE FAILED: {res['error']}")
                continue
            with open(mat) as f:
                material = json.load(f)
            warnings = []
            if os.path.exists(rep):
                with open(rep) as f:
                    warnings = json.load(f).get("warnings", [])
            damping = material["damping"]
            support = (material.get("support") or {}).get("mean_c_per_s", 0.0)
            ratios, free_ratios = [], []
            for c in cs:
                ref = reference_for(c, a.cache)
                # Mode index k as in render_check's bank (partials by frequency): the plugin
                # adds support × support_quantile(k) to c (Support: As recorded, the default).
                by_f = sorted(range(len(ref["partials"])), key=lambda i: ref["partials"][i]["freq_hz"])
                k_of = {i: k for k, i in enumerate(by_f)}
                for i, q in enumerate(ref["partials"]):
                    lam = (2 * math.pi * q["freq_hz"]) ** 2 + q["decay_per_s"] ** 2
                    c_free = c_of_lambda(damping, lam)
                    lam_bank = (2 * math.pi * q["freq_hz"]) ** 2
                    draw = support_quantile(k_of[i], lam_bank)
                    for out, cc in ((free_ratios, c_free), (ratios, c_free + support * draw)):
                        # T60(material) / T60(recording) = d_recording / d_material.
                        out.append(float("inf") if cc <= 0 else q["decay_per_s"] / (cc / 2))
            all_ratios += ratios
            all_free += free_ratios
            res.update({"damping": damping, "support_mean_c_per_s": support, "warnings": warnings,
                        "t60_ratios": ratios, "median_t60_ratio": median(ratios),
                        "median_t60_ratio_free": median(free_ratios),
                        "within_25": sum(abs(r - 1) <= 0.25 for r in ratios) / len(ratios)})
            line = (f"{name:40s} {len(cs)} clips  {damping['model']} {['%.4g' % v for v in damping['params']]}"
                    f" support {support:.3g}"
                    f"  T60 material/recording median {res['median_t60_ratio']:.2f} (free {res['median_t60_ratio_free']:.2f})"
                    f" (within 25 %: {100 * res['within_25']:.0f} %)  warnings {len(warnings)}")
            if a.render:
                rc = render_check(a.struck, mat, cs[0], reference_for(cs[0], a.cache), tmp)
                res["render"] = rc
                if "error" in rc:
                    line += f"  render FAILED: {rc['error']}"
                else:
                    rr = [r["t60_ratio"] for r in rc["partials"] if r["rendered"]]
                    render_ratios += rr
                    line += f"  rendered: median {median(rr):.2f} ({len(rr)}/{len(rc['partials'])} partials)" if rr \
                        else "  rendered: no partial found"
            print(line)
            results.append(res)
        object_rows = []
        if a.objects:
            print()
            for c in clips:
                obj = OBJECTS.get(c["object"])
                if a.own_modes:
                    obj = own_modes_bank(a.struck, c, a.cache, tmp)
                if not obj:
                    continue
                oc = object_check(a.struck, c, obj, reference_for(c, a.cache), a.cache, tmp)
                oc["clip"] = c["id"]
                if a.own_modes:
                    obj = "its own modes"
                object_rows.append(oc)
                if "error" in oc:
                    print(f"{c['id']:40s} on {obj}: FAILED: {oc['error']}")
                    continue
                parts = []
                for label in ("recorded", "mean", "free"):
                    r = [v for v in oc[label] if v is not None]
                    w = sum(abs(v - 1) <= 0.25 for v in r)
                    parts.append(f"{label} {w}/{len(r)} within 25 %" + (f" (median {median(r):.2f})" if r else ""))
                pc = oc["pitch"].get("cents_vs_reference")
                if pc is not None:
                    parts.append(f"lowest mode {pc:+.0f} cents from the lowest of the 5 strongest partials")
                for suffix, db in (("", 20), ("_30db", 30)):
                    pc = oc["pitch"].get(f"cents_vs_lowest_strong{suffix}")
                    if pc is not None:
                        parts.append(f"{pc:+.0f} cents from the lowest partial within {db} dB "
                                     f"({oc['pitch'][f'reference_lowest_strong{suffix}_hz']:.1f} Hz)")
                print(f"{c['id']:40s} on {obj} ({oc['recorded_modes']} modes recorded): " + "; ".join(parts))

    fin = [r for r in all_ratios if math.isfinite(r)]
    summary = {"instruments": len(results), "failed": sum("error" in r for r in results),
               "partials": len(all_ratios), "median_t60_ratio": median(fin),
               "median_t60_ratio_free": median([r for r in all_free if math.isfinite(r)]),
               "within_25_free": sum(abs(r - 1) <= 0.25 for r in all_free) / max(1, len(all_free)),
               "within_25": sum(abs(r - 1) <= 0.25 for r in all_ratios) / max(1, len(all_ratios)),
               "longer_than_recording": sum(r > 1 for r in all_ratios) / max(1, len(all_ratios))}
    if render_ratios:
        summary["render_median_t60_ratio"] = median(render_ratios)
    ok_rows = [r for r in object_rows if "error" not in r]
    if ok_rows:
        # Compared on one set: the reference partials every one of the three renders holds.
        common = [(r, i) for r in ok_rows for i in range(len(r["recorded"]))
                  if all(r[label][i] is not None for label in ("recorded", "mean", "free"))]
        for label in ("recorded", "mean", "free"):
            allr = [r[label][i] for r, i in common]
            summary[f"objects_{label}_within_25"] = sum(abs(v - 1) <= 0.25 for v in allr) / max(1, len(allr))
            summary[f"objects_{label}_median_t60_ratio"] = median([v for v in allr if math.isfinite(v)])
            summary[f"objects_{label}_partials"] = len(allr)
        cents = [r["pitch"]["cents_vs_reference"] for r in ok_rows if "cents_vs_reference" in r["pitch"]]
        if cents:
            summary["objects_pitch_clips"] = len(cents)
            summary["objects_pitch_within_semitone"] = sum(abs(v) <= 100 for v in cents) / len(cents)
            summary["objects_pitch_median_abs_cents"] = sorted(abs(v) for v in cents)[len(cents) // 2]
        for suffix in ("", "_30db"):
            cents = [r["pitch"][f"cents_vs_lowest_strong{suffix}"] for r in ok_rows
                     if f"cents_vs_lowest_strong{suffix}" in r["pitch"]]
            if cents:
                summary[f"objects_pitch_clips_lowest_strong{suffix}"] = len(cents)
                summary[f"objects_pitch_within_semitone_lowest_strong{suffix}"] = \
                    sum(abs(v) <= 100 for v in cents) / len(cents)
                summary[f"objects_pitch_median_abs_cents_lowest_strong{suffix}"] = \
                    sorted(abs(v) for v in cents)[len(cents) // 2]
        nominal = [r["pitch"]["cents_vs_nominal"] for r in ok_rows if "cents_vs_nominal" in r["pitch"]]
        if nominal:
            summary["objects_pitch_tuned_bars"] = len(nominal)
            summary["objects_pitch_tuned_within_semitone"] = sum(abs(v) <= 100 for v in nominal) / len(nominal)
        summary["objects_reference_partials"] = sum(len(reference_for(c, a.cache)["partials"]) for c in clips
                                                    if a.own_modes or OBJECTS.get(c["object"]))
        summary["objects_failed"] = sum("error" in r for r in object_rows)
    print()
    print(f"e2e: {summary['instruments']} instruments ({summary['failed']} failed), {summary['partials']} partials; "
          f"T60 material (support as recorded)/recording median {summary['median_t60_ratio']:.2f}, within 25 %: "
          f"{100 * summary['within_25']:.1f} %, longer than recorded: {100 * summary['longer_than_recording']:.0f} %; "
          f"free material median {summary['median_t60_ratio_free']:.2f}, within 25 %: {100 * summary['within_25_free']:.1f} %"
          + (f"; rendered median {summary['render_median_t60_ratio']:.2f}" if render_ratios else "")
          + f"; {time.time() - t0:.1f} s")
    if ok_rows:
        print("on their own objects (" + f"{len(ok_rows)} clips, {summary['objects_failed']} failed; "
              + f"{summary['objects_reference_partials']} reference partials, "
              + f"{summary['objects_recorded_partials']} found in all three renders): "
              + "; ".join(f"{label}: "
                          f"{100 * summary[f'objects_{label}_within_25']:.1f} % within 25 %, median "
                          f"{summary[f'objects_{label}_median_t60_ratio']:.2f}" for label in ("recorded", "mean", "free"))
              + (f"; object's lowest mode within a semitone of the lowest of the 5 strongest partials on "
                 f"{summary['objects_pitch_within_semitone'] * summary['objects_pitch_clips']:.0f}/"
                 f"{summary['objects_pitch_clips']} clips (median {summary['objects_pitch_median_abs_cents']:.0f} cents)"
                 if "objects_pitch_clips" in summary else "")
              + "".join(f"; of the lowest partial within {db} dB of the strongest on "
                        f"{summary[f'objects_pitch_within_semitone_lowest_strong{sx}'] * summary[f'objects_pitch_clips_lowest_strong{sx}']:.0f}/"
                        f"{summary[f'objects_pitch_clips_lowest_strong{sx}']} (median "
                        f"{summary[f'objects_pitch_median_abs_cents_lowest_strong{sx}']:.0f} cents)"
                        for sx, db in (("", 20), ("_30db", 30)) if f"objects_pitch_clips_lowest_strong{sx}" in summary)
              + (f"; of the sample's nominal pitch on {summary['objects_pitch_tuned_within_semitone'] * summary['objects_pitch_tuned_bars']:.0f}/"
                 f"{summary['objects_pitch_tuned_bars']} tuned bars" if "objects_pitch_tuned_bars" in summary else ""))
    if a.json_out:
        with open(a.json_out, "w") as f:
            json.dump({"summary": summary, "instruments": results, "objects": object_rows}, f, indent=1)


if __name__ == "__main__":
    main()
