#!/usr/bin/env python3
"""Real sensor data (../shared/data/ycbv-0000, 10 YCB-Video frames): scripts/bop_split.py
makes a train split from the masked object pixels of frames 0,2,4,6,8 and a test scene of
the others; `skimap eval --train` (SIFT) against a real skimapd then recognises the objects
in the test frames. Environment: SKIMAP_CLI, SKIMAPD, BOP_SPLIT_SCRIPT, YCBV_DIR."""
import csv
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
import unittest

ENV = {k: os.environ[k] for k in ("SKIMAP_CLI", "SKIMAPD", "BOP_SPLIT_SCRIPT", "YCBV_DIR")}


def split(*args):
    return subprocess.run([sys.executable, ENV["BOP_SPLIT_SCRIPT"], *args], capture_output=True,
                          text=True, timeout=60)


class YcbvSplitTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="ycbv_split_test_")
        cls.out = os.path.join(cls.tmp.name, "ycbv")
        cls.made = split(ENV["YCBV_DIR"], "--scene=test/000000", "--train_frames=0,2,4,6,8",
                         f"--out={cls.out}")

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_split_holds_the_chosen_frames_on_each_side(self):
        self.assertEqual(self.made.returncode, 0, self.made.stderr)
        self.assertEqual(sorted(os.listdir(os.path.join(self.out, "train"))),
                         ["000008", "000014", "000021"])
        for obj in ("000008", "000014", "000021"):
            with open(os.path.join(self.out, "train", obj, "scene_gt.json")) as f:
                self.assertEqual(sorted(json.load(f), key=int), ["0", "2", "4", "6", "8"])
            self.assertTrue(os.path.islink(os.path.join(self.out, "train", obj, "mask_visib")))
        for name in ("scene_camera.json", "scene_gt.json", "scene_gt_info.json"):
            with open(os.path.join(self.out, "test", "000000", name)) as f:
                self.assertEqual(sorted(json.load(f), key=int), ["1", "3", "5", "7", "9"], name)
        self.assertTrue(os.path.exists(os.path.join(self.out, "camera.json")))

    def test_bad_arguments_are_named(self):
        bad = split(ENV["YCBV_DIR"], "--scene=test/000000", "--train_frames=0,42",
                    f"--out={self.tmp.name}/bad")
        self.assertEqual(bad.returncode, 2)
        self.assertIn("--train_frames: image ids 42", bad.stderr)
        everything = split(ENV["YCBV_DIR"], "--scene=test/000000",
                           "--train_frames=" + ",".join(map(str, range(10))),
                           f"--out={self.tmp.name}/bad")
        self.assertEqual(everything.returncode, 2)
        self.assertIn("at least one frame on each side", everything.stderr)
        missing = split(ENV["YCBV_DIR"], "--scene=test/nothing", "--train_frames=0",
                        f"--out={self.tmp.name}/bad")
        self.assertEqual(missing.returncode, 2)
        self.assertIn("--scene", missing.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.tmp.name, "bad", "test")))

    def test_eval_trains_and_recognises_on_real_frames(self):
        self.assertEqual(self.made.returncode, 0, self.made.stderr)
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            address = f"127.0.0.1:{s.getsockname()[1]}"
        server = subprocess.Popen(
            [ENV["SKIMAPD"], f"--address={address}", "--http_address=",
             f"--data_dir={self.tmp.name}/data"], stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL)
        try:
            deadline = time.time() + 60
            while subprocess.run([ENV["SKIMAP_CLI"], f"--server={address}", "health"],
                                 capture_output=True).returncode != 0:
                self.assertIsNone(server.poll(), "skimapd exited")
                self.assertLess(time.time(), deadline, "skimapd not healthy in 60 s")
                time.sleep(0.3)
            result_csv = os.path.join(self.tmp.name, "eval.csv")
            run = subprocess.run(
                [ENV["SKIMAP_CLI"], f"--server={address}", "eval", self.out, "--train",
                 "--detector=SIFT", "--resolution=0.01", f"--csv={result_csv}"],
                capture_output=True, text=True, timeout=900)
            self.assertEqual(run.returncode, 0, run.stderr)
        finally:
            server.terminate()
            server.wait(timeout=60)
        with open(result_csv) as f:
            rows = {int(r["obj_id"]): r for r in csv.DictReader(f)}
        self.assertEqual(sorted(rows), [8, 14, 21])
        # Measured 2026-11-26 (SIFT, default 100 classes): the gelatin box within 2.2 mm and
        # 0.5 deg, the foam brick within 1.9 mm and 1.2 deg, the plain red mug (65 training
        # descriptors) not found. Floors: both found at 3 cm / 10 deg, within 10 mm / 5 deg.
        for obj in (8, 21):
            self.assertEqual(rows[obj]["true_positive"], "1", rows[obj])
            self.assertLess(float(rows[obj]["translation_error_mm"]), 10, rows[obj])
            self.assertLess(float(rows[obj]["rotation_error_deg"]), 5, rows[obj])
        # No false instance: the table's totals row has precision 1.
        totals = [line for line in run.stdout.splitlines() if line.startswith("| all |")]
        self.assertEqual(len(totals), 1, run.stdout)
        self.assertEqual(totals[0].split("|")[6].strip(), "1.000", totals[0])


if __name__ == "__main__":
    unittest.main()
