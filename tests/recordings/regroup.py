"""Replays the extractor's grouping of features into partials under other rules (stop 46).

`struck features --json` lists each impact's partials (`features`) and their other members
(`components`). Their union is what `estimator::features::group_partials` grouped; this
script groups it again — most energetic first, each member joining the first group whose
leader it lies close to — under several rules, reports each group by its late slope (the
slowest member holding at least 10 % of the group's energy within the record, as the
extractor does), and scores the result as validate.py does (strong reference partials found
within 0.5 %, decays within 20 %). It is how `DOUBLET_DECAY_RATIO` was chosen; it reads the
references validate.py cached, so run validate.py first.

    python regroup.py [--struck PATH] [--cache DIR]

With `--envelope` each rule is scored twice more: each group reported by the slope of its
envelope (the energy-weighted least-squares line through ln |s(t)|, s the sum of its members
with their amplitudes and phases, from 10 ms after the strike to the end of the record;
members ten times slower than the late slope, a floor, left out; at least half the slowest
member's decay: `envelope_decay_per_s`, which the extractor reports since stop 47 but the
fits do not use), the same from t = 0, and the envelope only where the record (from 10 ms)
holds at least 2 or 5 periods of the group's slowest beat (its two closest members), the late
slope elsewhere: a partial whose members beat fewer times has an envelope slope that depends
on the strike's phase.

Rules (df: the two members' distance in Hz, T the record, bw the joining member's half-power
bandwidth d/2π when it decays faster than the leader, else 0):
  all-0.5%       df < 1/T, or df <= max(0.5 % of f, bw): the grouping before stop 46
  resolved-apart df < 1/T, or df <= bw: every pair the record resolves apart
  ratio R        as all-0.5%, except members that decay within R× of each other and are apart
                 by more than their bandwidths (d₁ + d₂)/2π stay apart (stop 46: R = 1.25)
"""

import argparse
import cmath
import json
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from validate import DECAY_TOL, FREQ_TOL, default_struck, load_manifest  # noqa: E402

LATE_SHARE = 0.1  # features::LATE_SHARE
ENVELOPE_START_S = 0.010  # features::ENVELOPE_START_S
FLOOR_DECAY_RATIO = 10.0  # features::FLOOR_DECAY_RATIO
ENVELOPE_MIN_SHARE = 0.5  # features::ENVELOPE_MIN_SHARE


def ratio_rule(r):
    def rule(df, lead, f, bw, res):
        dl, dff = lead["decay_per_s"], f["decay_per_s"]
        alike = max(dl, dff) <= r * min(dl, dff)
        apart = df > (dl + dff) / (2 * math.pi)
        return df < res or df <= bw or (df <= 0.005 * lead["freq_hz"] and not (alike and apart))
    return rule


RULES = [
    ("all-0.5%", lambda df, lead, f, bw, res: df < res or df <= max(0.005 * lead["freq_hz"], bw)),
    ("resolved-apart", lambda df, lead, f, bw, res: df < res or df <= bw),
    ("ratio 1.25", ratio_rule(1.25)),
    ("ratio 1.5", ratio_rule(1.5)),
    ("ratio 2", ratio_rule(2.0)),
]


def group(members, T, rule, envelope=False):
    res = 1.0 / T

    def energy(f):
        return f["amplitude"] ** 2 / (4 * max(f["decay_per_s"], 1e-9))

    def seen(f):
        d = max(f["decay_per_s"], 1e-9)
        return f["amplitude"] ** 2 * -math.expm1(-2 * d * T) / (4 * d)

    groups = []
    for f in sorted(members, key=energy, reverse=True):
        for g in groups:
            lead = g[0]
            df = abs(f["freq_hz"] - lead["freq_hz"])
            bw = f["decay_per_s"] / (2 * math.pi) if f["decay_per_s"] > lead["decay_per_s"] else 0.0
            if rule(df, lead, f, bw, res):
                g.append(f)
                break
        else:
            groups.append([f])
    partials = []
    for g in groups:
        total = sum(seen(f) for f in g)
        late = [f for f in g if seen(f) >= LATE_SHARE * total] or [g[0]]
        p = dict(min(late, key=lambda f: f["decay_per_s"]))
        if envelope:
            ring = [f for f in g if f["decay_per_s"] * FLOOR_DECAY_RATIO >= p["decay_per_s"]]
            floor = ENVELOPE_MIN_SHARE * min(f["decay_per_s"] for f in ring)
            for key, start in (("envelope", ENVELOPE_START_S), ("envelope_from_0", 0.0)):
                d = envelope_decay(ring, T, start)
                p[key] = max(d, floor) if d else p["decay_per_s"]
            # Only where the window holds at least k periods of the group's slowest beat
            # (its two closest members), else the late slope.
            fs = sorted(f["freq_hz"] for f in ring)
            beats = (T - min(ENVELOPE_START_S, 0.2 * T)) * min((b - a for a, b in zip(fs, fs[1:])), default=0.0)
            for k in (2, 5):
                p[f"envelope_{k}_beats"] = p["envelope"] if beats >= k else p["decay_per_s"]
        partials.append(p)
    return partials


def envelope_decay(members, T, start):
    """Slope of the energy-weighted LS line through ln|sum of members| over [start, T]
    (start at most a fifth of T), or None; members need `phase_rad`."""
    if len(members) < 2:
        return members[0]["decay_per_s"] if members else None
    t0 = min(start, 0.2 * T)
    fs = [f["freq_hz"] for f in members]
    step = min(1e-3, 1.0 / (8.0 * max(max(fs) - min(fs), 1e-9)))
    n = min(max(int(math.ceil((T - t0) / step)), 50), 20000)
    sw = swt = swtt = swy = swty = 0.0
    for i in range(n):
        t = t0 + (T - t0) * i / (n - 1)
        s = sum(f["amplitude"] * cmath.exp(complex(-f["decay_per_s"], 2 * math.pi * (f["freq_hz"] - fs[0])) * t
                                           + 1j * f.get("phase_rad", 0.0)) for f in members)
        w = abs(s) ** 2
        if w > 0:
            y = math.log(abs(s))
            sw, swt, swtt, swy, swty = sw + w, swt + w * t, swtt + w * t * t, swy + w * y, swty + w * t * y
    det = sw * swtt - swt * swt
    if sw <= 0 or det <= 1e-12 * sw * swtt:
        return None
    d = -(sw * swty - swt * swy) / det
    return d if d > 0 else None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--struck", default=default_struck())
    ap.add_argument("--cache", default=os.environ.get("STRUCK_REC_CACHE", "/work/rec-cache"))
    ap.add_argument("--envelope", action="store_true",
                    help="also score each rule with the partials' envelope slopes (from 10 ms and from 0)")
    a = ap.parse_args()
    variants = [(name, rule, key) for name, rule in RULES
                for key in (("decay_per_s", "envelope", "envelope_from_0", "envelope_2_beats", "envelope_5_beats")
                            if a.envelope else ("decay_per_s",))]
    manifest = load_manifest("regroup", a.cache, a.struck)
    clips = [c for c in manifest["clips"] if "wav" in c]
    # partials, found, decays, reliable, reliable decays
    score = {(name, key): [0, 0, 0, 0, 0] for name, _, key in variants}
    for c in clips:
        rpath = os.path.join(a.cache, "reference", f"{c['id']}.json")
        if not os.path.exists(rpath):
            sys.exit(f"regroup: no reference for {c['id']}: run validate.py first")
        with open(rpath) as f:
            ref = json.load(f)
        p = subprocess.run([a.struck, "features", os.path.join(a.cache, c["wav"]), "--json"],
                           capture_output=True, text=True)
        impacts = json.loads(p.stdout).get("impacts", []) if p.returncode == 0 else []
        imp = min(impacts, key=lambda i: abs(i.get("onset_s", 0) - ref["onset_s"])) if impacts else None
        members = imp["features"] + imp.get("components", []) if imp else []
        grouped = {name: group(members, imp["duration_s"], rule, a.envelope) if imp else [] for name, rule in RULES}
        for name, _, key in variants:
            parts = grouped[name]
            s = score[(name, key)]
            for rp in ref["partials"]:
                cands = [f for f in parts if abs(f["freq_hz"] - rp["freq_hz"]) <= FREQ_TOL * rp["freq_hz"]]
                best = max(cands, key=lambda f: f["amplitude"]) if cands else None
                ok = best is not None and abs(best[key] / rp["decay_per_s"] - 1) <= DECAY_TOL
                s[0] += 1
                s[1] += best is not None
                s[2] += ok
                s[3] += bool(rp["reliable"])
                s[4] += bool(rp["reliable"]) and ok
    print(f"{'rule':16s} {'decay':16s} {'found':>9s} {'decay<=20%':>11s} {'reliable':>9s}")
    for name, _, key in variants:
        n, found, ok, nr, okr = score[(name, key)]
        label = {"decay_per_s": "late slope", "envelope": "envelope", "envelope_from_0": "envelope from 0",
                 "envelope_2_beats": "env. >= 2 beats", "envelope_5_beats": "env. >= 5 beats"}[key]
        print(f"{name:16s} {label:16s} {found:4d}/{n:<4d} {ok:6d}/{n:<4d} {okr:4d}/{nr}")


if __name__ == "__main__":
    main()
