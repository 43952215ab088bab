#!/usr/bin/env python3
"""Scores the independent simulator's records (validation/independent/run.sh): per planted effect,
how often the loop added it (as the kinds that describe it), what else it added on that channel,
whether a rate ramp was kept or added, and on clean records every effect added (a false alarm).
Prints markdown. usage: score.py RUNS_DIR"""
import glob
import json
import os
import sys

# The kinds that describe each planted effect (a wandering line is a narrow band; a stationary one
# a sinusoid or a narrow band; a resonance inside the fit band a resonance, beyond it a band).
ACCEPT = {
    "wandering_line": {"narrowband", "sinusoid"},
    "line": {"sinusoid", "narrowband"},
    "resonance": {"resonance", "narrowband"},
    "gauss_markov": {"gauss_markov"},
    "drift_exp": {"drift"},
    "step": {"step"},
    "coupling": {"coupling"},
    "spikes": {"spikes"},
}


def channels(report):
    for a in report["files"][0].get("analysis") or []:
        loop = a.get("residual_loop") or {}
        kinds = [s["effect"]["kind"] for s in loop.get("steps", [])]
        ramp = (loop.get("ramp") or {}).get("action")
        r_kept = any(t["term"] == "rate_ramp" for t in a["combined"]["terms"])
        yield a["channel"], kinds, ramp, r_kept


def main(runs):
    rows = {}
    clean = {"records": 0, "channels": 0, "false": [], "ramps": 0}
    for kind in ("effects", "effects2", "clean"):
        for path in sorted(glob.glob(os.path.join(runs, f"{kind}_*.report.json"))):
            seed = path.rsplit("_", 1)[1].split(".")[0]
            report = json.load(open(path))
            truth = json.load(open(path.replace(".report.json", ".truth.json")))
            if kind == "clean":
                clean["records"] += 1
            for ch, kinds, ramp, r_kept in channels(report):
                if kind == "clean":
                    clean["channels"] += 1
                    clean["false"] += [f"{ch} {k} (seed {seed})" for k in kinds]
                    clean["ramps"] += int(r_kept)
                    continue
                planted = truth["effects"].get(ch, {}).get("type")
                if planted is None:
                    continue
                label = f"{kind}: {ch} {planted}"
                r = rows.setdefault(label, {"n": 0, "found": 0, "extra": {}, "ramp": 0})
                r["n"] += 1
                ok = ACCEPT[planted]
                r["found"] += int(any(k in ok for k in kinds))
                for k in kinds:
                    if k not in ok:
                        r["extra"][k] = r["extra"].get(k, 0) + 1
                r["ramp"] += int(r_kept)
    print("| planted effect | found | other effects added on the channel | R in the combined result |")
    print("|---|---|---|---|")
    for label, r in sorted(rows.items()):
        extra = ", ".join(f"{k} {v}" for k, v in sorted(r["extra"].items())) or "–"
        print(f"| {label} | {r['found']}/{r['n']} | {extra} | {r['ramp']}/{r['n']} |")
    print()
    print(
        f"Clean records: {clean['records']} ({clean['channels']} channels): "
        f"{len(clean['false'])} effects added ({'; '.join(clean['false']) or 'none'}), "
        f"R in {clean['ramps']} combined results."
    )


if __name__ == "__main__":
    main(sys.argv[1])
