#!/usr/bin/env python3
"""Chooses the visibility thresholds of online recognition on validation renders.

Reads `skimap eval ... --min_instance_score=0 --min_instance_fit=0 --max_view_conflict=1
--summary=FILE` summaries (every instance the reconciler keeps, with its score, score_scale,
fit, view_conflict and verdict), pools them, and prints precision, recall and F1 for every
combination of min_instance_score (the score needed is min_instance_score x score_scale),
min_instance_fit and max_view_conflict on a grid, best F1 first, with the plateau around the
best. Recall is over every truth of the summaries (instances are matched to truths one to
one before thresholds, so a threshold only removes instances).

  scripts/threshold_sweep.py VAL1.json [VAL2.json ...] [--top 15] [--min_precision P]

Only Python's standard library; docs/recognition.md ("Choosing thresholds").
"""
import argparse
import itertools
import json
import sys


def load(paths):
    dets, truths = [], 0
    for p in paths:
        with open(p) as f:
            s = json.load(f)
        truths += s["truths"]
        for d in s["multi_view"]["detections"]:
            if "score_scale" not in d:
                sys.exit(f"{p}: detections lack score_scale (an eval from before it existed)")
            dets.append((d["score"] / d["score_scale"], d["fit"], d["view_conflict"],
                         bool(d["true_positive"])))
    return dets, truths


def frange(lo, hi, step):
    out, v = [], lo
    while v <= hi + 1e-9:
        out.append(round(v, 4))
        v += step
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("summaries", nargs="+")
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--min_precision", type=float, default=0,
                    help="only combinations at least this precise (best recall among them)")
    a = ap.parse_args()
    dets, truths = load(a.summaries)
    if truths == 0:
        sys.exit("no truths in the summaries")
    scores = frange(0, 120, 4)
    fits = frange(0, 0.5, 0.05)
    conflicts = frange(0.02, 0.2, 0.02) + [1.0]
    rows = []
    for s, f, c in itertools.product(scores, fits, conflicts):
        kept = [tp for (sc, fi, vc, tp) in dets if sc >= s and fi >= f and vc <= c]
        tp = sum(kept)
        p = tp / len(kept) if kept else 0
        r = tp / truths
        f1 = 2 * p * r / (p + r) if p + r > 0 else 0
        rows.append((f1, p, r, s, f, c, len(kept), tp))
    if a.min_precision > 0:
        rows = [x for x in rows if x[1] >= a.min_precision]
        rows.sort(key=lambda x: (-x[2], -x[1]))
    else:
        rows.sort(key=lambda x: -x[0])
    print(f"{len(dets)} instances, {sum(d[3] for d in dets)} true, {truths} truths, "
          f"{len(a.summaries)} summaries")
    print("| F1 | precision | recall | min_instance_score | min_instance_fit | max_view_conflict "
          "| instances | true |\n|---|---|---|---|---|---|---|---|")
    for x in rows[: a.top]:
        print("| %.4f | %.3f | %.3f | %g | %g | %g | %d | %d |" % x)


if __name__ == "__main__":
    main()
