#!/usr/bin/env python3
"""Ablations of online recognition like the paper's Fig. 10-11, through `skimap eval`.

Usage: scripts/ablation.py DATASET --out DIR [--detectors SIFT,ORB] [--classes 50,100,300]
           [--trees 6,12,24] [--every 1,2,4,8] [--base SIFT,300,24] [--scenes A,B]
           [--max_frames N] [--skimap PATH] [--skimapd PATH] [--resume]

One factor at a time around a base configuration (detector, classes per object, forest
trees; every frame streamed): the base run of each detector, then the classes per object,
the forest size and the frame rate (every n-th frame, i.e. fewer vantage points) varied
alone with the base detector. Every run is `skimap eval DATASET --train ... --summary`
against a skimapd this script starts per detector (loopback, a fresh data dir under
DIR/servers: an object database holds one detector's features), so runs never share a
database with another tool.

Writes DIR/runs/<run>.json (eval's summary), DIR/ablation.csv and DIR/ablation.md (one
row per run, the same table as CSV and Markdown) and the
plots DIR/ablation_<factor>.png (precision, recall and AR_MSSD against the factor, frames/s
beside) and DIR/precision_recall.png (each detector's base run swept over the minimum
instance score; the single-view baseline's too when it ran). --resume keeps runs whose
summary exists. Exit status 0 when every run succeeded.
"""
import argparse
import csv
import json
import os
import socket
import subprocess
import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after the backend choice)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def ints(text):
    return [int(v) for v in text.split(",") if v]


class Server:
    """A skimapd on a loopback port with its own data dir; stopped on exit."""

    def __init__(self, skimapd, skimap, data_dir, log_path):
        self.address = f"127.0.0.1:{free_port()}"
        os.makedirs(data_dir, exist_ok=True)
        self.log = open(log_path, "ab")
        self.proc = subprocess.Popen(
            [skimapd, f"--address={self.address}", "--http_address=", f"--data_dir={data_dir}"],
            stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.time() + 60
        while True:
            if self.proc.poll() is not None:
                raise RuntimeError(f"skimapd exited ({self.proc.returncode}); see {log_path}")
            probe = subprocess.run([skimap, f"--server={self.address}", "health"],
                                   capture_output=True)
            if probe.returncode == 0:
                return
            if time.time() > deadline:
                self.stop()
                raise RuntimeError(f"skimapd at {self.address} not healthy within 60 s")
            time.sleep(0.3)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()


def plan(args):
    """(name, detector, classes, trees, every, single_view) of every run, base runs first."""
    base_detector, base_classes, base_trees = args.base
    runs = []

    def add(detector, classes, trees, every):
        name = f"{detector}_c{classes}_t{trees}_e{every}"
        if all(r[0] != name for r in runs):
            base = (classes, trees, every) == (base_classes, base_trees, 1)
            runs.append((name, detector, classes, trees, every, base and args.single_view))

    for d in args.detectors:
        add(d, base_classes, base_trees, 1)
    for c in args.classes:
        add(base_detector, c, base_trees, 1)
    for t in args.trees:
        add(base_detector, base_classes, t, 1)
    for e in args.every:
        add(base_detector, base_classes, base_trees, e)
    return runs


def run_eval(args, server, run, out):
    name, detector, classes, trees, every, single_view = run
    summary = os.path.join(out, "runs", name + ".json")
    if args.resume and os.path.exists(summary):
        print(f"{name}: kept {summary}", flush=True)
        return summary
    cmd = [args.skimap, f"--server={server.address}", "eval", args.dataset, "--train",
           f"--detector={detector}", f"--classes_per_object={classes}", f"--trees={trees}",
           f"--every={every}", f"--single_view={'true' if single_view else 'false'}",
           f"--summary={summary}.part"]
    if args.scenes:
        cmd.append(f"--scenes={args.scenes}")
    if args.max_frames:
        cmd.append(f"--max_frames={args.max_frames}")
    print(f"{name}: {' '.join(cmd)}", flush=True)
    started = time.time()
    with open(os.path.join(out, "runs", name + ".log"), "w") as log:
        result = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT)
    if result.returncode != 0:
        log_path = os.path.join(out, "runs", name + ".log")
        with open(log_path) as log:
            last = (log.read().strip().splitlines() or [""])[-1]
        raise RuntimeError(f"{name}: skimap eval failed ({result.returncode}): {last} "
                           f"(log: {log_path})")
    os.replace(summary + ".part", summary)
    print(f"{name}: done in {time.time() - started:.0f} s", flush=True)
    return summary


def pr_curve(detections, truths):
    """(recall, precision) points of the instances at each minimum score, highest first."""
    points = []
    tp = 0
    ranked = sorted(detections, key=lambda d: -d["score"])
    for k, d in enumerate(ranked, 1):
        tp += d["true_positive"]
        if k == len(ranked) or ranked[k]["score"] != d["score"]:
            points.append((tp / truths if truths else 0, tp / k, d["score"]))
    return points


def write_outputs(args, runs, summaries, out):
    rows = []
    for run in runs:
        name, detector, classes, trees, every, _ = run
        s = summaries[name]
        m = s["multi_view"]
        rows.append({"run": name, "detector": detector, "classes_per_object": classes,
                     "trees": trees, "every": every, "frames": s["frames"],
                     "frames_per_second": round(s["frames_per_second"], 2),
                     "truths": s["truths"], "instances": m["instances"],
                     "true_positives": m["true_positives"],
                     "precision": round(m["precision"], 4), "recall": round(m["recall"], 4),
                     "ar_mssd": "" if m["ar_mssd"] is None else round(m["ar_mssd"], 4)})
    with open(os.path.join(out, "ablation.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)
    with open(os.path.join(out, "ablation.md"), "w") as f:
        f.write("| " + " | ".join(rows[0].keys()) + " |\n")
        f.write("|" + "---|" * len(rows[0]) + "\n")
        for r in rows:
            f.write("| " + " | ".join(str(v) for v in r.values()) + " |\n")

    base_detector, base_classes, base_trees = args.base
    factors = [("classes_per_object", "classes per object", args.classes,
                lambda r: r["detector"] == base_detector and r["trees"] == base_trees
                and r["every"] == 1),
               ("trees", "forest trees", args.trees,
                lambda r: r["detector"] == base_detector
                and r["classes_per_object"] == base_classes and r["every"] == 1),
               ("every", "every n-th frame streamed", args.every,
                lambda r: r["detector"] == base_detector
                and r["classes_per_object"] == base_classes and r["trees"] == base_trees),
               ("detector", "detector", args.detectors,
                lambda r: r["classes_per_object"] == base_classes and r["trees"] == base_trees
                and r["every"] == 1)]
    for key, label, values, keep in factors:
        if len(values) < 2:
            continue
        chosen = sorted((r for r in rows if keep(r) and r[key] in values),
                        key=lambda r: values.index(r[key]))
        x = list(range(len(chosen))) if key == "detector" else [r[key] for r in chosen]
        fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=100)
        series = [("precision", "o-"), ("recall", "s-")]
        if all(r["ar_mssd"] != "" for r in chosen):
            series.append(("ar_mssd", "^-"))
        for k, (name, style) in enumerate(series):
            legend = "AR_MSSD" if name == "ar_mssd" else name
            values = [r[name] for r in chosen]
            if key == "detector":  # categories: grouped bars
                ax.bar([v + (k - 1) * 0.25 for v in x], values, width=0.25, label=legend)
            else:
                ax.plot(x, values, style, label=legend)
        ax.set_ylim(0, 1.05)
        ax.set_xlabel(label)
        ax.set_ylabel("score (3 cm / 10°)")
        if key == "detector":
            ax.set_xticks(x, [r["detector"] for r in chosen])
        else:
            ax.set_xticks(x)
        ax.grid(alpha=0.3)
        fps = ax.twinx()
        fps.plot(x, [r["frames_per_second"] for r in chosen], "kD" if key == "detector" else "k--",
                 alpha=0.5, label="frames/s")
        fps.set_ylabel("frames/s (whole pipeline)")
        fps.set_ylim(0, max(r["frames_per_second"] for r in chosen) * 1.2 or 1)
        lines = ax.get_legend_handles_labels()
        more = fps.get_legend_handles_labels()
        ax.legend(lines[0] + more[0], lines[1] + more[1], loc="lower right", fontsize=8)
        ax.set_title(f"{os.path.basename(os.path.normpath(args.dataset))}: {label}")
        fig.tight_layout()
        fig.savefig(os.path.join(out, f"ablation_{key}.png"))
        plt.close(fig)

    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=100)
    for run in runs:
        name, detector, classes, trees, every, single_view = run
        if (classes, trees, every) != (base_classes, base_trees, 1):
            continue
        s = summaries[name]
        curves = [("map", s["multi_view"])]
        if single_view and "single_view" in s:
            curves.append(("single view", s["single_view"]))
        for label, method in curves:
            pts = pr_curve(method["detections"], s["truths"])
            if pts:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], ".-",
                        label=f"{detector} {label}")
    ax.set_xlim(0, 1.02)
    ax.set_ylim(0, 1.05)
    ax.set_xlabel("recall")
    ax.set_ylabel("precision")
    ax.set_title("over the minimum instance score (3 cm / 10°)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "precision_recall.png"))
    plt.close(fig)
    return rows


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("dataset")
    p.add_argument("--out", required=True)
    p.add_argument("--detectors", default="SIFT,ORB")
    p.add_argument("--classes", default="50,100,200,300")
    p.add_argument("--trees", default="6,12,24")
    p.add_argument("--every", default="1,2,4,8")
    p.add_argument("--base", default="SIFT,300,24", help="detector,classes,trees")
    p.add_argument("--scenes", default="")
    p.add_argument("--max_frames", type=int, default=0)
    p.add_argument("--single_view", action="store_true",
                   help="also run the single-view baseline in each detector's base run")
    p.add_argument("--skimap", default=os.path.join(ROOT, "build/release/client/skimap"))
    p.add_argument("--skimapd", default=os.path.join(ROOT, "build/release/server/skimapd"))
    p.add_argument("--resume", action="store_true")
    args = p.parse_args()
    args.detectors = [d for d in args.detectors.split(",") if d]
    args.classes, args.trees, args.every = ints(args.classes), ints(args.trees), ints(args.every)
    base = args.base.split(",")
    if len(base) != 3:
        p.error("--base must be DETECTOR,CLASSES,TREES")
    args.base = (base[0], int(base[1]), int(base[2]))
    if args.base[0] not in args.detectors:
        p.error("--base's detector must be one of --detectors")
    for name in ("skimap", "skimapd"):
        if not os.access(getattr(args, name), os.X_OK):
            p.error(f"--{name}: {getattr(args, name)} is not an executable")

    out = os.path.abspath(args.out)
    os.makedirs(os.path.join(out, "runs"), exist_ok=True)
    runs = plan(args)
    summaries = {}
    for detector in args.detectors:
        mine = [r for r in runs if r[1] == detector]
        if args.resume and all(os.path.exists(os.path.join(out, "runs", r[0] + ".json"))
                               for r in mine):
            server = None
        else:
            data_dir = os.path.join(out, "servers", detector)
            server = Server(args.skimapd, args.skimap, data_dir,
                            os.path.join(out, "servers", detector + ".log"))
        try:
            for run in mine:
                path = run_eval(args, server, run, out)
                with open(path) as f:
                    summaries[run[0]] = json.load(f)
        finally:
            if server:
                server.stop()
    rows = write_outputs(args, runs, summaries, out)
    for r in rows:
        print(f"{r['run']}: precision {r['precision']:.3f} recall {r['recall']:.3f} "
              f"AR_MSSD {r['ar_mssd']} {r['frames_per_second']:.1f} frames/s")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except RuntimeError as e:
        print(f"ablation: {e}", file=sys.stderr)
        sys.exit(1)
