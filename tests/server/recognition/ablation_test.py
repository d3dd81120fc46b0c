#!/usr/bin/env python3
"""scripts/ablation.py end to end: the sim `mini` preset rendered by skimap-sim, a small
one-factor grid run through `skimap eval` against the skimapd the script starts, and its
CSV, per-run summaries and PNG plots checked. Environment: SKIMAP_CLI, SKIMAPD, SKIMAP_SIM
(the binaries), ABLATION_SCRIPT (scripts/ablation.py)."""
import argparse
import csv
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import unittest

ENV = {k: os.environ[k] for k in ("SKIMAP_CLI", "SKIMAPD", "SKIMAP_SIM", "ABLATION_SCRIPT")}


def ablation(*args):
    return subprocess.run([sys.executable, ENV["ABLATION_SCRIPT"], *args,
                           f"--skimap={ENV['SKIMAP_CLI']}", f"--skimapd={ENV['SKIMAPD']}"],
                          capture_output=True, text=True, timeout=600)


class AblationTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="ablation_test_")
        cls.dataset = os.path.join(cls.tmp.name, "mini")
        subprocess.run([ENV["SKIMAP_SIM"], "--preset", "mini", "--quiet", "--out", cls.dataset],
                       check=True, timeout=600)
        cls.out = os.path.join(cls.tmp.name, "out")
        cls.grid = ["--detectors=ORB", "--base=ORB,100,24", "--classes=50,100", "--trees=8,24",
                    "--every=1,4", "--single_view"]
        cls.first = ablation(cls.dataset, f"--out={cls.out}", *cls.grid)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_grid_runs_one_factor_at_a_time(self):
        self.assertEqual(self.first.returncode, 0, self.first.stderr + self.first.stdout)
        with open(os.path.join(self.out, "ablation.csv")) as f:
            rows = {r["run"]: r for r in csv.DictReader(f)}
        # Base, classes 50, trees 8, every 4: the base configuration appears once.
        self.assertEqual(sorted(rows), ["ORB_c100_t24_e1", "ORB_c100_t24_e4",
                                        "ORB_c100_t8_e1", "ORB_c50_t24_e1"])
        self.assertEqual(int(rows["ORB_c100_t24_e1"]["frames"]), 100)
        self.assertEqual(int(rows["ORB_c100_t24_e4"]["frames"]), 25)  # every 4th of 100
        for name, r in rows.items():
            self.assertEqual(int(r["truths"]), 3, name)
            # Measured 2026-11-26: every run found all 3 objects (precision 0.75-1.0); the
            # floor allows one miss.
            self.assertGreaterEqual(int(r["true_positives"]), 2, name)
            self.assertAlmostEqual(float(r["recall"]), int(r["true_positives"]) / 3, 3)
            self.assertAlmostEqual(float(r["precision"]),
                                   int(r["true_positives"]) / int(r["instances"]), 3)
            self.assertGreater(float(r["frames_per_second"]), 0, name)

    def test_summaries_hold_each_instance_with_its_verdict(self):
        with open(os.path.join(self.out, "runs", "ORB_c100_t24_e1.json")) as f:
            s = json.load(f)
        m = s["multi_view"]
        self.assertEqual(len(m["detections"]), m["instances"])
        self.assertEqual(sum(d["true_positive"] for d in m["detections"]), m["true_positives"])
        self.assertTrue(all(d["score"] > 0 and d["scene"] == "000001" for d in m["detections"]))
        # Only the base run carries the single-view baseline.
        self.assertIn("single_view", s)
        with open(os.path.join(self.out, "runs", "ORB_c50_t24_e1.json")) as f:
            self.assertNotIn("single_view", json.load(f))

    def test_markdown_table_and_png_plots(self):
        with open(os.path.join(self.out, "ablation.md")) as f:
            self.assertEqual(len(f.read().splitlines()), 2 + 4)  # header, rule, one row per run
        for name in ("ablation_classes_per_object", "ablation_trees", "ablation_every",
                     "precision_recall"):
            with open(os.path.join(self.out, name + ".png"), "rb") as f:
                data = f.read()
            self.assertEqual(data[:8], b"\x89PNG\r\n\x1a\n", name)
            self.assertGreater(len(data), 10000, name)  # axes, lines and labels drawn
        # One detector: no detector plot.
        self.assertFalse(os.path.exists(os.path.join(self.out, "ablation_detector.png")))

    def test_resume_keeps_finished_runs(self):
        again = ablation(self.dataset, f"--out={self.out}", "--resume", *self.grid)
        self.assertEqual(again.returncode, 0, again.stderr)
        self.assertEqual(again.stdout.count(": kept "), 4, again.stdout)

    def test_two_detectors_get_a_detector_plot(self):
        # write_outputs alone on made-up summaries (no server): each detector's base run.
        spec = importlib.util.spec_from_file_location("ablation", ENV["ABLATION_SCRIPT"])
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        args = argparse.Namespace(dataset=self.dataset, detectors=["SIFT", "ORB"], classes=[300],
                                  trees=[24], every=[1], base=("SIFT", 300, 24), single_view=False)
        runs = module.plan(args)
        self.assertEqual([r[0] for r in runs], ["SIFT_c300_t24_e1", "ORB_c300_t24_e1"])
        detections = [{"scene": "000001", "obj_id": 1, "score": 200.0, "true_positive": True},
                      {"scene": "000001", "obj_id": 2, "score": 120.0, "true_positive": False}]
        summary = {"frames": 10, "frames_per_second": 5.0, "truths": 2,
                   "multi_view": {"instances": 2, "true_positives": 1, "precision": 0.5,
                                  "recall": 0.5, "ar_mssd": None, "detections": detections}}
        out = os.path.join(self.tmp.name, "two_detectors")
        os.makedirs(out)
        rows = module.write_outputs(args, runs, {r[0]: summary for r in runs}, out)
        self.assertEqual([r["detector"] for r in rows], ["SIFT", "ORB"])
        self.assertEqual(rows[0]["ar_mssd"], "")  # no models: no AR_MSSD
        with open(os.path.join(out, "ablation_detector.png"), "rb") as f:
            self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")
        # Precision-recall points: the 200-score instance alone (recall 0.5, precision 1),
        # then both (recall 0.5, precision 0.5).
        self.assertEqual(module.pr_curve(detections, 2), [(0.5, 1.0, 200.0), (0.5, 0.5, 120.0)])

    def test_bad_arguments_are_named(self):
        bad = ablation(self.dataset, f"--out={self.out}/bad", "--detectors=ORB",
                       "--base=SIFT,100,24")
        self.assertEqual(bad.returncode, 2)
        self.assertIn("--base", bad.stderr)
        missing = ablation(os.path.join(self.tmp.name, "nothing"), f"--out={self.out}/bad",
                           "--detectors=ORB", "--base=ORB,100,24", "--classes=100",
                           "--trees=24", "--every=1")
        self.assertEqual(missing.returncode, 1)
        self.assertIn("skimap eval failed", missing.stderr)


if __name__ == "__main__":
    unittest.main()
