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

Rules (df: the two members' distance in Hz, T the record, bw the joining member's half-power
bandwidth d/2π when it decays faster than the leader, else 0):
  all-0.5%       df < 1/T, or df <= max(0.5 % of f, bw): the grouping before stop 46
  resolved-apart df < 1/T, or df <= bw: every pair the record resolves apart
  ratio R        as all-0.5%, except members that decay within R× of each other and are apart
                 by more than their bandwidths (d₁ + d₂)/2π stay apart (stop 46: R = 1.25)
"""

import argparse
import json
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from validate import DECAY_TOL, FREQ_TOL, default_struck, load_manifest  # noqa: E402

LATE_SHARE = 0.1  # features::LATE_SHARE


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


def group(members, T, rule):
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
        partials.append(min(late, key=lambda f: f["decay_per_s"]))
    return partials


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--struck", default=default_struck())
    ap.add_argument("--cache", default=os.environ.get("STRUCK_REC_CACHE", "/work/rec-cache"))
    a = ap.parse_args()
    manifest = load_manifest("regroup", a.cache, a.struck)
    clips = [c for c in manifest["clips"] if "wav" in c]
    score = {name: [0, 0, 0, 0, 0] for name, _ in RULES}  # partials, found, decays, reliable, reliable decays
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
        for name, rule in RULES:
            parts = group(imp["features"] + imp.get("components", []), imp["duration_s"], rule) if imp else []
            s = score[name]
            for rp in ref["partials"]:
                cands = [f for f in parts if abs(f["freq_hz"] - rp["freq_hz"]) <= FREQ_TOL * rp["freq_hz"]]
                best = max(cands, key=lambda f: f["amplitude"]) if cands else None
                ok = best is not None and abs(best["decay_per_s"] / rp["decay_per_s"] - 1) <= DECAY_TOL
                s[0] += 1
                s[1] += best is not None
                s[2] += ok
                s[3] += bool(rp["reliable"])
                s[4] += bool(rp["reliable"]) and ok
    print(f"{'rule':16s} {'found':>9s} {'decay<=20%':>11s} {'reliable':>9s}")
    for name, _ in RULES:
        n, found, ok, nr, okr = score[name]
        print(f"{name:16s} {found:4d}/{n:<4d} {ok:6d}/{n:<4d} {okr:4d}/{nr}")


if __name__ == "__main__":
    main()
